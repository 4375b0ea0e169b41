"""A removal on a capture without ground truth, scored by what can be measured without object-free
photos (:mod:`inpaint360gs.metrics.capture`; docs/architecture.md, "Real captures"):

* PSNR against the photos outside the removed object's footprint grown by 15 px, for the 3DGS, the
  removed and the inpainted model, on the training and the held-out views: the inpainting must not
  change what the photos explain;
* inside the footprint column (the object's centres projected onto the support plane fitted
  around it): the opacity-weighted share of Gaussians standing higher above the plane than 10 %
  of the object's height, after removal and after inpainting: nothing may be left standing;
* the fill's texture at the training cameras: mean |Laplacian| of the luminance inside the
  footprint over that of a 20-px ring around it, and the mean luminance inside over the ring's;
* stage wall times from ``OUT/run.json``.

It reads a run folder of ``inpaint360gs run`` (``3dgs/``, ``distill/``, ``removed/``,
``inpainted/``) and its scene, and renders every model at the training and held-out cameras:

    python benchmarks/bench_capture.py data/kitchen outputs/kitchen --resize 4
    python benchmarks/bench_capture.py data/kitchen outputs/kitchen --resize 4 --figure docs/images/kitchen_removal.jpg --figure-views IMG_03,IMG_12,IMG_19

``--figure`` writes rows before / removed / inpainted at the named training views. Works on
synthetic scenes too (their ``test_`` views are not read).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

TARGETS = {"outside_drop_db": 0.2, "standing": 0.02, "laplacian": 0.7, "luminance": 0.15}


def _resize_of(run: Path) -> int | None:
    p = run / "distill" / "distill.json"
    if p.is_file():
        r = json.loads(p.read_text()).get("inputs", {}).get("resize")
        return int(r) if r else None
    return None


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", type=Path)
    ap.add_argument("run", type=Path, help="OUT of inpaint360gs run")
    ap.add_argument("--resize", type=int, default=None, help="the run's --resize (default: what distill.json records)")
    ap.add_argument("--grow", type=int, default=15, help="footprint margin of the outside PSNR, pixels")
    ap.add_argument("--ring", type=int, default=20, help="ring width of the texture ratios, pixels")
    ap.add_argument("--json", type=Path, default=None, help="also write the numbers here")
    ap.add_argument("--figure", type=Path, default=None, help="before / removed / inpainted at --figure-views")
    ap.add_argument("--figure-views", default="", help="comma-separated training view names or stems (default: 3 spread views)")
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args()

    import torch

    from inpaint360gs.cli.common import set_threads
    from inpaint360gs.io.ply import read_ply
    from inpaint360gs.io.scene import load_scene
    from inpaint360gs.core.support import object_footprint
    from inpaint360gs.metrics.capture import psnr_outside, standing_share, texture_ratios
    from inpaint360gs.remove.removal import fill_masks
    from inpaint360gs.render.api import render
    from inpaint360gs.segment.frame import camera_up

    set_threads(args.threads)
    run = args.run
    resize = args.resize or _resize_of(run) or 1
    scene = load_scene(args.scene, resize=resize, load_masks=False, unregistered="warn")
    distilled = read_ply(run / "distill" / "point_cloud.ply")
    index = np.load(run / "removed" / "removed_index.npy")
    removed_flag = torch.zeros(len(distilled), dtype=torch.bool)
    removed_flag[torch.from_numpy(index.astype(np.int64))] = True
    models = {"3dgs": read_ply(run / "3dgs" / "point_cloud.ply"), "removed": read_ply(run / "removed" / "point_cloud.ply")}
    if (run / "inpainted" / "point_cloud.ply").is_file():
        models["inpainted"] = read_ply(run / "inpainted" / "point_cloud.ply")

    views = {"train": scene.train_views, "held-out": scene.holdout_views}
    all_views = views["train"] + views["held-out"]
    footprints = fill_masks(distilled, removed_flag, all_views)
    out: dict = {"scene": str(args.scene), "run": str(run), "resize": resize, "psnr_outside": {}, "texture": {}, "standing": {}}
    renders: dict[str, dict[str, np.ndarray]] = {k: {} for k in models}
    with torch.no_grad():
        for split, vs in views.items():
            for name, g in models.items():
                vals = []
                for v in vs:
                    img = render(g, v.camera).color.clamp(0, 1).numpy()
                    renders[name][v.name] = img
                    vals.append(psnr_outside(img, scene.load_image(v).numpy(), footprints[v.name], args.grow))
                out["psnr_outside"].setdefault(split, {})[name] = float(np.nanmean(vals)) if vals else float("nan")
    for name in models:
        if name == "3dgs":
            continue
        lap, lum = [], []
        for v in views["train"]:
            r = texture_ratios(renders[name][v.name], footprints[v.name], args.ring)
            if r is not None:
                lap.append(r.laplacian)
                lum.append(r.luminance)
        out["texture"][name] = {"laplacian": float(np.nanmean(lap)) if lap else None, "luminance": float(np.nanmean(lum)) if lum else None, "views": len(lap)}

    g = distilled
    means = g.means.detach().double().numpy()
    opac = g.opacities.detach().double().numpy()
    rm = removed_flag.numpy()
    fp = object_footprint(means[rm], opac[rm], means[~rm], opac[~rm], camera_up([v.camera for v in scene.train_views]))
    out["object_height"] = fp.height
    for name in ("removed", "inpainted"):
        if name in models:
            m = models[name]
            share, count = standing_share(m.means.detach().double().numpy(), m.opacities.detach().double().numpy(), fp)
            out["standing"][name] = {"share": share, "count": count}

    rec = run / "run.json"
    if rec.is_file():
        out["seconds"] = json.loads(rec.read_text()).get("seconds", {})
    ip = run / "inpainted" / "inpaint.json"
    if ip.is_file():
        out["inpaint_seconds"] = json.loads(ip.read_text()).get("seconds", {})

    _print(out)
    if args.json:
        args.json.write_text(json.dumps(out, indent=1) + "\n")
    if args.figure:
        _figure(args, scene, models, renders, out)
    return 0


def _print(out: dict) -> None:
    p = out["psnr_outside"]
    print(f"{out['scene']} (run {out['run']}, resize {out['resize']})")
    print("PSNR outside the footprint grown by the margin (dB), mean over views:")
    print(f"  {'split':10s} {'3dgs':>8s} {'removed':>8s} {'inpainted':>10s} {'inp-rem':>8s}")
    for split, row in p.items():
        inp = row.get("inpainted", float("nan"))
        print(f"  {split:10s} {row['3dgs']:8.2f} {row['removed']:8.2f} {inp:10.2f} {inp - row['removed']:+8.2f}   (target >= -{TARGETS['outside_drop_db']})")
    print(f"Standing in the footprint column (> 10% of the object's height {out['object_height']:.4f} above the support), opacity-weighted:")
    for name, s in out["standing"].items():
        print(f"  {name:10s} {100 * s['share']:6.2f} %  ({s['count']} Gaussians)   (target <= {100 * TARGETS['standing']:.0f} %)")
    print("Fill texture at the training cameras, inside the footprint / ring:")
    for name, t in out["texture"].items():
        lap = "n/a" if t["laplacian"] is None else f"{t['laplacian']:.2f}"
        lum = "n/a" if t["luminance"] is None else f"{t['luminance']:.2f}"
        print(f"  {name:10s} |Laplacian| {lap:>5s} (target >= {TARGETS['laplacian']})   luminance {lum:>5s} (target 1 +- {TARGETS['luminance']})   over {t['views']} views")
    if out.get("seconds"):
        print("Stage wall times (s): " + ", ".join(f"{k} {v:.0f}" for k, v in out["seconds"].items()))
    if out.get("inpaint_seconds"):
        print("Inpainting parts (s): " + ", ".join(f"{k} {v:.0f}" for k, v in out["inpaint_seconds"].items()))


def _figure(args, scene, models, renders, out) -> None:
    from PIL import Image

    from inpaint360gs.io.atomic import atomic_path

    names = [s for s in args.figure_views.split(",") if s]
    train = scene.train_views
    picked = [scene.view(n) for n in names] if names else [train[i] for i in np.linspace(0, len(train) - 1, 3).round().astype(int)]
    rows = []
    for key in ("3dgs", "removed", "inpainted"):
        if key in renders:
            rows.append(np.concatenate([renders[key][v.name] for v in picked], axis=1))
    grid = np.concatenate(rows, axis=0)
    with atomic_path(args.figure) as tmp:
        Image.fromarray((grid * 255 + 0.5).astype(np.uint8)).save(tmp, format="JPEG" if args.figure.suffix.lower() in (".jpg", ".jpeg") else "PNG", quality=90)
    print(f"{args.figure}: rows = 3DGS with the object, after removal, after inpainting; views {[v.name for v in picked]}")


if __name__ == "__main__":
    sys.exit(main())
