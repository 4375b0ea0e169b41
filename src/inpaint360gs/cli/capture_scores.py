"""``inpaint360gs capture-scores SCENE MODEL DISTILL REMOVED [INPAINTED] OUT.json``: how a removal did on a
capture without ground truth (docs/architecture.md, "Real captures"): PSNR against the photos outside
the grown footprint, what stands in the footprint column, the fill's texture against a ring
(thin shell over :func:`inpaint360gs.evaluate.capture.score_capture`); ``--figure`` writes before /
removed / inpainted at chosen training views."""

from __future__ import annotations

import argparse


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``inpaint360gs capture-scores``' arguments to ``parser``."""
    from inpaint360gs.cli.common import add_scene_arguments, add_threads_argument, existing_dir, existing_file, output_file

    parser.add_argument("scene", type=existing_dir, help="scene folder")
    parser.add_argument("model", type=existing_file, help="the trained 3DGS PLY")
    parser.add_argument("distill", type=existing_dir, help="the distillation folder the removal was made from")
    parser.add_argument("removed", type=existing_dir, help="the removal folder")
    parser.add_argument("out", type=output_file, help="scores JSON to write")
    parser.add_argument("--inpainted", type=existing_dir, default=None, help="the inpainting folder (default: removal only)")
    parser.add_argument("--figure", type=output_file, default=None, help="before / removed / inpainted at --views (PNG or JPEG by suffix)")
    parser.add_argument("--views", default="", help="comma-separated training views of the figure (default: three spread ones)")
    add_scene_arguments(parser)
    add_threads_argument(parser)


def run(args: argparse.Namespace) -> int:
    """Run ``inpaint360gs capture-scores`` with parsed ``args``; returns the exit status."""
    import json

    import numpy as np

    from inpaint360gs.cli.common import check_apart, set_threads
    from inpaint360gs.evaluate.capture import CaptureRun, figure, format_scores, score_capture
    from inpaint360gs.io.atomic import write_text
    from inpaint360gs.io.images import write_image
    from inpaint360gs.io.scene import load_scene

    set_threads(args.threads)
    inputs = {"SCENE": args.scene, "MODEL": args.model, "DISTILL": args.distill, "REMOVED": args.removed, "--inpainted": args.inpainted}
    check_apart({"OUT": args.out, "--figure": args.figure}, inputs, replaced=False)
    scene = load_scene(args.scene, resize=args.resize, llffhold=args.llffhold, load_masks=False)
    picked = [scene.view(n).name for n in args.views.split(",") if n.strip()]
    scores, renders = score_capture(scene, CaptureRun(args.model, args.distill, args.removed, args.inpainted))
    write_text(args.out, json.dumps({"scene": str(args.scene), "resize": args.resize, **scores}, indent=1) + "\n")
    print(format_scores(scores))
    if args.figure is not None:
        train = [v.name for v in scene.train_views]
        names = picked or [train[i] for i in np.linspace(0, len(train) - 1, 3).round().astype(int)]
        write_image(args.figure, figure(renders, names))
        print(f"{args.figure}: rows 3DGS / removed{' / inpainted' if args.inpainted else ''}; views {names}")
    return 0
