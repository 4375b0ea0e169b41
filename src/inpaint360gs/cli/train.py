"""``inpaint360gs train SCENE OUT``: 3DGS on a scene folder (thin shell over :func:`gs.trainer.train`)."""

from __future__ import annotations

import argparse

from inpaint360gs.cli.common import (
    add_backend_argument,
    add_scene_arguments,
    add_support_init_argument,
    add_threads_argument,
    check_apart,
    existing_dir,
    nonneg_int,
    output_dir,
    positive_float,
    positive_int,
    set_threads,
)
from inpaint360gs.gs.config import DENSIFY_GRADIENTS, ORIGINAL_ITERATIONS, DensifyConfig, TrainConfig


def _schedule_scale(text: str) -> float | str:
    if text == "auto":
        return text
    return positive_float(text)


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``inpaint360gs train``'s arguments to ``parser``."""
    d = TrainConfig()
    parser.add_argument("scene", type=existing_dir, help="scene folder (images/, sparse/0, ...)")
    parser.add_argument("out", type=output_dir, help="output folder (point_cloud.ply, metrics.json, config.yaml, train_log.csv, checkpoint.pt)")
    parser.add_argument("--iterations", type=positive_int, default=d.iterations, help=f"training steps (default {d.iterations})")
    parser.add_argument(
        "--schedule-scale", type=_schedule_scale, default=d.schedule_scale,
        help="multiply the step-based schedule (densification window, opacity-reset period, SH steps, "
        f"position-lr decay) by this; 'auto' = iterations / {ORIGINAL_ITERATIONS} (default 1: the original schedule)",
    )  # fmt: skip
    parser.add_argument(
        "--densify-grad-threshold", type=positive_float, default=d.densify.grad_threshold,
        help=f"densify Gaussians whose mean NDC position gradient exceeds this (default {d.densify.grad_threshold:g}, the original)",
    )  # fmt: skip
    parser.add_argument(
        "--densify-gradient", choices=DENSIFY_GRADIENTS, default=d.densify.gradient,
        help=f"view-space gradient the densification thresholds: mean (3DGS), abs (AbsGS: per-pixel absolute values, "
        f"threshold {d.densify.abs_grad_threshold:g}), or auto: abs when support points were added (a sparse capture) "
        f"(default {d.densify.gradient})",
    )  # fmt: skip
    parser.add_argument(
        "--max-gaussians", type=nonneg_int, default=d.densify.max_gaussians,
        help="cap on the Gaussian count during densification, largest gradients first (default 0: no cap, the original)",
    )  # fmt: skip
    add_scene_arguments(parser)
    add_backend_argument(parser, d.backend)
    parser.add_argument("--seed", type=nonneg_int, default=d.seed)
    parser.add_argument("--sh-degree", type=nonneg_int, default=d.sh_degree, help="highest SH degree (default 3)")
    parser.add_argument("--random-background", action="store_true", help="a random background colour every step")
    add_support_init_argument(parser, d.support_init)
    parser.add_argument("--white-background", action="store_true", help="render on white instead of black")
    parser.add_argument("--eval-every", type=nonneg_int, default=d.eval_every, help="held-out PSNR/SSIM into train_log.csv every N steps (0: end only)")
    parser.add_argument("--checkpoint-every", type=nonneg_int, default=d.checkpoint_every, help="steps between checkpoints (0: only at the end)")
    parser.add_argument("--log-every", type=positive_int, default=d.log_every, help="steps between train_log.csv rows")
    parser.add_argument(
        "--resume", action="store_true",
        help="continue from OUT/checkpoint.pt (same scene content and settings); with no checkpoint and no previous run in OUT, start afresh",
    )  # fmt: skip
    parser.add_argument("--overwrite", action="store_true", help="discard a previous run in OUT and start afresh instead of refusing")
    parser.add_argument("--allow-unregistered", action="store_true", help="warn about, instead of rejecting, images not in sparse/0")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_threads_argument(parser)


def config_from_args(args: argparse.Namespace) -> TrainConfig:
    """The :class:`TrainConfig` the parsed ``args`` give (``--schedule-scale auto`` = iterations / 30000)."""
    scale = args.schedule_scale
    if scale == "auto":
        scale = args.iterations / ORIGINAL_ITERATIONS
    return TrainConfig(
        iterations=args.iterations,
        seed=args.seed,
        backend=args.backend,
        sh_degree=args.sh_degree,
        background=(1.0, 1.0, 1.0) if args.white_background else (0.0, 0.0, 0.0),
        random_background=args.random_background,
        support_init=args.support_init,
        schedule_scale=float(scale),
        checkpoint_every=args.checkpoint_every,
        eval_every=args.eval_every,
        log_every=args.log_every,
        densify=DensifyConfig(grad_threshold=args.densify_grad_threshold, gradient=args.densify_gradient, max_gaussians=args.max_gaussians),
    )


def run(args: argparse.Namespace) -> int:
    """Run ``inpaint360gs train`` with parsed ``args``; returns the exit status."""
    from inpaint360gs.gs.trainer import train_stage
    from inpaint360gs.io.scene import load_scene

    check_apart({"OUT": args.out}, {"SCENE": args.scene}, replaced=False)  # a run never replaces OUT as a whole
    set_threads(args.threads)
    cfg = config_from_args(args)
    cfg.validate()
    scene = load_scene(args.scene, resize=args.resize, llffhold=args.llffhold, unregistered="warn" if args.allow_unregistered else "error")
    res = train_stage(scene, args.out, cfg, resume=args.resume, overwrite=args.overwrite, progress=not args.no_progress)
    m = res.metrics
    held = f"held-out PSNR {m['psnr']:.2f} dB, SSIM {m['ssim']:.4f} on {m['num_holdout_views']} views" if m["psnr"] is not None else "no held-out views"
    print(f"{scene.name}: {m['num_gaussians']} Gaussians after {m['iterations']} steps in {m['train_seconds']:.0f} s; {held}; peak RSS {m['peak_rss_mb']:.0f} MiB")
    return 0
