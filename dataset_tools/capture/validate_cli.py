"""``inpaint360gs-dataset validate SCENE``: pass/fail report on a scene folder; exit code 0 = valid, 1 = not."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from dataset_tools.capture.validate import validate_scene
from inpaint360gs.io.atomic import write_text


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("scene", type=Path, help="scene folder (Inpaint360GS layout)")
    p.add_argument("--no-unseen-masks", action="store_true", help="unseen_mask/ is optional (e.g. before unseen-masks ran)")
    p.add_argument("--json", type=Path, default=None, help="also write the report as JSON here")


def run(args: argparse.Namespace) -> int:
    report = validate_scene(args.scene, require_unseen_masks=not args.no_unseen_masks)
    print(report.format())
    if args.json is not None:
        write_text(args.json, json.dumps(report.to_dict(), indent=2) + "\n")
    return 0 if report.ok else 1
