"""Joint structure-from-motion of all captures with pycolmap: one shared camera, one coordinate frame.

The paper's dataset (supp. Sec. A) processes the object-inclusive and the object-free sequence of a
scene jointly with COLMAP, every image sharing one set of intrinsics, and undistorts to a pinhole
model. This module runs that with pycolmap (SIFT extraction, matching, incremental mapping,
undistortion); it does not decide what goes into the scene folder (see ``pipeline.py``).

Matching (``SfMConfig.matcher``):

* ``exhaustive``: every pair; best for small captures (cost grows with N²: ~15 s for 64 images of
  256×192 on 2 cores).
* ``sequential``: vocabulary-free pairs for long captures taken as walks around the scene:
  each image with its ``overlap`` neighbours (and ``2^k`` further ones) inside its own sequence,
  wrapping around because a 360° orbit closes, plus every object-free image against
  ``cross_pairs`` evenly spaced object-inclusive images so both sequences land in one frame.
  Photos must be named in capture order. (A vocabulary tree would need a downloaded tree file.)
* ``auto``: exhaustive up to ``exhaustive_max_images`` images, sequential above.
"""

from __future__ import annotations

import contextlib
import itertools
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pycolmap

from inpaint360gs.core.errors import InputError
from inpaint360gs.io.colmap import PINHOLE_MODELS, colmap_log

# SfM camera models: the distortion-free ones (nothing to undistort), then those undistorted to PINHOLE.
SUPPORTED_MODELS = PINHOLE_MODELS + ("SIMPLE_RADIAL", "RADIAL", "OPENCV", "FULL_OPENCV")

ProgressFn = Callable[[str, int, int], None]  # (stage, done, total)


@dataclass
class SfMConfig:
    """Options of the joint SfM; defaults are COLMAP's unless a comment says otherwise."""

    camera_model: str = "SIMPLE_RADIAL"  # COLMAP's default for photos; PINHOLE/SIMPLE_PINHOLE skip undistortion
    camera_params: str = ""  # optional initial intrinsics, comma-separated in the model's order
    matcher: str = "auto"  # exhaustive | sequential | auto (see module docstring)
    exhaustive_max_images: int = 150  # auto: exhaustive up to this many images (~N²/2 pairs)
    overlap: int = 10  # sequential: neighbours matched on each side within a sequence
    cross_pairs: int = 20  # sequential: object-inclusive partners of each object-free image
    max_num_features: int = 8192  # SIFT features per image (COLMAP default)
    max_image_size: int = 3200  # longer side is downscaled to this for extraction (COLMAP GUI default)
    # registering an image needs this many 2D-3D inliers, and this share of its matches inliers
    abs_pose_min_num_inliers: int = 30
    abs_pose_min_inlier_ratio: float = 0.25
    num_threads: int = 2  # this machine has 2 cores
    seed: int = 0  # RANSAC/mapper seeds: bit-identical runs with num_threads=1; with more, ~1e-4 relative jitter
    verbose: bool = False  # show COLMAP's own log

    def __post_init__(self) -> None:
        if self.matcher not in ("exhaustive", "sequential", "auto"):
            raise InputError(f"unknown matcher '{self.matcher}' (exhaustive, sequential, auto)", "--matcher")
        if self.camera_model not in SUPPORTED_MODELS:
            raise InputError(
                f"unsupported camera model '{self.camera_model}' ({', '.join(SUPPORTED_MODELS)})", "--camera-model"
            )
        if self.camera_params:
            parse_camera_params(self.camera_model, self.camera_params)


def parse_camera_params(model: str, text: str) -> list[float]:
    """Initial intrinsics ``text`` ("f,cx,cy,k", ...) for camera ``model``, checked before any SfM work:
    the model's number of parameters, finite numbers, positive focal lengths (COLMAP would stop deep
    inside feature extraction)."""
    names = [n.strip() for n in pycolmap.Camera(model=model, width=1, height=1).params_info.split(",")]
    items = [t.strip() for t in text.split(",")]
    if len(items) != len(names):
        raise InputError(f"{model} takes {len(names)} parameters ({', '.join(names)}), got {len(items)}: {text!r}", "--camera-params")
    try:
        values = [float(t) for t in items]
    except ValueError:
        raise InputError(f"expected {len(names)} comma-separated numbers ({', '.join(names)}), got {text!r}", "--camera-params") from None
    for name, v in zip(names, values):
        if not np.isfinite(v) or (name in ("f", "fx", "fy") and v <= 0):
            raise InputError(f"{name} must be a finite number{' > 0' if name.startswith('f') else ''}, got {v:g}", "--camera-params")
    return values


@dataclass
class SfMResult:
    """The chosen (largest) reconstruction and what did not make it into it."""

    reconstruction: pycolmap.Reconstruction
    unregistered: list[str]  # image names not in the chosen model, sorted
    model_sizes: list[int]  # registered images of every model COLMAP produced, largest first
    matcher: str  # the strategy actually used
    num_pairs: int
    timings: dict[str, float] = field(default_factory=dict)


def _pair_list(names: Sequence[str], free: set[str], cfg: SfMConfig) -> tuple[list[tuple[str, str]], str]:
    """Image pairs to match, and the strategy name."""
    strategy = cfg.matcher
    if strategy == "auto":
        strategy = "exhaustive" if len(names) <= cfg.exhaustive_max_images else "sequential"
    if strategy == "exhaustive":
        return list(itertools.combinations(names, 2)), strategy
    pairs: set[tuple[str, str]] = set()
    inclusive = [n for n in names if n not in free]
    object_free = [n for n in names if n in free]
    for seq in (inclusive, object_free):
        n = len(seq)
        offsets = set(range(1, cfg.overlap + 1)) | {2**k for k in range(int(np.log2(max(n, 2))) + 1)}
        for i in range(n):
            for d in offsets:
                if d < n:
                    a, b = seq[i], seq[(i + d) % n]  # wraps: a 360° orbit closes on itself
                    pairs.add((a, b) if a < b else (b, a))
    if inclusive:
        k = min(cfg.cross_pairs, len(inclusive))
        for j, f in enumerate(object_free):
            # evenly spaced partners; successive object-free images shift them by a fraction of the
            # spacing, so that together they reach every object-inclusive image
            start = (j * len(inclusive)) // (k * max(len(object_free), 1))
            for m in range(k):
                a = inclusive[(start + (m * len(inclusive)) // k) % len(inclusive)]
                pairs.add((a, f) if a < f else (f, a))
    return sorted(pairs), strategy


def run_sfm(
    image_dir: Path,
    names: Sequence[str],
    object_free: set[str],
    work_dir: Path,
    cfg: SfMConfig,
    progress: ProgressFn | None = None,
) -> SfMResult:
    """Extract, match and map ``names`` (files in ``image_dir``) with one shared camera.

    Returns the largest model; images outside it are listed as unregistered (COLMAP may split a
    capture into several models when parts of it do not overlap).
    """
    progress = progress or (lambda stage, done, total: None)
    work_dir.mkdir(parents=True, exist_ok=True)
    db_path = work_dir / "database.db"
    names = list(names)
    timings: dict[str, float] = {}
    pycolmap.set_random_seed(cfg.seed)
    with colmap_log(cfg.verbose):
        # --- features: chunked so that progress can be shown; chunks after the first reuse the camera
        t0 = time.perf_counter()
        reader = pycolmap.ImageReaderOptions()
        reader.camera_model = cfg.camera_model
        if cfg.camera_params:
            reader.camera_params = cfg.camera_params
        extraction = pycolmap.FeatureExtractionOptions()
        extraction.num_threads = cfg.num_threads
        extraction.max_image_size = cfg.max_image_size
        extraction.sift.max_num_features = cfg.max_num_features
        chunk = 8
        for i in range(0, len(names), chunk):
            pycolmap.extract_features(
                db_path,
                image_dir,
                image_names=names[i : i + chunk],
                camera_mode=pycolmap.CameraMode.SINGLE,
                reader_options=reader,
                extraction_options=extraction,
                device=pycolmap.Device.cpu,
            )
            if i == 0:
                with contextlib.closing(pycolmap.Database.open(db_path)) as db:
                    cams = db.read_all_cameras()
                    if len(cams) != 1:
                        raise InputError(f"expected one shared camera, COLMAP created {len(cams)}", image_dir)
                    reader.existing_camera_id = cams[0].camera_id
            progress("features", min(i + chunk, len(names)), len(names))
        with contextlib.closing(pycolmap.Database.open(db_path)) as db:
            if db.num_cameras() != 1 or db.num_images() != len(names):
                raise InputError(
                    f"feature extraction read {db.num_images()} of {len(names)} images into "
                    f"{db.num_cameras()} camera(s)",
                    image_dir,
                )
        timings["features_s"] = time.perf_counter() - t0

        # --- matching + two-view geometric verification, in blocks of pairs (progress)
        t0 = time.perf_counter()
        pairs, strategy = _pair_list(names, object_free, cfg)
        matching = pycolmap.FeatureMatchingOptions()
        matching.num_threads = cfg.num_threads
        verification = pycolmap.TwoViewGeometryOptions()
        verification.ransac.random_seed = cfg.seed
        block = 256
        pair_file = work_dir / "pairs.txt"
        for i in range(0, len(pairs), block):
            pair_file.write_text("".join(f"{a} {b}\n" for a, b in pairs[i : i + block]))
            pairing = pycolmap.ImportedPairingOptions()
            pairing.match_list_path = pair_file
            pycolmap.match_image_pairs(
                db_path,
                matching_options=matching,
                pairing_options=pairing,
                verification_options=verification,
                device=pycolmap.Device.cpu,
            )
            progress("matching", min(i + block, len(pairs)), len(pairs))
        timings["matching_s"] = time.perf_counter() - t0

        # --- incremental mapping
        t0 = time.perf_counter()
        opts = pycolmap.IncrementalPipelineOptions()
        opts.num_threads = cfg.num_threads
        opts.random_seed = cfg.seed
        opts.mapper.random_seed = cfg.seed
        opts.mapper.abs_pose_min_num_inliers = cfg.abs_pose_min_num_inliers
        opts.mapper.abs_pose_min_inlier_ratio = cfg.abs_pose_min_inlier_ratio
        opts.triangulation.random_seed = cfg.seed
        sparse_dir = work_dir / "sparse"
        sparse_dir.mkdir(exist_ok=True)
        registered = [0]

        def _next_image() -> None:
            registered[0] += 1
            progress("mapping", min(registered[0], len(names)), len(names))

        models = pycolmap.incremental_mapping(
            db_path, image_dir, sparse_dir, options=opts, next_image_callback=_next_image
        )
        timings["mapping_s"] = time.perf_counter() - t0
    if not models:
        raise InputError("COLMAP could not reconstruct the scene (no image pair with enough matches)", image_dir)
    ordered = sorted(models.values(), key=lambda r: r.num_reg_images(), reverse=True)
    best = ordered[0]
    reg = {best.image(i).name for i in best.reg_image_ids()}
    progress("mapping", len(reg), len(names))
    return SfMResult(
        reconstruction=best,
        unregistered=sorted(set(names) - reg),
        model_sizes=[r.num_reg_images() for r in ordered],
        matcher=strategy,
        num_pairs=len(pairs),
        timings=timings,
    )


def needs_undistortion(rec: pycolmap.Reconstruction) -> bool:
    """True when some camera of ``rec`` has a distortion model."""
    return any(c.model_name not in PINHOLE_MODELS for c in rec.cameras.values())


def undistort(rec_dir: Path, image_dir: Path, out_dir: Path, num_threads: int = 2, verbose: bool = False) -> Path:
    """Undistort ``rec_dir``'s images to a PINHOLE camera with pycolmap; returns the output folder.

    ``out_dir/images`` and ``out_dir/sparse`` hold the result. COLMAP crops to the valid region, so the
    image size may shrink by a few pixels.
    """
    with colmap_log(verbose):
        pycolmap.undistort_images(out_dir, rec_dir, image_dir, num_threads=num_threads)
    return out_dir


def undistortion_options() -> pycolmap.UndistortCameraOptions:
    """The options ``undistort`` uses (pycolmap defaults), for warping masks the same way."""
    return pycolmap.UndistortCameraOptions()


def undistort_mask(mask: np.ndarray, camera: pycolmap.Camera) -> np.ndarray:
    """Warp a binary (H, W) mask taken with ``camera`` into the undistorted PINHOLE image."""
    bitmap = pycolmap.Bitmap.from_array(np.ascontiguousarray(mask.astype(np.uint8) * 255))
    out, _ = pycolmap.undistort_image(undistortion_options(), bitmap, camera)
    return out.to_array() >= 128
