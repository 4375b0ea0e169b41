"""``inpaint360gs-dataset build CAPTURES OUT``: joint COLMAP of object-inclusive + object-free photos.

CAPTURES is either two folders, ``with_objects/`` and ``without_objects/``, or one folder in which the
object-free photos are named ``test_*``. The object-free photos are optional: without them the scene
has no ground truth (no test_ views; scene.json says so). See dataset_tools/capture/README.md.

Each option's ``dest`` is the name of the ``BuildConfig``, ``CaptureConfig`` or ``SfMConfig`` field it sets.
"""

from __future__ import annotations

import argparse
from dataclasses import fields

from dataset_tools.capture.captures import CaptureConfig
from dataset_tools.capture.colmap import SFM_MAX_SIZE, SUPPORTED_MODELS, SfMConfig
from dataset_tools.capture.pipeline import BuildConfig, build_dataset
from inpaint360gs.cli.common import check_apart, existing_dir, fraction, nonneg_int, number, output_dir, positive_int


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("captures", type=existing_dir, help="folder of photos (with_objects/ [+ without_objects/], or one folder where object-free photos "
                        "are named test_*); without object-free photos the scene has no ground truth")
    p.add_argument("out", type=output_dir, help="scene folder to write (Inpaint360GS layout)")
    p.add_argument("--matcher", choices=["exhaustive", "sequential", "auto"], default="auto",
                   help="pair selection: exhaustive for small sets, sequential (photos named in capture order) "
                        "for large ones; auto picks exhaustive up to --exhaustive-max images (default: auto)")
    p.add_argument("--exhaustive-max", dest="exhaustive_max_images", type=positive_int, default=150, metavar="N",
                   help="auto: largest set matched exhaustively (150)")
    p.add_argument("--overlap", type=positive_int, default=10, help="sequential: neighbours per side (10)")
    p.add_argument("--cross-pairs", type=positive_int, default=20,
                   help="sequential: object-inclusive partners per object-free photo (20)")
    p.add_argument("--camera-model", choices=SUPPORTED_MODELS, default="SIMPLE_RADIAL",
                   help="shared camera model; distortion models are undistorted to PINHOLE (SIMPLE_RADIAL)")
    p.add_argument("--camera-params", default="", help="initial intrinsics, comma-separated, in the model's order")
    p.add_argument("--downscale", type=positive_int, nargs="*", default=[], metavar="F",
                   help="also write images_F/ copies, e.g. --downscale 2 4 8")
    p.add_argument("--with-dir", default="with_objects", help="sub-folder of object-inclusive photos")
    p.add_argument("--without-dir", default="without_objects", help="sub-folder of object-free photos (optional)")
    p.add_argument("--test-prefix", default="test_", help="one-folder layout: prefix of object-free photos")
    p.add_argument("--unseen-masks", type=existing_dir, default=None,
                   help="folder of unseen masks (one per object-free photo, same stem, 255 = unseen); copied to unseen_mask/")
    p.add_argument("--min-train-views", type=positive_int, default=2,
                   help="keep a sparse point only when at least this many object-inclusive photos observe it "
                        "(default 2: one ray does not fix a depth; 1: drop only points no such photo sees)")
    p.add_argument("--min-train-angle", type=number(float, lo=0.0, hi=90.0, hi_open=True), default=1.5, metavar="DEG",
                   help="... and when their rays span at least DEG degrees (default 1.5, COLMAP's minimum "
                        "triangulation angle: nearly parallel rays do not fix a depth either; 0 turns this off)")
    p.add_argument("--remove-unseen-points", action="store_true",
                   help="also delete sparse points that an object-free view observes inside its unseen mask")
    p.add_argument("--skip-unreadable", action="store_true", help="skip corrupt photos (reported) instead of failing")
    reg = p.add_mutually_exclusive_group()
    reg.add_argument("--min-registered", type=fraction, default=0.9, metavar="FRACTION",
                     help="fail, naming the photos SfM could not place, when fewer than this share of all photos "
                          "register (default 0.9); photos left out of a model that passes are skipped and reported")
    reg.add_argument("--allow-partial", dest="min_registered", action="store_const", const=0.0,
                     help="keep the model however few photos register (--min-registered 0)")
    reg.add_argument("--require-all-registered", dest="min_registered", action="store_const", const=1.0,
                     help="fail when any photo cannot be registered (--min-registered 1)")
    p.add_argument("--sfm-max-size", dest="sfm_max_size", type=nonneg_int, default=SFM_MAX_SIZE, metavar="PX",
                   help=f"working size of SfM (default {SFM_MAX_SIZE}; 0: full size): features and matching run on "
                        "copies whose longest side is PX pixels (never enlarged), the cameras are mapped back to the "
                        "full-size photos, which the scene keeps")
    p.add_argument("--no-affine-shape", dest="estimate_affine_shape", action="store_false",
                   help="plain SIFT (oriented disks) instead of affine-covariant SIFT: faster features, fewer matches "
                        "between photos taken far apart")
    p.add_argument("--max-features", dest="max_num_features", type=positive_int, default=8192, metavar="N",
                   help="SIFT features per image (8192)")
    p.add_argument("--threads", dest="num_threads", type=positive_int, default=2, metavar="N", help="COLMAP threads (2)")
    p.add_argument("--seed", type=nonneg_int, default=0)
    p.add_argument("--name", dest="scene_name", default=None, help="scene name in scene.json (default: OUT's folder name)")
    p.add_argument("--overwrite", action="store_true", help="replace OUT if it exists")
    p.add_argument("--verbose", action="store_true", help="show COLMAP's log")
    p.add_argument("--no-progress", action="store_true")


def _config(cls, args: argparse.Namespace, **given):
    """``cls(**given)``, its other fields taken from the options of the same name (the rest keep their defaults)."""
    options = vars(args)
    return cls(**given, **{f.name: options[f.name] for f in fields(cls) if f.name in options and f.name not in given})


def config_from_args(args: argparse.Namespace) -> BuildConfig:
    return _config(BuildConfig, args, captures=_config(CaptureConfig, args), sfm=_config(SfMConfig, args),
                   downscale=tuple(args.downscale), progress=not args.no_progress)


def run(args: argparse.Namespace) -> int:
    check_apart({"OUT": args.out}, {"CAPTURES": args.captures, "--unseen-masks": args.unseen_masks})
    report = build_dataset(args.captures, args.out, config_from_args(args))
    print(report.format())
    return 0
