"""``inpaint360gs-dataset import {360usid,spinnerf} SRC OUT``: convert a released scene, removing point leaks."""

from __future__ import annotations

import argparse

from dataset_tools.capture.importers import LAYOUTS, import_360usid, import_spinnerf
from inpaint360gs.cli.common import check_apart, existing_dir, output_dir, positive_int


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("layout", choices=LAYOUTS, help="source layout: 360usid (AuraFusion360) or spinnerf")
    p.add_argument("src", type=existing_dir, help="one scene folder of the source dataset")
    p.add_argument("out", type=output_dir, help="scene folder to write (Inpaint360GS layout)")
    p.add_argument("--n-test", type=positive_int, default=40,
                   help="spinnerf: the first N images (sorted) are the object-free views (40 in the release)")
    p.add_argument("--overwrite", action="store_true")


def run(args: argparse.Namespace) -> int:
    check_apart({"OUT": args.out}, {"SRC": args.src})
    if args.layout == "360usid":
        report = import_360usid(args.src, args.out, overwrite=args.overwrite)
    else:
        report = import_spinnerf(args.src, args.out, n_test=args.n_test, overwrite=args.overwrite)
    print(report.format())
    return 0
