"""``inpaint360gs <stage> ...``: one subcommand per pipeline stage.

Each stage is a module of this package that defines ``add_arguments(parser)`` and ``run(args) -> int``
and is a thin shell over a library function; modules are imported only when their stage runs, so
``--help`` stays fast. The shared layer (:mod:`.common`) turns every failure into one line and a
documented exit code.
"""

from __future__ import annotations

import sys

from inpaint360gs.cli.common import run_stages

# stage name -> (module, one-line help)
STAGES: dict[str, tuple[str, str]] = {
    "train": ("inpaint360gs.cli.train", "train 3D Gaussian Splatting on a scene folder"),
    "render": ("inpaint360gs.cli.render", "render a trained model at a scene's cameras"),
    "distill": ("inpaint360gs.cli.distill", "distill associated object masks into identity features of a trained model (Sec. 3.3)"),
    "table": ("inpaint360gs.cli.table", "collect per-scene metrics.json files into CSV/Markdown tables"),
}


def main(argv: list[str] | None = None) -> int:
    return run_stages("inpaint360gs", STAGES, argv, __doc__.splitlines()[0])


__all__ = ["STAGES", "main", "run_stages"]

if __name__ == "__main__":
    sys.exit(main())
