"""``inpaint360gs-dataset <command> ...``: synthetic benchmark generation and dataset building."""

from __future__ import annotations

import sys

from inpaint360gs.cli import run_stages

COMMANDS: dict[str, tuple[str, str]] = {
    "synth": ("dataset_tools.synth.cli", "generate the embedded synthetic 360° inpainting benchmark"),
    "build": ("dataset_tools.capture.build_cli", "build a scene folder from object-inclusive + object-free photos (joint COLMAP)"),
    "unseen-masks": ("dataset_tools.capture.unseen_cli", "derive (from object masks) or import the test views' unseen masks"),
    "synth-colmap": ("dataset_tools.capture.synth_colmap_cli", "rebuild a generated synthetic scene's poses and sparse points through COLMAP"),
    "import": ("dataset_tools.capture.import_cli", "convert a 360-USID (AuraFusion360) or SPIn-NeRF scene, removing point leaks"),
    "validate": ("dataset_tools.capture.validate_cli", "check a scene folder (registration, masks, point leaks, split); exit 0 valid, 2 not"),
}


def main(argv: list[str] | None = None) -> int:
    return run_stages("inpaint360gs-dataset", COMMANDS, argv, __doc__.splitlines()[0])


if __name__ == "__main__":
    sys.exit(main())
