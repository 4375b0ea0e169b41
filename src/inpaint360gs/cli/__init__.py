"""``inpaint360gs <stage> ...``: one subcommand per pipeline stage.

Each stage lives in its own module that defines ``add_arguments(parser)`` and ``run(args) -> int``;
modules are imported only when their stage runs, so ``--help`` stays fast. Errors in user input
(:class:`~inpaint360gs.core.errors.InputError`) and diverged training print one line and exit non-zero.
"""

from __future__ import annotations

import argparse
import importlib
import sys

# stage name -> (module, one-line help)
STAGES: dict[str, tuple[str, str]] = {
    "train": ("inpaint360gs.cli.train", "train 3D Gaussian Splatting on a scene folder"),
    "render": ("inpaint360gs.cli.render", "render a trained model at a scene's cameras"),
    "table": ("inpaint360gs.cli.table", "collect per-scene metrics.json files into CSV/Markdown tables"),
}


def run_stages(prog: str, stages: dict[str, tuple[str, str]], argv: list[str] | None, description: str) -> int:
    """Shared dispatcher for ``inpaint360gs`` and ``inpaint360gs-dataset``."""
    from inpaint360gs.core.errors import InputError, TrainingDivergedError

    parser = argparse.ArgumentParser(prog=prog, description=description)
    sub = parser.add_subparsers(dest="stage", metavar="STAGE", required=True)
    argv = sys.argv[1:] if argv is None else argv
    wanted = argv[0] if argv and not argv[0].startswith("-") else None
    for name, (module, help_text) in stages.items():
        p = sub.add_parser(name, help=help_text, description=help_text)
        if name == wanted:  # import only the module that runs
            importlib.import_module(module).add_arguments(p)
    args = parser.parse_args(argv)
    try:
        return int(importlib.import_module(stages[args.stage][0]).run(args) or 0)
    except InputError as e:
        print(f"{prog} {args.stage}: error: {e}", file=sys.stderr)
        return 2
    except TrainingDivergedError as e:
        print(f"{prog} {args.stage}: training diverged: {e}", file=sys.stderr)
        return 3
    except KeyboardInterrupt:
        print(f"{prog} {args.stage}: interrupted", file=sys.stderr)
        return 130


def main(argv: list[str] | None = None) -> int:
    return run_stages("inpaint360gs", STAGES, argv, __doc__.splitlines()[0])


if __name__ == "__main__":
    sys.exit(main())
