"""``inpaint360gs-dataset validate SCENE``: pass/fail report on a scene folder.

The report goes to stdout (and to ``--json``); exit code 0 = valid, 2 = not valid, with one line on
stderr naming the failed checks (the shared exit codes, docs/architecture.md, "Reliability": 1 stays
"internal error", so a script can tell a bad scene from a crash).
"""

from __future__ import annotations

import argparse
import json

from dataset_tools.capture.validate import validate_scene
from inpaint360gs.cli.common import check_apart, existing_dir, output_file
from inpaint360gs.core.errors import InputError
from inpaint360gs.io.atomic import write_text


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("scene", type=existing_dir, help="scene folder (Inpaint360GS layout)")
    p.add_argument("--no-unseen-masks", action="store_true", help="unseen_mask/ is optional (e.g. before unseen-masks ran)")
    p.add_argument("--json", type=output_file, default=None, help="also write the report as JSON here")


def run(args: argparse.Namespace) -> int:
    check_apart({"--json": args.json}, {"SCENE": args.scene}, replaced=False)  # never inside the scene being validated
    report = validate_scene(args.scene, require_unseen_masks=not args.no_unseen_masks)
    print(report.format())
    if args.json is not None:
        write_text(args.json, json.dumps(report.to_dict(), indent=2) + "\n")
    if not report.ok:
        failed = "; ".join(f"{c.name}: {c.detail}" for c in report.failed())
        raise InputError(f"not a valid scene ({len(report.failed())} check(s) failed): {failed}", args.scene)
    return 0
