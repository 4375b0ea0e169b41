"""``inpaint360gs render MODEL.ply SCENE OUT``: colour and depth of a model at a scene's cameras.

Writes ``OUT/color/<stem>.png``, ``OUT/depth/<stem>.npy`` (float32, paper Eq. 5) and
``OUT/depth/<stem>.png`` (16 bit; depth = png / scale, scales in ``OUT/render.json``). Test views
are rendered from their cameras only; their pixels are never read.
"""

from __future__ import annotations

import argparse
import json


def add_arguments(parser: argparse.ArgumentParser) -> None:
    from inpaint360gs.cli.train import add_threads_argument

    parser.add_argument("model", help="Gaussian PLY (3DGS layout)")
    parser.add_argument("scene", help="scene folder whose cameras to render")
    parser.add_argument("out", help="output folder (created atomically)")
    parser.add_argument("--split", default="test", choices=["train", "holdout", "test", "all"], help="which views (default test)")
    parser.add_argument("--resize", type=int, default=1, help="image downscale factor")
    parser.add_argument("--llffhold", type=int, default=8)
    parser.add_argument("--backend", default="auto", choices=["auto", "torch", "numba", "gsplat"])
    parser.add_argument("--sh-degree", type=int, default=None, help="SH degree to use (default: all the model holds)")
    parser.add_argument("--white-background", action="store_true")
    parser.add_argument("--overwrite", action="store_true", help="replace OUT if it exists")
    add_threads_argument(parser)


def run(args: argparse.Namespace) -> int:
    import torch
    from tqdm import tqdm

    from inpaint360gs.cli.train import set_threads
    from inpaint360gs.io.atomic import atomic_dir
    from inpaint360gs.io.images import write_depth, write_image
    from inpaint360gs.io.ply import read_ply
    from inpaint360gs.io.scene import load_scene
    from inpaint360gs.render.api import render

    set_threads(args.threads)
    model = read_ply(args.model)
    scene = load_scene(args.scene, resize=args.resize, llffhold=args.llffhold, load_masks=False, unregistered="warn")
    views = scene.views if args.split == "all" else scene.split(args.split)
    bg = torch.ones(3) if args.white_background else torch.zeros(3)
    scales = {}
    with atomic_dir(args.out, overwrite=args.overwrite) as tmp, torch.no_grad():
        for v in tqdm(views, desc=f"render {args.split}", disable=not views):
            out = render(model, v.camera, sh_degree=args.sh_degree, background=bg, backend=args.backend)
            write_image(tmp / "color" / f"{v.stem}.png", out.color)
            scales[v.name] = write_depth(tmp / "depth" / v.stem, out.depth)
        info = {"model": str(args.model), "scene": str(scene.root), "split": args.split, "resize": scene.resize, "depth_png_scale": scales}
        (tmp / "render.json").write_text(json.dumps(info, indent=2) + "\n")
    print(f"rendered {len(views)} {args.split} view(s) of {scene.name} to {args.out}")
    return 0
