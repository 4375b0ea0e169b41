"""``inpaint360gs-dataset synth OUT [--scenes NAME ...|all] [--reduced] [--width W --height H] [--seed S] [--overwrite]``.

Writes one folder per scene under OUT, each atomically; every argument is checked and every target
folder is tested for conflicts before the first scene is rendered, so an error writes nothing.
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
    p.add_argument("--scenes", nargs="+", default=["all"], metavar="NAME", help="scene names, or 'all' (default)")
    p.add_argument("--reduced", action="store_true", help="CI size: 128x96, 32 object-inclusive + 8 object-free captures")
    p.add_argument("--width", type=image_side, default=None, help="image width, 16..8192 (with --height; default 256, or 128 with --reduced)")
    p.add_argument("--height", type=image_side, default=None, help="image height, 16..8192 (with --width; default 192, or 96 with --reduced)")
    p.add_argument("--seed", type=nonneg_int, default=0, help="texture noise and camera jitter seed (default 0)")
    p.add_argument("--overwrite", action="store_true", help="replace existing scene folders")
    p.add_argument("--list", action="store_true", help="print the scene catalogue and exit")
    p.add_argument("--quiet", action="store_true", help="no progress bar")


def resolve_scenes(names: list[str]) -> list[str]:
    """Expand ``all``, keep order, drop duplicates; unknown names raise :class:`InputError`."""
    from dataset_tools.synth.catalogue import SCENES, scene_spec

    out: list[str] = []
    for n in names:
        for m in sorted(SCENES) if n == "all" else [n]:
            scene_spec(m)
            if m not in out:
                out.append(m)
    if not out:
        raise InputError("--scenes: no scene selected")
    return out


def run(args: argparse.Namespace) -> int:
    from dataset_tools.synth.catalogue import SCENES
    from dataset_tools.synth.generate import generate_scene
    from dataset_tools.synth.scene import build_scene

    if args.list:
        for name in sorted(SCENES):
            s = SCENES[name]
            kind = "multi" if len(s.objects) > 1 else "single"
            print(f"{name:8s} {kind:6s} targets={s.removal_targets} {s.description}")
        return 0
    if args.out is None:
        raise InputError("OUT: output folder required")
    names = resolve_scenes(args.scenes)
    build_scene(names[0], reduced=args.reduced, width=args.width, height=args.height, seed=args.seed)  # validates size
    for n in names:
        target = args.out / n
        if target.exists() and not target.is_dir():
            raise InputError("exists and is not a folder", target)
        if target.exists() and not args.overwrite and any(target.iterdir()):
            raise InputError("scene folder exists and is not empty (pass --overwrite to replace it)", target)
    for n in names:
        t0 = time.perf_counter()
        path = generate_scene(n, args.out, reduced=args.reduced, width=args.width, height=args.height,
                              seed=args.seed, overwrite=args.overwrite, progress=not args.quiet)
        print(f"wrote {path} ({time.perf_counter() - t0:.1f} s)")
    return 0
