"""``inpaint360gs run SCENE OUT [--click VIEW:X,Y ...] [--model PLY] [--until STAGE] [--preset cpu|gpu|paper]``: the whole method
on one scene folder for people without Snakemake (paper Alg. 1; thin shell over
:class:`inpaint360gs.pipeline.run.Runner`). One sub-folder per stage under OUT; a stage whose inputs
and settings did not change since the last run is skipped. Clicks default to ``scene.json``'s. A scene
without test_ views (photos with the object only) runs the same; its result has no test_ renders."""

from __future__ import annotations

import argparse
from pathlib import Path

from inpaint360gs.cli.common import add_backend_argument, add_scene_arguments, add_support_init_argument, add_threads_argument, check_apart, existing_dir, existing_file, nonneg_int, output_dir, positive_int, set_threads


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``inpaint360gs run``'s arguments to ``parser``."""
    from inpaint360gs.cli.inpaint import add_inpaint_arguments
    from inpaint360gs.cli.remove import add_click_arguments
    from inpaint360gs.distill.config import DistillConfig
    from inpaint360gs.gs.config import TrainConfig
    from inpaint360gs.pipeline.presets import DEFAULT_PRESET, PRESETS, SUMMARIES
    from inpaint360gs.pipeline.run import STAGES
    from inpaint360gs.segment.base import DEFAULT_SEGMENTER, segmenter_names

    parser.add_argument("scene", type=existing_dir, help="scene folder (images/, sparse/0, scene.json, ...)")
    parser.add_argument("out", type=output_dir, help="output folder: 3dgs/ segment/ associate/ distill/ removed/ inpainted/ run.json")
    add_click_arguments(parser)
    parser.add_argument("--model", type=existing_file, default=None, help="a trained 3DGS PLY of this scene: skip training")
    parser.add_argument("--until", default=STAGES[-1], choices=STAGES, help="stop after this stage (default: the last)")
    presets = "; ".join(f"{name}: {summary}" for name, summary in SUMMARIES.items())
    parser.add_argument("--preset", default=DEFAULT_PRESET, choices=list(PRESETS), help=f"training budget and backend (default {DEFAULT_PRESET}; {presets})")
    parser.add_argument("--iterations", type=positive_int, default=None, help="3DGS steps, the schedule scaled to them (default: the preset's)")
    parser.add_argument("--max-gaussians", type=nonneg_int, default=None, help="3DGS cap (default: the preset's; 0: none)")
    add_support_init_argument(parser, TrainConfig().support_init)
    parser.add_argument("--segmenter", default=DEFAULT_SEGMENTER, choices=segmenter_names(), help=f"2D masks (default {DEFAULT_SEGMENTER}; oracle reads gt/ of synthetic scenes)")
    parser.add_argument("--association", default="kom", choices=["kom", "tracker"], help="Key Object Management (default) or 2D tracking (ablation a)")
    parser.add_argument("--distill-iterations", type=positive_int, default=DistillConfig().iterations)
    add_inpaint_arguments(parser)
    parser.add_argument("--seed", type=nonneg_int, default=0)
    add_scene_arguments(parser, llffhold=False, resize_note="else images/ shrunk on read; clicks stay in the coordinates of images/")
    parser.add_argument("--accept", action="store_true", help="keep a result that fails the run's own check (check.json, check.png) and exit 0; default: exit 4 naming the check")
    parser.add_argument("--no-progress", action="store_true")
    add_backend_argument(parser, default=None)
    add_threads_argument(parser)


def run_config(args: argparse.Namespace):
    """The run's settings (:class:`RunConfig`): the preset's, with what the options give."""
    from dataclasses import replace

    from inpaint360gs.associate.config import AssociationConfig
    from inpaint360gs.cli.inpaint import inpaint_config
    from inpaint360gs.pipeline.presets import get_preset, with_budget

    preset = get_preset(args.preset)
    backend = preset.backend if args.backend is None else args.backend
    cfg = with_budget(preset, iterations=args.iterations, max_gaussians=args.max_gaussians)
    cfg = replace(cfg, train=replace(cfg.train, support_init=args.support_init))
    return replace(cfg, seed=args.seed, backend=backend, segmenter=args.segmenter, association=AssociationConfig(method=args.association).resolved(),
                   distill=replace(cfg.distill, iterations=args.distill_iterations), inpaint=inpaint_config(args, args.seed, backend))  # fmt: skip


def run(args: argparse.Namespace) -> int:
    """Run ``inpaint360gs run`` (every stage) with parsed ``args``; returns the exit status."""
    from inpaint360gs.io.scene import load_scene
    from inpaint360gs.pipeline.run import Runner
    from inpaint360gs.remove.select import Click

    set_threads(args.threads)
    check_apart({"OUT": args.out}, {"SCENE": args.scene, "--model": args.model}, replaced=False)  # stages replace their sub-folders only
    clicks = [Click.parse(c) for c in args.click]
    scene = load_scene(args.scene, resize=args.resize, load_masks=False)
    cfg = run_config(args)
    runner = Runner(scene, args.out, cfg, model=args.model, clicks=clicks, ids=args.id, progress=not args.no_progress, announce=True, accept=args.accept)
    for stage, what in runner.run(args.until):
        print(f"{stage:10s} {what}")
    if runner.check is not None:
        from inpaint360gs.pipeline.check import CHECK_JSON, CHECK_PICTURE

        state = "passed" if runner.check.passed else "FAILED (" + ", ".join(c.name for c in runner.check.failed) + "), accepted with --accept"
        print(f"{'check':10s} {state}: {Path(args.out) / CHECK_JSON}, {Path(args.out) / CHECK_PICTURE}")
    print(f"{scene.name}: done up to {args.until} -> {args.out}")
    if args.until == "inpaint" and not scene.test_views:
        from inpaint360gs.core.layout import NO_GROUND_TRUTH, RunLayout

        inpainted = RunLayout(args.out).inpainted
        print(f"{NO_GROUND_TRUTH} (nothing to evaluate): see {inpainted / 'grid.png'} and {inpainted / 'trajectory.gif'}")
    return 0
