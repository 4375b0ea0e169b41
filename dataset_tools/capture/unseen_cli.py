"""``inpaint360gs-dataset unseen-masks SCENE``: write SCENE/unseen_mask/ for the test_ views.

Either derive them (``--object-masks DIR``: one mask per object-inclusive image, 255 = the objects
removed in the object-free capture) or import the user's own (``--import DIR``: one mask per test_
image, named like it or like the original photo).
"""

from __future__ import annotations

import argparse

import numpy as np

from dataset_tools.capture.unseen import (
    UnseenConfig,
    derive_unseen_masks,
    import_unseen_masks,
    load_object_masks,
    write_unseen_masks,
)
from inpaint360gs.cli.common import check_apart, check_writable, existing_dir, nonneg_int
from inpaint360gs.core.errors import InputError


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("scene", type=existing_dir, help="scene folder built by `build` (images/, sparse/0)")
    src = p.add_mutually_exclusive_group(required=True)
    src.add_argument("--object-masks", type=existing_dir, help="derive from these training-view object masks")
    src.add_argument("--import", dest="import_dir", type=existing_dir, help="validate and copy these unseen masks")
    p.add_argument("--mask-dilate", type=nonneg_int, default=UnseenConfig.mask_dilate_px,
                   help=f"derive: grow object masks by this many pixels ({UnseenConfig.mask_dilate_px})")
    p.add_argument("--depth-test", action="store_true",
                   help="derive: also count surfaces behind a training view's sparse depth as hidden")
    p.add_argument("--overwrite", action="store_true", help="replace an existing unseen_mask/")


def run(args: argparse.Namespace) -> int:
    target = args.scene / "unseen_mask"  # checked before any work: written last, atomically
    check_writable(target, folder=True)
    if target.is_dir() and any(target.iterdir()) and not args.overwrite:
        raise InputError("output folder exists and is not empty (pass --overwrite to replace it)", target)
    check_apart({"SCENE/unseen_mask": target}, {"--object-masks": args.object_masks, "--import": args.import_dir})
    if not (args.scene / "images").is_dir():
        raise InputError("missing images/ folder", args.scene / "images")
    if args.import_dir is not None:
        masks, ignored = import_unseen_masks(args.scene, args.import_dir)
        for name in ignored:
            print(f"  ignored (no matching test_ image): {args.import_dir / name}")
        how = f"imported from {args.import_dir}"
    else:
        cfg = UnseenConfig(mask_dilate_px=args.mask_dilate, depth_test=args.depth_test)
        masks = derive_unseen_masks(args.scene, load_object_masks(args.scene, args.object_masks), cfg)
        how = f"derived from {args.object_masks} and sparse/0"
    target = write_unseen_masks(args.scene, masks, overwrite=args.overwrite)
    frac = np.mean([m.mean() for m in masks.values()]) * 100
    print(f"wrote {len(masks)} unseen masks to {target} ({how}); mean unseen area {frac:.1f}% of the image")
    return 0
