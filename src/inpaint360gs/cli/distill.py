"""``inpaint360gs distill SCENE MODEL.ply ASSOC OUT``: object-ID distillation (paper Sec. 3.3), a thin
shell over :func:`inpaint360gs.distill.distill`.

``ASSOC`` is an association output folder (docs/architecture.md, "Stage outputs"): ``object_mask/<stem>.png``
per training view (8-bit object ids, 0 = background) and ``objects.json``. ``OUT`` receives
``point_cloud.ply`` (with ``obj_*`` identity features), ``classifier.json`` and ``distill.json``.
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
    nonneg_float,
    nonneg_int,
    number,
    output_dir,
    positive_float,
    positive_int,
    set_threads,
)
from inpaint360gs.distill.config import DistillConfig


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``inpaint360gs distill``'s arguments to ``parser``."""
    d = DistillConfig()
    parser.add_argument("scene", type=existing_dir, help="scene folder (images/, sparse/0, ...)")
    parser.add_argument("model", type=existing_file, help="trained Gaussian PLY of this scene (e.g. 3dgs/point_cloud.ply)")
    parser.add_argument("assoc", type=existing_dir, help="association folder: object_mask/<stem>.png per training view and objects.json")
    parser.add_argument("out", type=output_dir, help="output folder (point_cloud.ply, classifier.json, distill.json)")
    parser.add_argument("--iterations", type=positive_int, default=d.iterations, help=f"optimisation steps (default {d.iterations}, the paper's)")
    parser.add_argument("--lambda-space", type=nonneg_float, default=d.lambda_space, help=f"weight of the 3D spatial loss, Eq. 4 (default {d.lambda_space:g})")
    parser.add_argument("--knn", type=positive_int, default=d.knn, help=f"neighbours per Gaussian in the spatial loss (default {d.knn})")
    parser.add_argument(
        "--knn-sample", type=nonneg_int, default=d.knn_sample,
        help=f"Gaussians the spatial loss is evaluated on per step, drawn at random (default {d.knn_sample}; 0: all)",
    )  # fmt: skip
    parser.add_argument("--feature-dim", type=positive_int, default=d.feature_dim, help=f"identity feature channels (default {d.feature_dim})")
    parser.add_argument("--features-lr", type=positive_float, default=d.features_lr, help=f"Adam learning rate of the features (default {d.features_lr:g})")
    parser.add_argument("--classifier-lr", type=positive_float, default=d.classifier_lr, help=f"Adam learning rate of the classifier (default {d.classifier_lr:g})")
    parser.add_argument(
        "--min-weight", type=number(float, lo=0.0, hi=1.0, hi_open=True), default=d.min_weight,
        help="drop cached compositing weights below this (default 0: exact; see results/README.md on what pruning costs)",
    )  # fmt: skip
    add_scene_arguments(parser)
    add_backend_argument(parser, d.backend)
    parser.add_argument("--seed", type=nonneg_int, default=d.seed)
    parser.add_argument("--overwrite", action="store_true", help="replace OUT if it holds a previous run")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_threads_argument(parser)


def config_from_args(args: argparse.Namespace) -> DistillConfig:
    """The :class:`DistillConfig` the parsed ``args`` give."""
    return DistillConfig(
        iterations=args.iterations,
        feature_dim=args.feature_dim,
        lambda_space=args.lambda_space,
        knn=args.knn,
        knn_sample=args.knn_sample,
        features_lr=args.features_lr,
        classifier_lr=args.classifier_lr,
        min_weight=args.min_weight,
        backend=args.backend,
        seed=args.seed,
    )


def run(args: argparse.Namespace) -> int:
    """Run ``inpaint360gs distill`` with parsed ``args``; returns the exit status."""
    from inpaint360gs.core.errors import InputError
    from inpaint360gs.distill import distill_stage
    from inpaint360gs.io.scene import load_scene

    set_threads(args.threads)
    check_apart({"OUT": args.out}, {"SCENE": args.scene, "MODEL": args.model, "ASSOC": args.assoc})  # --overwrite replaces OUT as a whole
    cfg = config_from_args(args)
    cfg.validate()
    objects = args.assoc / "objects.json"
    masks = args.assoc / "object_mask"
    if not objects.is_file():
        raise InputError("no objects.json in the association folder", args.assoc)
    if not masks.is_dir():
        raise InputError("no object_mask/ folder in the association folder", args.assoc)
    scene = load_scene(args.scene, resize=args.resize, llffhold=args.llffhold, load_masks=False, unregistered="warn")
    res = distill_stage(scene, args.model, masks, objects, args.out, cfg, overwrite=args.overwrite, progress=not args.no_progress)
    r = res.report
    tv = r["final"]["train_views"]
    miou = f", mean object IoU {tv['mean_object_iou']:.3f}" if tv["mean_object_iou"] is not None else ""
    print(
        f"{scene.name}: {r['num_gaussians']} Gaussians, {len(r['object_ids']) - 1} object(s), {cfg.iterations} steps in {r['timing_s']['total']:.0f} s; "
        f"training views: pixel accuracy {tv['pixel_accuracy']:.4f}{miou}; peak RSS {r['peak_rss_mb']:.0f} MiB"
    )
    return 0
