"""Joint structure-from-motion of all captures with pycolmap: one shared camera, one coordinate frame.

The paper's dataset (supp. Sec. A) processes the object-inclusive and the object-free sequence of a
scene jointly with COLMAP, every image sharing one set of intrinsics, and undistorts to a pinhole
model. This module runs that with pycolmap (SIFT extraction, matching, incremental mapping,
undistortion); it does not decide what goes into the scene folder (see ``pipeline.py``).

SfM runs at a working size (``SfMConfig.sfm_max_size``, see ``SFM_MAX_SIZE``): on copies of the photos
shrunk by one factor on both axes, whose camera and 2D observations are then mapped back to the
full-size photos (``rescale_reconstruction``); poses and points do not depend on the image size.

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
import os
import shutil
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np
import pycolmap
from PIL import Image

from inpaint360gs.core.errors import InputError
from inpaint360gs.io.colmap import PINHOLE_MODELS, colmap_log

# SfM camera models: the distortion-free ones (nothing to undistort), then those undistorted to PINHOLE.
SUPPORTED_MODELS = PINHOLE_MODELS + ("SIMPLE_RADIAL", "RADIAL", "OPENCV", "FULL_OPENCV")

ProgressFn = Callable[[str, int, int], None]  # (stage, done, total)

# Working size of SfM (``SfMConfig.sfm_max_size``): features, matching and mapping run on copies
# whose longest side is this many pixels; the poses and intrinsics are then mapped back to the
# full-size photos, which the scene keeps. Feature extraction costs about the number of pixels and
# exhaustive matching the square of the features per photo, so the size sets the time; too small
# and SIFT finds too few features to link photos taken far apart. On a real walk-around, 800 keeps a
# step of margin above the smallest size that registered every photo, in less time than 1000, with
# poses that agree with those at full size (results/README.md, "Building datasets through COLMAP").
SFM_MAX_SIZE = 800


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
    # registering an image needs this many 2D-3D inliers, and this share of its matches inliers
    abs_pose_min_num_inliers: int = 30
    abs_pose_min_inlier_ratio: float = 0.25
    # Affine-covariant SIFT (oriented ellipses instead of disks; COLMAP's option for hard, wide-baseline
    # sets): neighbouring photos of a walk-around see surfaces (table tops, floors) under quite
    # different slants, which distorts a disk-shaped patch. Not upright SIFT: photos may be rotated.
    estimate_affine_shape: bool = True
    sfm_max_size: int = SFM_MAX_SIZE  # working size: longest side of the copies SfM runs on (0: full size)
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
    sfm_size: tuple[int, int]  # (width, height) of the images SfM ran on (the working size)
    scale: float  # sfm_size / the photos' size; the reconstruction is already mapped back to full size
    working_reprojection_error_px: float  # mean reprojection error in pixels of the working size
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


def working_scale(width: int, height: int, max_size: int) -> float:
    """Scale factor of the SfM copies: their longest side becomes ``max_size`` (never enlarged; 0 = full size)."""
    longest = max(width, height)
    return 1.0 if max_size <= 0 or longest <= max_size else max_size / longest


# formats whose files can carry EXIF (COLMAP reads a focal-length prior from it)
_EXIF_FORMATS = {"JPEG", "PNG", "TIFF", "WEBP"}


def write_working_copy(src: Path, dst: Path, scale: float) -> tuple[int, int]:
    """Write ``src`` shrunk by ``scale`` to ``dst`` (same format and name; EXIF kept); returns (w, h).

    The pixels keep their stored order (no EXIF rotation, as COLMAP reads the original). The map is
    exactly isotropic: OpenCV resizes with the given factor for both axes, so a point at ``x`` (COLMAP's
    convention, pixel centres at +0.5) in the photo is at ``scale * x`` in the copy, whatever the
    rounding of the copy's size. Area averaging: no aliasing for SIFT.
    """
    with Image.open(src) as im:
        fmt, exif = im.format, im.info.get("exif")
        if im.mode.startswith("I"):  # 16-bit grey: 65535 -> 255, as an 8-bit reader maps it
            arr = np.clip(np.asarray(im, np.float64) / 257.0, 0, 255).round().astype(np.uint8)
        else:
            arr = np.asarray(im if im.mode in ("L", "RGB") else im.convert("RGB"))
    fmt = "JPEG" if fmt == "MPO" else fmt  # a camera's multi-picture JPEG: its first picture, as COLMAP reads it
    small = cv2.resize(arr, (0, 0), fx=scale, fy=scale, interpolation=cv2.INTER_AREA)
    kwargs: dict = {"quality": 95} if fmt == "JPEG" else {"compress_level": 1} if fmt == "PNG" else {}
    if exif and fmt in _EXIF_FORMATS:
        kwargs["exif"] = exif
    Image.fromarray(small).save(dst, format=fmt, **kwargs)
    return small.shape[1], small.shape[0]


def _link_or_copy(src: Path, dst: Path) -> None:
    """``dst`` as a hard link to ``src`` (no copy of the bytes), or a copy where links are not possible."""
    dst.unlink(missing_ok=True)
    try:
        os.link(src, dst)
    except OSError:
        shutil.copyfile(src, dst)


def rescale_reconstruction(rec: pycolmap.Reconstruction, scale: float, width: int, height: int) -> None:
    """Map a reconstruction made on copies shrunk by ``scale`` back to the ``width`` x ``height`` photos.

    Poses and 3D points do not change with the image size; focal lengths, principal points and the 2D
    observations are divided by ``scale`` (exact for copies from :func:`write_working_copy`). Distortion
    parameters act on normalised coordinates and stay as they are.
    """
    for cam in rec.cameras.values():
        params = np.array(cam.params, dtype=float)
        idx = list(cam.focal_length_idxs()) + list(cam.principal_point_idxs())
        params[idx] /= scale
        cam.width, cam.height = width, height
        cam.params = params
    for image in rec.images.values():
        for p in image.points2D:
            p.xy = p.xy / scale
    rec.update_point_3d_errors()  # the stored per-point errors were in pixels of the copies


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

    # --- working copies (SfMConfig.sfm_max_size) under plain names; the photos stay as they are.
    # COLMAP's pair list is space-separated text: a photo named "IMG 0010.png" would be read as two
    # names and silently never matched. Every photo is given to COLMAP as <index><suffix> and its
    # own name is put back in the model.
    t0 = time.perf_counter()
    with Image.open(image_dir / names[0]) as im:
        full_size = im.size
    scale = working_scale(*full_size, cfg.sfm_max_size)
    sfm_size = full_size
    alias = {n: f"{i:06d}{Path(n).suffix.lower()}" for i, n in enumerate(names)}
    original = {a: n for n, a in alias.items()}
    sfm_dir = work_dir / "sfm_images"
    sfm_dir.mkdir(exist_ok=True)
    stage = "resize to {}x{}".format(*(round(v * scale) for v in full_size)) if scale < 1.0 else "stage photos"  # the stage names the working size
    progress(stage, 0, len(names))
    for i, name in enumerate(names):
        if scale < 1.0:
            sfm_size = write_working_copy(image_dir / name, sfm_dir / alias[name], scale)
        else:
            _link_or_copy(image_dir / name, sfm_dir / alias[name])
        progress(stage, i + 1, len(names))
    timings["resize_s"] = time.perf_counter() - t0

    with colmap_log(cfg.verbose):
        # --- features: chunked so that progress can be shown; chunks after the first reuse the camera
        t0 = time.perf_counter()
        reader = pycolmap.ImageReaderOptions()
        reader.camera_model = cfg.camera_model
        if cfg.camera_params:  # given for the full-size photos
            params = np.array(parse_camera_params(cfg.camera_model, cfg.camera_params))
            probe = pycolmap.Camera(model=cfg.camera_model, width=1, height=1)
            params[list(probe.focal_length_idxs()) + list(probe.principal_point_idxs())] *= scale
            reader.camera_params = ",".join(repr(float(v)) for v in params)
        extraction = pycolmap.FeatureExtractionOptions()
        extraction.num_threads = cfg.num_threads
        extraction.max_image_size = -1  # the copies are already at the working size
        extraction.sift.max_num_features = cfg.max_num_features
        extraction.sift.estimate_affine_shape = cfg.estimate_affine_shape
        chunk = 8
        progress("features", 0, len(names))  # every stage opens its bar before its first (slow) step
        for i in range(0, len(names), chunk):
            pycolmap.extract_features(
                db_path,
                sfm_dir,
                image_names=[alias[n] for n in names[i : i + chunk]],
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
                    if scale < 1.0 and not cfg.camera_params:
                        # COLMAP starts (and keeps) the principal point at the image centre; the copy's
                        # size is rounded, so its centre is up to half a pixel off the photo's
                        cam = cams[0]
                        params = np.array(cam.params, dtype=float)
                        params[list(cam.principal_point_idxs())] = [full_size[0] * scale / 2, full_size[1] * scale / 2]
                        cam.params = params
                        db.update_camera(cam)
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
        block = max(32, -(-len(pairs) // 50))  # progress about every 2 %, at most 50 calls' overhead
        pair_file = work_dir / "pairs.txt"
        progress("matching", 0, len(pairs))
        for i in range(0, len(pairs), block):
            pair_file.write_text("".join(f"{alias[a]} {alias[b]}\n" for a, b in pairs[i : i + block]))
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
        progress("mapping", 0, len(names))

        def _next_image() -> None:
            registered[0] += 1
            progress("mapping", min(registered[0], len(names)), len(names))

        models = pycolmap.incremental_mapping(
            db_path, sfm_dir, sparse_dir, options=opts, next_image_callback=_next_image
        )
        timings["mapping_s"] = time.perf_counter() - t0
    if not models:
        raise InputError("COLMAP could not reconstruct the scene (no image pair with enough matches)", image_dir)
    ordered = sorted(models.values(), key=lambda r: r.num_reg_images(), reverse=True)
    best = ordered[0]
    for image in best.images.values():
        image.name = original[image.name]
    reg = {best.image(i).name for i in best.reg_image_ids()}
    progress("mapping", len(reg), len(names))
    working_error = float(best.compute_mean_reprojection_error())
    if scale < 1.0:
        rescale_reconstruction(best, scale, *full_size)
    return SfMResult(
        reconstruction=best,
        unregistered=sorted(set(names) - reg),
        model_sizes=[r.num_reg_images() for r in ordered],
        matcher=strategy,
        num_pairs=len(pairs),
        sfm_size=sfm_size,
        scale=scale,
        working_reprojection_error_px=working_error,
        timings=timings,
    )


def needs_undistortion(rec: pycolmap.Reconstruction) -> bool:
    """True when some camera of ``rec`` has a distortion model."""
    return any(c.model_name not in PINHOLE_MODELS for c in rec.cameras.values())


def undistort(
    rec_dir: Path,
    image_dir: Path,
    out_dir: Path,
    num_threads: int = 2,
    verbose: bool = False,
    progress: ProgressFn | None = None,
) -> Path:
    """Undistort ``rec_dir``'s images to a PINHOLE camera with pycolmap; returns the output folder.

    ``out_dir/images`` and ``out_dir/sparse`` hold the result. COLMAP crops to the valid region, so the
    image size may shrink by a few pixels. Runs in chunks of images so that progress can be shown
    (each call writes the whole undistorted model again; the images are what takes time).
    """
    progress = progress or (lambda stage, done, total: None)
    rec = pycolmap.Reconstruction(rec_dir)
    names = sorted(rec.image(i).name for i in rec.reg_image_ids())
    chunk = 8
    progress("undistort", 0, len(names))
    with colmap_log(verbose):
        for i in range(0, len(names), chunk):
            pycolmap.undistort_images(out_dir, rec_dir, image_dir, image_names=names[i : i + chunk], num_threads=num_threads)
            progress("undistort", min(i + chunk, len(names)), len(names))
    return out_dir


def undistortion_options() -> pycolmap.UndistortCameraOptions:
    """The options ``undistort`` uses (pycolmap defaults), for warping masks the same way."""
    return pycolmap.UndistortCameraOptions()


def undistort_mask(mask: np.ndarray, camera: pycolmap.Camera) -> np.ndarray:
    """Warp a binary (H, W) mask taken with ``camera`` into the undistorted PINHOLE image."""
    bitmap = pycolmap.Bitmap.from_array(np.ascontiguousarray(mask.astype(np.uint8) * 255))
    out, _ = pycolmap.undistort_image(undistortion_options(), bitmap, camera)
    return out.to_array() >= 128
