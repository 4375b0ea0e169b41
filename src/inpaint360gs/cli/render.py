"""``inpaint360gs render MODEL.ply SCENE OUT``: colour and depth of a model at a scene's cameras.

Writes ``OUT/color/<stem>.png``, ``OUT/depth/<stem>.npy`` (float32, paper Eq. 5) and
``OUT/depth/<stem>.png`` (16 bit; depth = png / scale, scales in ``OUT/render.json``). Test views
are rendered from their cameras only; their pixels are never read.
"""

from __future__ import annotations

import argparse

from inpaint360gs.cli.common import (
    add_backend_argument,
    add_scene_arguments,
    add_threads_argument,
    check_apart,
    existing_dir,
    existing_file,
    nonneg_int,
    output_dir,
    set_threads,
)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``inpaint360gs render``'s arguments to ``parser``."""
    parser.add_argument("model", type=existing_file, help="Gaussian PLY (3DGS layout)")
    parser.add_argument("scene", type=existing_dir, help="scene folder whose cameras to render")
    parser.add_argument("out", type=output_dir, help="output folder (created atomically)")
    parser.add_argument("--split", default="test", choices=["train", "holdout", "test", "all"], help="which views (default test)")
    add_scene_arguments(parser)
    add_backend_argument(parser)
    parser.add_argument("--sh-degree", type=nonneg_int, default=None, help="SH degree to use (default: all the model holds)")
    parser.add_argument("--white-background", action="store_true")
    parser.add_argument("--overwrite", action="store_true", help="replace OUT if it exists")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_threads_argument(parser)


def run(args: argparse.Namespace) -> int:
    """Run ``inpaint360gs render`` with parsed ``args``; returns the exit status."""
    import warnings

    import torch

    from inpaint360gs.core.errors import InputError
    from inpaint360gs.io import provenance
    from inpaint360gs.io.ply import read_ply
    from inpaint360gs.io.scene import load_scene
    from inpaint360gs.render.stage import render_stage

    check_apart({"OUT": args.out}, {"MODEL": args.model, "SCENE": args.scene})  # --overwrite replaces OUT as a whole
    set_threads(args.threads)
    model = read_ply(args.model)
    if args.sh_degree is not None and args.sh_degree > model.sh_degree:
        raise InputError(f"{args.sh_degree} is above the SH degree {model.sh_degree} that {args.model} holds", "--sh-degree")
    scene = load_scene(args.scene, resize=args.resize, llffhold=args.llffhold, load_masks=False, unregistered="warn")
    views = scene.views if args.split == "all" else scene.split(args.split)
    if not views and args.split == "test":
        raise InputError("the scene has no test_ views (no object-free photos, no ground truth); nothing to render: "
                         "use --split train, holdout or all", args.scene)
    if not views:
        raise InputError(f"the scene has no {args.split} views (llffhold={args.llffhold}); nothing to render", args.scene)
    # a model a stage recorded as made from another scene is refused (docs/architecture.md, "Provenance chain")
    model_sha = provenance.check_model(args.model, scene, "render it at the scene it was made from")
    bg = torch.ones(3) if args.white_background else torch.zeros(3)
    settings = {"views": [v.name for v in views], "sh_degree": args.sh_degree, "white_background": args.white_background}
    meta = {"model": str(args.model), "split": args.split, provenance.KEY: provenance.make("render", scene, {"model": model_sha}, settings)}
    summary = render_stage(scene, model, views, args.out, sh_degree=args.sh_degree, background=bg, backend=args.backend, overwrite=args.overwrite,
                           progress=not args.no_progress, meta=meta)
    if views and summary["empty_views"] == len(views):
        warnings.warn(f"{args.model}: every rendered pixel is background in all {len(views)} view(s); is this model in this scene's frame, with sensible scales and opacities?")
    print(f"rendered {len(views)} {args.split} view(s) of {scene.name} to {args.out}")
    return 0
