"""``inpaint360gs-dataset synth OUT [--scenes NAME ...|all | --suite dev|test] [--reduced] [--width W --height H] [--seed S] [--poses P] [--overwrite]``.

Writes one folder per scene under OUT, each atomically; every argument is checked and every target
folder is tested for conflicts before the first scene is rendered, so an error writes nothing.
After each scene it prints the unseen share of its test views (``visibility.MIN_UNSEEN_SHARE``).
"""

from __future__ import annotations

import argparse
import time
from pathlib import Path

from inpaint360gs.cli.common import nonneg_int, number, output_dir
from inpaint360gs.core.errors import InputError

image_side = number(int, lo=16, hi=8192)  # pixels (argument type)


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("out", nargs="?", type=output_dir, help="output folder; scenes go to OUT/<name>/")
    p.add_argument("--scenes", nargs="+", default=None, metavar="NAME",
                   help="scene names, or 'all' (default): the ten scenes of the committed tables")
    p.add_argument("--suite", choices=["dev", "test"], default=None,
                   help="every scene of a suite instead of --scenes (dev: the code may be tuned on them; test: never looked at while tuning)")
    p.add_argument("--reduced", action="store_true", help="CI size: 128x96, 32 object-inclusive + 8 object-free captures")
    p.add_argument("--width", type=image_side, default=None, help="image width, 16..8192 (with --height; default 256, or 128 with --reduced)")
    p.add_argument("--height", type=image_side, default=None, help="image height, 16..8192 (with --width; default 192, or 96 with --reduced)")
    p.add_argument("--seed", type=nonneg_int, default=0, help="texture noise, camera jitter and photo-effect seed (default 0)")
    p.add_argument("--poses", choices=["scene", "generator", "colmap"], default="scene",
                   help="sparse/0 from the true poses (generator) or from pycolmap SfM on the images (colmap); "
                        "default: each scene's own (the realistic family: colmap)")
    p.add_argument("--overwrite", action="store_true", help="replace existing scene folders")
    p.add_argument("--list", action="store_true", help="print the scene catalogue (name, suite, family, views, poses) and exit")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def resolve_scenes(names: list[str]) -> list[str]:
    """Expand ``all`` (the ten benchmark scenes), keep order, drop duplicates; unknown names raise :class:`InputError`."""
    from dataset_tools.synth.catalogue import BENCHMARK_SCENES, scene_spec

    out: list[str] = []
    for n in names:
        for m in BENCHMARK_SCENES if n == "all" else [n]:
            scene_spec(m)
            if m not in out:
                out.append(m)
    if not out:
        raise InputError("--scenes: no scene selected")
    return out


def catalogue_lines() -> list[str]:
    """One line per catalogue scene: name, suite, family, object count, views, poses, whether its unseen
    share is below the minimum (``unseen<1%``), targets, description."""
    from dataset_tools.synth.catalogue import LOW_UNSEEN_SHARE, SCENES
    from dataset_tools.synth.visibility import MIN_UNSEEN_SHARE

    low = f"unseen<{100 * MIN_UNSEEN_SHARE:g}%"
    lines = []
    for name in sorted(SCENES):
        s = SCENES[name]
        kind = "multi" if len(s.objects) > 1 else "single"
        lines.append(f"{name:19s} {s.suite:4s} {s.family:9s} {kind:6s} views={s.n_views}+{s.n_test} poses={s.poses:9s} "
                     f"{low if name in LOW_UNSEEN_SHARE else '':{len(low)}s} targets={s.removal_targets} {s.description}")
    return lines


def share_line(path: Path) -> str:
    """The unseen share of a generated scene's test views, flagged when below the minimum."""
    from dataset_tools.synth.visibility import MIN_UNSEEN_SHARE, unseen_shares

    shares = list(unseen_shares(path).values())
    if not shares:
        return "  unseen share: no test views"
    mean = sum(shares) / len(shares)
    flag = "" if mean >= MIN_UNSEEN_SHARE else f"  BELOW {100 * MIN_UNSEEN_SHARE:g} %: leave it out of masked / ROI averages"
    return f"  unseen share of the test views: mean {100 * mean:.3f} %, min {100 * min(shares):.3f} %, max {100 * max(shares):.3f} %{flag}"


def run(args: argparse.Namespace) -> int:
    from dataset_tools.synth.catalogue import suite_scenes
    from dataset_tools.synth.generate import generate_scene
    from dataset_tools.synth.scene import build_scene

    if args.list:
        print("\n".join(catalogue_lines()))
        return 0
    if args.out is None:
        raise InputError("OUT: output folder required")
    if args.suite is not None and args.scenes is not None:
        raise InputError("--suite: give --scenes or --suite, not both")
    names = suite_scenes(args.suite) if args.suite is not None else resolve_scenes(args.scenes or ["all"])
    build_scene(names[0], reduced=args.reduced, width=args.width, height=args.height, seed=args.seed)  # validates size
    for n in names:
        target = args.out / n
        if target.exists() and not target.is_dir():
            raise InputError("exists and is not a folder", target)
        if target.exists() and not args.overwrite and any(target.iterdir()):
            raise InputError("scene folder exists and is not empty (pass --overwrite to replace it)", target)
    poses = None if args.poses == "scene" else args.poses
    for n in names:
        t0 = time.perf_counter()
        path = generate_scene(n, args.out, reduced=args.reduced, width=args.width, height=args.height,
                              seed=args.seed, overwrite=args.overwrite, progress=not args.quiet, poses=poses)
        print(f"wrote {path} ({time.perf_counter() - t0:.1f} s)")
        print(share_line(path))
    return 0
