"""``inpaint360gs-dataset <command> ...``: synthetic benchmark generation and dataset building."""

from __future__ import annotations

import sys

from inpaint360gs.cli import run_stages

COMMANDS: dict[str, tuple[str, str]] = {
    "synth": ("dataset_tools.synth.cli", "generate the embedded synthetic 360° inpainting benchmark"),
}


def main(argv: list[str] | None = None) -> int:
    return run_stages("inpaint360gs-dataset", COMMANDS, argv, __doc__.splitlines()[0])


if __name__ == "__main__":
    sys.exit(main())
