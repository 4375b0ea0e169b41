"""The README's figure: one benchmark scene at a few test views, in rows: the 3DGS with the object,
after removal (the hole left), after the full method (removal + inpainting), and the object-free
ground truth. Reads what the workflow wrote (``make benchmark``); renders only the 3DGS rows.

    python benchmarks/figure_removal.py --data data/synthetic --out outputs --scene cone --image docs/images/cone_removal.jpg --gif docs/images/cone_trajectory.gif
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, required=True, help="folder of scene folders")
    ap.add_argument("--out", type=Path, required=True, help="the workflow's out_dir")
    ap.add_argument("--scene", required=True)
    ap.add_argument("--segmenter", default="geometric")
    ap.add_argument("--seed", type=int, default=0, help="which of the workflow's seeds (OUT/<scene>/seed<k>/)")
    ap.add_argument("--views", type=int, default=4, help="test views, spread evenly")
    ap.add_argument("--image", type=Path, required=True, help="output file; the format follows the suffix (.jpg keeps it small)")
    ap.add_argument("--gif", type=Path, default=None, help="also a light copy of the full method's trajectory GIF (every 2nd frame, 128 colours)")
    args = ap.parse_args()

    from PIL import Image

    from inpaint360gs.io.atomic import atomic_path
    from inpaint360gs.io.ply import read_ply
    from inpaint360gs.io.scene import load_scene
    from inpaint360gs.render.api import render

    scene = load_scene(args.data / args.scene, load_masks=False)
    tests = scene.test_views
    pick = [tests[i] for i in np.linspace(0, len(tests) - 1, min(args.views, len(tests))).round().astype(int)]
    model = read_ply(args.out / args.scene / "3dgs" / "point_cloud.ply")
    run = args.out / args.scene / f"seed{args.seed}" / args.segmenter
    rows = [[], [], [], []]
    for v in pick:
        rows[0].append(render(model, v.camera).color.clamp(0, 1).numpy())
        rows[1].append(np.asarray(Image.open(run / "kom" / "removed_renders" / "color" / f"{v.stem}.png").convert("RGB")) / 255.0)
        rows[2].append(np.asarray(Image.open(run / "methods" / "full" / "renders" / "test" / f"{v.stem}.png").convert("RGB")) / 255.0)
        rows[3].append(np.asarray(Image.open(v.image_path).convert("RGB")) / 255.0)
    grid = np.concatenate([np.concatenate(r, axis=1) for r in rows], axis=0)
    with atomic_path(args.image) as tmp:
        Image.fromarray((grid * 255 + 0.5).astype(np.uint8)).save(tmp, quality=88)
    print(f"{args.image}: rows = 3DGS with the object, after removal, after inpainting (full method), ground truth; views {[v.name for v in pick]}")
    if args.gif is not None:
        from PIL import ImageSequence

        src = Image.open(run / "methods" / "full" / "trajectory.gif")
        frames = [f.convert("RGB").quantize(colors=128, method=Image.Quantize.MEDIANCUT) for i, f in enumerate(ImageSequence.Iterator(src)) if i % 2 == 0]
        with atomic_path(args.gif) as tmp:
            frames[0].save(tmp, save_all=True, append_images=frames[1:], duration=160, loop=0, optimize=True)
        print(f"{args.gif}: {len(frames)} frames of the virtual trajectory")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
