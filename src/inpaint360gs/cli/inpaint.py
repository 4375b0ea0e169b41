"""``inpaint360gs inpaint SCENE DISTILL REMOVED OUT``: virtual views, geometric unseen masks and
occluders, recursive conditional RGB-D 2D inpainting, depth-guided initialisation and 3D inpainting
with hybrid supervision (paper Sec. 3.4-3.5; thin shell over
:func:`inpaint360gs.inpaint.stage.inpaint_stage`). Each switch turns one part off for the
ablations of paper Tab. 3."""

from __future__ import annotations

import argparse

from inpaint360gs.cli.common import (
    add_backend_argument,
    add_scene_arguments,
    add_threads_argument,
    check_apart,
    existing_dir,
    existing_file,
    fraction,
    nonneg_float,
    nonneg_int,
    output_dir,
    positive_float,
    positive_int,
    set_threads,
)


def add_inpaint_arguments(parser: argparse.ArgumentParser) -> None:
    """The inpainting settings (shared with ``inpaint360gs run``)."""
    from inpaint360gs.inpaint.inpainters import DEPTH_METHODS, RGB_METHODS
    from inpaint360gs.inpaint.stage import InpaintConfig

    d = InpaintConfig()
    g = parser.add_argument_group("inpainting (paper Sec. 3.4-3.5; the switches are the ablations of Tab. 3)")
    g.add_argument("--virtual-views", type=positive_int, default=d.virtual.num_views, help=f"L, views on the virtual trajectory (default {d.virtual.num_views})")
    g.add_argument("--views", default=d.views, choices=["virtual", "training"], help="inpaint on the virtual trajectory (default) or the training views (ablation c)")
    g.add_argument("--masks", default=d.masks, choices=["unseen", "footprint"], help="geometric unseen masks (default) or the removed objects' whole footprint (a per-view 2D baseline)")
    g.add_argument("--no-condition", action="store_true", help="inpaint each view on its own (ablation d)")
    g.add_argument("--init", default=d.init, choices=["depth", "naive", "none"], help="new Gaussians from the inpainted depth (default), uniform in the object's box (ablation b), or none")
    g.add_argument("--supervision", default=d.refine.supervision, choices=["hybrid", "mask", "lpips"],
                   help="Eq. 6 hybrid loss (default), mask-only (ablation e), or Gaussian Grouping's: LPIPS inside the mask, L1 outside (the strong baseline)")
    g.add_argument("--densify", action="store_true", help="3DGS clone/split/prune of the Gaussians that train during 3D inpainting (the strong baseline; the method keeps its count)")
    g.add_argument("--densify-until", type=fraction, default=d.refine.densify_until, help=f"with --densify: share of the steps it runs for (default {d.refine.densify_until})")
    g.add_argument("--densify-grad", type=positive_float, default=d.refine.densify_grad, help=f"with --densify: view-space gradient threshold (default {d.refine.densify_grad})")
    g.add_argument("--refine-variant", default=d.refine.variant, choices=["paper", "code"], help="paper: lambda1 0.2, lambda2 0.005, 2000 iterations (default); code: the authors' public code")
    g.add_argument("--inpaint-iterations", type=positive_int, default=None, help="3D inpainting steps (default 2000; 5000 with --refine-variant code)")
    g.add_argument("--lambda-dssim", type=nonneg_float, default=None, help="lambda1 of Eq. 6 (default: the variant's)")
    g.add_argument("--lambda-lpips", type=nonneg_float, default=None, help="lambda2 of Eq. 6 (default: the variant's)")
    g.add_argument("--rgb-inpainter", default=d.rgb_inpainter, choices=list(RGB_METHODS), help=f"2D inpainter for colour (default {d.rgb_inpainter})")
    g.add_argument("--depth-inpainter", default=d.depth_inpainter, choices=list(DEPTH_METHODS), help=f"2D inpainter for depth (default {d.depth_inpainter})")
    g.add_argument("--lama-onnx", type=existing_file, default=None, help="LaMa checkpoint (ONNX) for --rgb-inpainter/--depth-inpainter lama")
    g.add_argument("--no-occluders", action="store_true", help="do not take other objects in front of the target out while inpainting")


def inpaint_config(args: argparse.Namespace, seed: int, backend: str):
    """The :class:`InpaintConfig` the parsed inpainting ``args`` give, with ``seed`` and ``backend``."""
    from inpaint360gs.inpaint.refine import RefineConfig
    from inpaint360gs.inpaint.stage import InpaintConfig
    from inpaint360gs.views.config import VirtualViewsConfig

    r = RefineConfig(
        variant=args.refine_variant, supervision=args.supervision, iterations=args.inpaint_iterations,
        lambda_dssim=args.lambda_dssim, lambda_lpips=args.lambda_lpips, seed=seed, backend=backend,
        densify=args.densify, densify_until=args.densify_until, densify_grad=args.densify_grad,
    ).resolved()  # explicit values override the variant's  # fmt: skip
    return InpaintConfig(
        views=args.views, masks=args.masks, condition=not args.no_condition, init=args.init,
        rgb_inpainter=args.rgb_inpainter, depth_inpainter=args.depth_inpainter,
        lama_onnx=None if args.lama_onnx is None else str(args.lama_onnx), occluders=not args.no_occluders,
        virtual=VirtualViewsConfig(num_views=args.virtual_views), refine=r, backend=backend,
    )  # fmt: skip


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``inpaint360gs inpaint``'s arguments to ``parser``."""
    parser.add_argument("scene", type=existing_dir, help="scene folder")
    parser.add_argument("distill", type=existing_dir, help="output folder of `inpaint360gs distill`")
    parser.add_argument("removed", type=existing_dir, help="output folder of `inpaint360gs remove`")
    parser.add_argument("out", type=output_dir, help="output folder: point_cloud.ply, renders/test/, grid.png, trajectory.gif, inpaint.json")
    add_inpaint_arguments(parser)
    parser.add_argument("--seed", type=nonneg_int, default=0)
    add_scene_arguments(parser)
    parser.add_argument("--overwrite", action="store_true", help="replace OUT if it exists")
    parser.add_argument("--no-progress", action="store_true")
    add_backend_argument(parser)
    add_threads_argument(parser)


def run(args: argparse.Namespace) -> int:
    """Run ``inpaint360gs inpaint`` with parsed ``args``; returns the exit status."""
    from inpaint360gs.distill.field import IdentityField
    from inpaint360gs.inpaint.stage import inpaint_stage
    from inpaint360gs.io.scene import load_scene

    check_apart({"OUT": args.out}, {"SCENE": args.scene, "DISTILL": args.distill, "REMOVED": args.removed, "--lama-onnx": args.lama_onnx})  # OUT is replaced as a whole
    set_threads(args.threads)
    cfg = inpaint_config(args, args.seed, args.backend)
    scene = load_scene(args.scene, resize=args.resize, llffhold=args.llffhold, load_masks=False)
    field = IdentityField.load(args.distill)
    rec = inpaint_stage(scene, field, args.removed, args.out, cfg, overwrite=args.overwrite, progress=not args.no_progress)
    print(f"{scene.name}: inpainted on {rec['num_views']} {rec['views']} view(s), {rec['new_gaussians']} new Gaussians, in {rec['seconds']['total_s']:.0f} s -> {args.out}")
    return 0
