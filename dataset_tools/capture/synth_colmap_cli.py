"""``inpaint360gs-dataset synth-colmap SCENE OUT``: rebuild a generated scene's poses and points through COLMAP."""

from __future__ import annotations

import argparse
import json

from dataset_tools.capture.colmap import SfMConfig
from dataset_tools.capture.pipeline import BuildConfig
from dataset_tools.capture.synth_colmap import build_synthetic_with_colmap
from inpaint360gs.cli.common import check_apart, existing_dir, nonneg_int, output_dir


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("scene", type=existing_dir, help="a scene folder written by `inpaint360gs-dataset synth`")
    p.add_argument("out", type=output_dir, help="scene folder to write (same layout, COLMAP poses and points)")
    p.add_argument("--matcher", choices=["exhaustive", "sequential", "auto"], default="auto")
    p.add_argument("--seed", type=nonneg_int, default=0)
    p.add_argument("--overwrite", action="store_true")
    p.add_argument("--no-progress", action="store_true")


def run(args: argparse.Namespace) -> int:
    check_apart({"OUT": args.out}, {"SCENE": args.scene})
    cfg = BuildConfig(sfm=SfMConfig(matcher=args.matcher, seed=args.seed), progress=not args.no_progress)
    report = build_synthetic_with_colmap(args.scene, args.out, cfg, overwrite=args.overwrite)
    print(report.format().replace(f"built {report.out}", f"built {args.out}"))
    acc = json.loads((args.out / "gt" / "colmap_frame.json").read_text())["pose_accuracy"]
    print(f"  poses vs the generator after Sim(3): centre error max {acc['center_err_max_pct']:.3f}% of the orbit "
          f"radius, rotation error max {acc['rot_err_max_deg']:.3f}°")
    return 0
