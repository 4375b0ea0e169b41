"""Inpainting after removal on the embedded benchmark (paper Sec. 3.4-3.5, Tab. 1 and 3): the full
method against the two naive baselines and with each ablation switch b)-e) turned off alone, plus
multi-view consistency and stage times.

It reads what the workflow wrote (``make benchmark``: ``OUT/<scene>/seed<k>/<segmenter>/eval/<method>.json``
from ``inpaint360gs evaluate``, ``OUT/<scene>/seed<k>/<segmenter>/methods/<method>/inpaint.json`` from
``inpaint360gs inpaint``), so every number comes from the stages as users run them; scenes where a
method is missing are listed and left out of every average (all averages cover the same scenes).

Printed:

* per scene and on average: ``roi_psnr``, ``roi_lpips``, ``masked_psnr``, ``masked_lpips`` (and
  full-image PSNR/LPIPS) of every method (metric conventions: docs/guide.md, "Metrics");
* checks: the full method beats (i) ``removal_only`` and (ii) ``per_view_2d`` on average on each of
  the four; each of ``abl_b`` .. ``abl_e`` is worse than ``full`` on average in ``roi_lpips`` or
  ``roi_psnr`` (``abl_a`` changes the association, measured by ``bench_object_field.py``, and is
  listed too);
* geometry of the fill (``--data``): each model rendered at the ``test_`` cameras, its depth inside
  the unseen mask against the generator's object-free depth (``gt/depth``): median relative error,
  share of mask pixels off the true surface by more than 5%, share left empty (alpha < 0.5). The
  colour metrics cannot tell whether the filled region has the right shape; this can (ablation b);
  and the texture of the fill: mean |Laplacian| of the rendered grey image inside the unseen mask
  eroded by one pixel (a blurred fill scores low, the ground truth's value is listed too). PSNR
  rewards a blur over texture that is plausible but shifted; this column shows which one a method drew;
* multi-view consistency: the photometric error between adjacent virtual views of the 2D inpainting,
  reprojected through the inpainted depth inside the filled region (``reprojection_error`` of
  ``inpaint.json``), with recursive conditioning (``full``) and without (``abl_d``);
* seconds of the inpainting stage per scene and part (virtual views, masks, 2D, 3D), and the whole
  pipeline's stage times from the workflow's ``benchmark:`` files.

    python benchmarks/bench_inpaint.py --out outputs [--data data/synthetic] [--segmenter geometric] [--seed 0] [--scenes cone toys]

Each comparison is averaged over the scenes that have both of its runs (the ablations run on a
subset of scenes; the baselines on every scene), and the printed lines name those scenes.
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

METHODS = ["full", "removal_only", "per_view_2d", "abl_a", "abl_b", "abl_c", "abl_d", "abl_e"]
METRICS = [("roi_psnr", +1), ("roi_lpips", -1), ("masked_psnr", +1), ("masked_lpips", -1), ("psnr", +1), ("lpips", -1)]
STAGES = ["train_3dgs", "segment", "associate", "distill", "remove", "inpaint", "evaluate"]


def read_json(path: Path) -> dict | None:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None


def bench_seconds(path: Path) -> float | None:
    """Mean wall seconds of a Snakemake benchmark file (None when it is missing or unreadable)."""
    from inpaint360gs.core.errors import InputError
    from inpaint360gs.report.records import read_benchmark

    try:
        return read_benchmark(path)["seconds"]
    except InputError:
        return None


def fmt(v, nd=3) -> str:
    return "—" if v is None or (isinstance(v, float) and not math.isfinite(v)) else f"{v:.{nd}f}"


def model_of(out: Path, scene: str, segmenter: str, method: str) -> Path:
    if method == "removal_only":
        return out / scene / segmenter / "kom" / "removed" / "point_cloud.ply"
    return out / scene / segmenter / "methods" / method / "point_cloud.ply"


def fill_geometry(args, scenes: list[str]) -> None:
    """Depth of each model inside the test views' unseen masks vs the object-free ground truth."""
    import cv2
    import numpy as np
    import torch

    from inpaint360gs.cli.common import set_threads
    from inpaint360gs.io.ply import read_ply
    from inpaint360gs.io.scene import load_scene
    from inpaint360gs.render.api import render
    from inpaint360gs.views.unseen import normalised_depth

    set_threads(args.threads)  # also makes torch's first multi-threaded vector-math call reproducible
    print("\nGeometry of the fill at the test_ cameras (inside the unseen mask, vs gt/depth without the objects):")
    print("| scene | method | median relative depth error | pixels off by > 5% | pixels left empty | texture: mean abs Laplacian |\n|---|---|---|---|---|---|")
    kernel = np.ones((3, 3), np.uint8)

    def texture(rgb: np.ndarray, mask: np.ndarray) -> float | None:
        inner = cv2.erode(mask.astype(np.uint8), kernel) > 0  # no mask-edge step in the Laplacian
        if not inner.any():
            return None
        grey = cv2.cvtColor(np.ascontiguousarray(rgb, dtype=np.float32), cv2.COLOR_RGB2GRAY)
        return float(np.abs(cv2.Laplacian(grey, cv2.CV_32F))[inner].mean())

    def mean_of(vals):
        vals = [x for x in vals if x is not None]
        return float(np.mean(vals)) if vals else None

    for s in scenes:
        scene_dir = args.data / s
        scene = load_scene(scene_dir, load_masks=["unseen_mask"])
        gt_tex = mean_of(texture(scene.load_image(v, allow_test=True).numpy(), scene.load_mask(v)) for v in scene.test_views)
        print(f"| {s} | ground truth | — | — | — | {fmt(gt_tex, 4)} |")
        for m in ("full", "abl_b", "per_view_2d", "removal_only"):
            ply = model_of(args.out, s, args.run, m)
            if not ply.is_file():
                continue
            g = read_ply(ply)
            errs, empty, total, tex = [], 0, 0, []
            for v in scene.test_views:
                mask = scene.load_mask(v)
                gt = np.load(scene_dir / "gt" / "depth" / f"{v.stem}.npy")
                with torch.no_grad():
                    o = render(g, v.camera)
                d, a = normalised_depth(o).numpy(), o.alpha.numpy()
                tex.append(texture(o.color.clamp(0, 1).numpy(), mask))
                solid = mask & (a >= 0.5) & np.isfinite(gt) & (gt > 0)
                errs.append(np.abs(d[solid] - gt[solid]) / gt[solid])
                empty += int((mask & (a < 0.5)).sum())
                total += int(mask.sum())
            e = np.concatenate(errs) if errs else np.zeros(0)
            med = float(np.median(e)) if e.size else float("nan")
            off = 100.0 * float((e > 0.05).sum()) / max(total, 1)
            print(f"| {s} | {m} | {fmt(med, 4)} | {off:.1f}% | {100.0 * empty / max(total, 1):.1f}% | {fmt(mean_of(tex), 4)} |")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, required=True, help="the workflow's out_dir")
    ap.add_argument("--segmenter", default="geometric")
    ap.add_argument("--seed", type=int, default=0, help="which of the workflow's seeds (its outputs sit under OUT/<scene>/seed<k>/)")
    ap.add_argument("--scenes", nargs="*", default=None, help="default: every scene with results")
    ap.add_argument("--data", type=Path, default=None, help="synthetic scenes folder: also measure the fill's geometry against gt/depth")
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args()
    args.run = f"seed{args.seed}/{args.segmenter}"  # a run's folder under OUT/<scene>/ (and OUT/benchmarks/<scene>/)

    scenes = args.scenes or sorted(p.parent.parent.parent.name for p in args.out.glob(f"*/{args.run}/eval"))
    ev = {s: {m: read_json(args.out / s / args.run / "eval" / f"{m}.json") for m in METHODS} for s in scenes}
    present = [m for m in METHODS if any(ev[s][m] for s in scenes)]
    print(f"segmenter {args.segmenter}, seed {args.seed}; methods {present}; scenes {scenes}")

    def val(s, m, k):
        e = ev[s][m]
        v = None if e is None else e["mean"].get(k)
        return None if v is None else float(v)

    def having(*methods) -> list[str]:
        return [s for s in scenes if all(ev[s][m] for m in methods)]

    def mean(m, k, over):
        return sum(val(s, m, k) for s in over) / len(over)

    head = "| scene | method | " + " | ".join(k for k, _ in METRICS) + " |"
    print("\n" + head + "\n|" + "---|" * (len(METRICS) + 2))
    for s in scenes:
        for m in present:
            if ev[s][m]:
                print(f"| {s} | {m} | " + " | ".join(fmt(val(s, m, k)) for k, _ in METRICS) + " |")
    tab1 = having("full", "removal_only", "per_view_2d")
    for label, over, methods in (("average, Tab. 1 methods", tab1, ["full", "removal_only", "per_view_2d"]),
                                 ("average, ablation scenes", having(*present), present)):  # fmt: skip
        if over:
            for m in methods:
                print(f"| {label} ({len(over)}) | {m} | " + " | ".join(fmt(mean(m, k, over)) for k, _ in METRICS) + " |")
    if "full" not in present:
        return 1

    def better(a, b, sign):
        return sign * (a - b) > 0

    print("\nChecks on averages:")
    for base in ("removal_only", "per_view_2d"):
        over = having("full", base)
        if base in present and over:
            res = {k: (mean("full", k, over), mean(base, k, over), sg) for k, sg in METRICS[:4]}
            print(f"- full beats {base} over {len(over)} scene(s) {over}: "
                  + ", ".join(f"{k} {'yes' if better(a, b, sg) else 'NO'} ({fmt(a)} vs {fmt(b)})" for k, (a, b, sg) in res.items()))  # fmt: skip
    for ab in ("abl_a", "abl_b", "abl_c", "abl_d", "abl_e"):
        over = having("full", ab)
        if ab in present and over:
            f = {k: mean("full", k, over) for k, _ in METRICS[:2]}
            a = {k: mean(ab, k, over) for k, _ in METRICS[:2]}
            worse = any(better(f[k], a[k], sg) for k, sg in METRICS[:2])
            print(f"- {ab} worse than full in roi_lpips or roi_psnr over {over}: {'yes' if worse else 'NO'} "
                  f"(roi_psnr {fmt(a['roi_psnr'])} vs {fmt(f['roi_psnr'])}, roi_lpips {fmt(a['roi_lpips'])} vs {fmt(f['roi_lpips'])})")  # fmt: skip
    complete = having("full")
    if args.data is not None:
        fill_geometry(args, complete)

    print("\nMulti-view consistency of the 2D inpainting (reprojection error between adjacent virtual views, filled region):")
    print("| scene | with conditioning (full) | without (abl_d) | share of pixels filled from earlier views |\n|---|---|---|---|")
    complete = having("full", "abl_d")
    for s in complete:
        rec = {m: read_json(args.out / s / args.run / "methods" / m / "inpaint.json") for m in ("full", "abl_d")}
        e = {m: (r or {}).get("reprojection_error") for m, r in rec.items()}
        print(f"| {s} | {fmt(e['full'], 4)} | {fmt(e['abl_d'], 4)} | {fmt((rec['full'] or {}).get('filled_from_earlier_views'), 3)} |")

    complete = having("full")
    print("\nInpainting stage seconds (inpaint.json of `full`):")
    parts = ["visibility_s", "cameras_s", "occluders_s", "unseen_masks_s", "inpaint_2d_s", "init_s", "refine_3d_s", "total_s"]
    print("| scene | " + " | ".join(parts) + " |\n|" + "---|" * (len(parts) + 1))
    for s in complete:
        r = read_json(args.out / s / args.run / "methods" / "full" / "inpaint.json") or {}
        sec = r.get("seconds", {})
        print(f"| {s} | " + " | ".join(fmt(sec.get(p), 1) for p in parts) + " |")

    print("\nWall seconds per stage of the full method (workflow benchmark files; the machine may be shared):")
    print("| scene | " + " | ".join(STAGES) + " | total |\n|" + "---|" * (len(STAGES) + 2))
    b = args.out / "benchmarks"
    for s in complete:
        paths = {
            "train_3dgs": b / s / "train_3dgs.tsv",
            "segment": b / s / args.run / "segment.tsv",
            "associate": b / s / args.run / "kom" / "associate.tsv",
            "distill": b / s / args.run / "kom" / "distill.tsv",
            "remove": b / s / args.run / "kom" / "remove.tsv",
            "inpaint": b / s / args.run / "methods" / "full" / "inpaint.tsv",
            "evaluate": b / s / args.run / "methods" / "full" / "evaluate.tsv",
        }
        secs = {k: bench_seconds(p) for k, p in paths.items()}
        total = sum(v for v in secs.values() if v is not None)
        print(f"| {s} | " + " | ".join(fmt(secs[k], 0) for k in STAGES) + f" | {total:.0f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
