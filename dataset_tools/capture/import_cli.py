"""``inpaint360gs-dataset import {360usid,spinnerf} SRC OUT``: convert a released scene, removing point leaks."""

from __future__ import annotations

import argparse
from pathlib import Path

from dataset_tools.capture.importers import LAYOUTS, import_360usid, import_spinnerf


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("layout", choices=LAYOUTS, help="source layout: 360usid (AuraFusion360) or spinnerf")
    p.add_argument("src", type=Path, help="one scene folder of the source dataset")
    p.add_argument("out", type=Path, help="scene folder to write (Inpaint360GS layout)")
    p.add_argument("--n-test", type=int, default=40,
                   help="spinnerf: the first N images (sorted) are the object-free views (40 in the release)")
    p.add_argument("--overwrite", action="store_true")


def run(args: argparse.Namespace) -> int:
    if args.layout == "360usid":
        report = import_360usid(args.src, args.out, overwrite=args.overwrite)
    else:
        report = import_spinnerf(args.src, args.out, n_test=args.n_test, overwrite=args.overwrite)
    print(report.format())
    return 0
