"""Which of the removal's low-parts conditions keeps a synthetic object's parts (README "What the
checks miss": a toy's feet the object field gave to the background).

Reruns ``inpaint360gs remove`` in this process on a run's distilled field with the run's click,
catching the inputs and output of the footprint step (``remove.geometry.footprint_columns``), and
takes as the object's true Gaussians those (opacity > 0.1) whose centres fall in the generator's
instance mask (``gt/instance``) in at least ``--share`` of the training views that see them. Of the
ones the removal keeps, it prints how many stand higher than the outline's standing share, how many
lie beyond the rule's reach (``RemovalConfig.low_parts`` footprint sizes), how many fail the colour
test and how many pass it but are not linked to what goes (their distance to it in links).

    python benchmarks/diagnose_low_parts.py data/dev/plush-dev1 runs/dev/plush-dev1/seed2
"""

from __future__ import annotations

import argparse
import json
import tempfile
from pathlib import Path

import numpy as np


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", type=Path, help="a generated scene folder (gt/instance)")
    ap.add_argument("run", type=Path, help="a run folder of `inpaint360gs run` (distill/, removed/removal.json)")
    ap.add_argument("--target", type=int, default=1, help="the object's id in gt/instance (default 1)")
    ap.add_argument("--share", type=float, default=0.7, help="share of the seeing views a true Gaussian's centre lies in the mask (default 0.7)")
    a = ap.parse_args(argv)

    import inpaint360gs.remove.geometry as geo
    import inpaint360gs.remove.objects as objs
    from scipy.spatial import cKDTree

    from inpaint360gs.cli import main as cli
    from inpaint360gs.core.support import STANDING, object_footprint
    from PIL import Image
    from inpaint360gs.io.scene import load_scene
    from inpaint360gs.views.unseen import project

    cap: dict = {}
    footprint_columns = geo.footprint_columns

    def caught(means, opacities, remove, bodies, keep, up, cfg, counts, colours=None, silhouette_share=None):
        cap.update(means=means, opac=opacities, selected=remove.copy(), bodies=bodies, keep=keep, up=up, cfg=cfg, colours=colours)
        out = footprint_columns(means, opacities, remove, bodies, keep, up, cfg, counts, colours, silhouette_share)
        cap["removed"] = out[0]
        return out

    objs.footprint_columns = caught
    click = json.loads((a.run / "removed" / "removal.json").read_text())["clicks"][0]
    with tempfile.TemporaryDirectory() as tmp:
        rc = cli(["remove", str(a.scene), str(a.run / "distill"), str(Path(tmp) / "removed"), "--click", click, "--threads", "1"])
    if rc != 0 or "removed" not in cap:
        print(f"diagnose_low_parts: the removal failed ({rc})")
        return 1
    means, opac, cfg, removed = cap["means"], cap["opac"], cap["cfg"], cap["removed"]
    scene = load_scene(a.scene)
    hits, seen = np.zeros(len(means)), np.zeros(len(means))
    for v in scene.train_views:
        inst = np.array(Image.open(a.scene / "gt" / "instance" / v.name))
        inst = inst[..., 0] if inst.ndim == 3 else inst
        cam = v.camera
        u, w, z = project(cam, means)
        inside = (z > 1e-6) & (u >= 0) & (u < cam.width) & (w >= 0) & (w < cam.height)
        seen[inside] += 1
        hits[np.flatnonzero(inside)] += inst[w[inside].astype(int), u[inside].astype(int)] == a.target
    true = (hits >= a.share * np.maximum(seen, 1)) & (seen > 0) & (opac > 0.1)
    left = np.flatnonzero(true & ~removed)
    body = cap["bodies"][0]
    fp = object_footprint(means[body], opac[body], means[~cap["selected"]], opac[~cap["selected"]], cap["up"])
    h, d = fp.heights(means), fp.distance(means)
    standing_left = h[left] > STANDING * fp.height
    far = ~standing_left & (d[left] > cfg.low_parts * fp.size)
    cand = ~standing_left & ~far & (h[left] > -cfg.support_band * fp.height)
    # the colour test as the rule makes it: the object standing, the support beyond the rule's reach
    standing = removed & body & (h > STANDING * fp.height)
    outer = ~removed & (h > -cfg.footprint_depth * fp.height) & (h <= cfg.support_band * fp.height)
    outer &= (d > cfg.low_parts * fp.size) & (d <= (cfg.low_parts + 0.25) * fp.size)
    c = left[cand]
    colour = geo.nearer_object(means[c], cap["colours"][c], means[outer], cap["colours"][outer], means[standing], cap["colours"][standing])
    link = cfg.link * geo.spacing(means[body])
    gap = cKDTree(means[removed]).query(means[c[colour]])[0] / link if colour.any() else np.zeros(0)
    print(f"{a.scene.name}: {int(true.sum())} true Gaussians of object {a.target}, {len(left)} kept by the removal")
    print(f"  standing (higher than {STANDING:g} x the height {fp.height:.3f}): {int(standing_left.sum())}")
    print(f"  low, beyond the reach ({cfg.low_parts:g} x the footprint size {fp.size:.3f}; farthest {d[left].max() / fp.size:.2f}): {int(far.sum())}")
    print(f"  low, within the reach: {int(cand.sum())}; failing the colour test: {int((~colour).sum())}; passing it: {int(colour.sum())}")
    if len(gap):
        print(f"  of those passing, distance to what the removal takes in links ({link:.4f}): min {gap.min():.2f}, median {np.median(gap):.2f}; "
              f"within one link: {int((gap <= 1).sum())}")
    print(f"  the rest (under the support band): {int((~standing_left & ~far & ~cand).sum())}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
