"""``inpaint360gs train SCENE OUT``: 3DGS on a scene folder (thin shell over :func:`gs.trainer.train`)."""

from __future__ import annotations

import argparse
import os

from inpaint360gs.gs.config import ORIGINAL_ITERATIONS, DensifyConfig, TrainConfig


def _schedule_scale(text: str) -> float | str:
    if text == "auto":
        return text
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected a number or 'auto', got {text!r}") from None


def add_threads_argument(parser: argparse.ArgumentParser) -> None:
    default = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (os.cpu_count() or 1)
    parser.add_argument("--threads", type=int, default=default, help=f"CPU threads for torch and numba (default: {default}, the usable cores)")


def set_threads(n: int) -> None:
    """Limit torch's and numba's thread pools (both matter on a small shared CPU)."""
    import torch

    torch.set_num_threads(max(1, n))
    try:
        import numba

        numba.set_num_threads(max(1, min(n, numba.config.NUMBA_NUM_THREADS)))
    except ImportError:
        pass


def add_arguments(parser: argparse.ArgumentParser) -> None:
    d = TrainConfig()
    parser.add_argument("scene", help="scene folder (images/, sparse/0, ...)")
    parser.add_argument("out", help="output folder (point_cloud.ply, metrics.json, config.yaml, train_log.csv, checkpoint.pt)")
    parser.add_argument("--iterations", type=int, default=d.iterations, help=f"training steps (default {d.iterations})")
    parser.add_argument(
        "--schedule-scale", type=_schedule_scale, default=d.schedule_scale,
        help="multiply the step-based schedule (densification window, opacity-reset period, SH steps, "
        f"position-lr decay) by this; 'auto' = iterations / {ORIGINAL_ITERATIONS} (default 1: the original schedule)",
    )  # fmt: skip
    parser.add_argument(
        "--densify-grad-threshold", type=float, default=d.densify.grad_threshold,
        help=f"densify Gaussians whose mean NDC position gradient exceeds this (default {d.densify.grad_threshold:g}, the original)",
    )  # fmt: skip
    parser.add_argument(
        "--max-gaussians", type=int, default=d.densify.max_gaussians,
        help="cap on the Gaussian count during densification, largest gradients first (default 0: no cap, the original)",
    )  # fmt: skip
    parser.add_argument("--resize", type=int, default=1, help="image downscale factor (uses images_<R>/ when present)")
    parser.add_argument("--llffhold", type=int, default=8, help="every N-th non-test view is held out for evaluation (default 8)")
    parser.add_argument("--backend", default=d.backend, choices=["auto", "torch", "numba", "gsplat"], help="rasterizer backend")
    parser.add_argument("--seed", type=int, default=d.seed)
    parser.add_argument("--sh-degree", type=int, default=d.sh_degree, help="highest SH degree (default 3)")
    parser.add_argument("--random-background", action="store_true", help="a random background colour every step")
    parser.add_argument("--white-background", action="store_true", help="render on white instead of black")
    parser.add_argument("--eval-every", type=int, default=d.eval_every, help="held-out PSNR/SSIM into train_log.csv every N steps (0: end only)")
    parser.add_argument("--checkpoint-every", type=int, default=d.checkpoint_every, help="steps between checkpoints")
    parser.add_argument("--log-every", type=int, default=d.log_every, help="steps between train_log.csv rows")
    parser.add_argument("--resume", action="store_true", help="continue from OUT/checkpoint.pt (same settings)")
    parser.add_argument("--overwrite", action="store_true", help="replace a previous run in OUT instead of refusing")
    parser.add_argument("--allow-unregistered", action="store_true", help="warn about, instead of rejecting, images not in sparse/0")
    parser.add_argument("--no-progress", action="store_true", help="no progress bar")
    add_threads_argument(parser)


def config_from_args(args: argparse.Namespace) -> TrainConfig:
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
        schedule_scale=float(scale),
        checkpoint_every=args.checkpoint_every,
        eval_every=args.eval_every,
        log_every=max(1, args.log_every),
        densify=DensifyConfig(grad_threshold=args.densify_grad_threshold, max_gaussians=args.max_gaussians),
    )


def run(args: argparse.Namespace) -> int:
    from inpaint360gs.gs.trainer import train
    from inpaint360gs.io.scene import load_scene

    set_threads(args.threads)
    cfg = config_from_args(args)
    cfg.validate()
    scene = load_scene(args.scene, resize=args.resize, llffhold=args.llffhold, unregistered="warn" if args.allow_unregistered else "error")
    res = train(scene, cfg, args.out, resume=args.resume, overwrite=args.overwrite, progress=not args.no_progress)
    m = res.metrics
    held = f"held-out PSNR {m['psnr']:.2f} dB, SSIM {m['ssim']:.4f} on {m['num_holdout_views']} views" if m["psnr"] is not None else "no held-out views"
    print(f"{scene.name}: {m['num_gaussians']} Gaussians after {m['iterations']} steps in {m['train_seconds']:.0f} s; {held}; peak RSS {m['peak_rss_mb']:.0f} MiB")
    return 0
