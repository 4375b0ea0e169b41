"""Writing parts of the Inpaint360GS scene layout (DESIGN.md §3): images, downscaled copies, masks, scene.json."""

from __future__ import annotations

import datetime as _dt
import json
import shutil
from collections.abc import Iterable, Mapping
from pathlib import Path

import cv2
import numpy as np

from inpaint360gs.core.errors import InputError

JPEG_QUALITY = 95


def scaled_size(width: int, height: int, factor: float) -> tuple[int, int]:
    """Size of an image downscaled by ``factor``: rounds like ``Camera.scaled`` and the original 3DGS loader."""
    return max(1, round(width / factor)), max(1, round(height / factor))


def read_image(path: Path, flags: int = cv2.IMREAD_UNCHANGED) -> np.ndarray:
    img = cv2.imread(str(path), flags)
    if img is None:
        raise InputError("cannot decode image", path)
    return img


def write_image(path: Path, img: np.ndarray) -> None:
    """Write with OpenCV, choosing the format by suffix (JPEG at quality 95)."""
    params = [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY] if path.suffix.lower() in (".jpg", ".jpeg") else []
    if not cv2.imwrite(str(path), img, params):
        raise InputError("cannot write image", path)


def copy_images(src_dir: Path, names: Iterable[str], dst_dir: Path) -> None:
    """Copy the named files unchanged (no re-encoding)."""
    dst_dir.mkdir(parents=True, exist_ok=True)
    for name in names:
        shutil.copy2(src_dir / name, dst_dir / name)


def write_downscaled(images_dir: Path, names: Iterable[str], out_root: Path, factors: Iterable[int]) -> dict[int, list[int]]:
    """Write ``out_root/images_{f}/`` for each factor; returns factor -> [width, height].

    Pixel centres stay consistent with intrinsics scaled by (new size / old size): OpenCV's area
    resampling maps continuous coordinates by that same ratio.
    """
    names = list(names)
    sizes: dict[int, list[int]] = {}
    for f in factors:
        if f < 1:
            raise InputError(f"downscale factor must be >= 1, got {f}", "--downscale")
        (out_root / f"images_{f}").mkdir(parents=True, exist_ok=True)
    for name in names:
        img = read_image(images_dir / name)
        h, w = img.shape[:2]
        for f in factors:
            sw, sh = scaled_size(w, h, f)
            small = cv2.resize(img, (sw, sh), interpolation=cv2.INTER_AREA)
            write_image(out_root / f"images_{f}" / name, small)
            sizes[f] = [sw, sh]
    return sizes


def write_mask(path: Path, mask: np.ndarray) -> None:
    """Binary mask as an 8-bit PNG: 255 inside, 0 outside."""
    path.parent.mkdir(parents=True, exist_ok=True)
    if not cv2.imwrite(str(path), np.where(mask, 255, 0).astype(np.uint8)):
        raise InputError("cannot write mask", path)


def read_mask(path: Path) -> np.ndarray:
    """Read a mask image (any bit depth/channels) as boolean.

    Inside is > half of the type's range (0/255 masks), or > 0 for masks stored as 0/1 labels.
    """
    img = read_image(path)
    if img.ndim == 3:
        img = img[..., :3].max(axis=2) if img.shape[2] >= 3 else img[..., 0]
    if img.max() <= 1:
        return img > 0
    top = np.iinfo(img.dtype).max if np.issubdtype(img.dtype, np.integer) else 1.0
    return img > top / 2


def find_mask(mask_dir: Path, stems: Iterable[str]) -> Path | None:
    """First ``mask_dir/<stem>.<png|jpg|jpeg>`` that exists among the candidate stems."""
    for stem in stems:
        for suffix in (".png", ".PNG", ".jpg", ".jpeg", ".JPG"):
            p = mask_dir / f"{stem}{suffix}"
            if p.is_file():
                return p
    return None


def provenance(command: str, config: Mapping | None = None, **extra) -> dict:
    """Who wrote a scene folder, with what, when."""
    import pycolmap

    import inpaint360gs

    return {
        "tool": command,
        "inpaint360gs_version": inpaint360gs.__version__,
        "pycolmap_version": pycolmap.__version__,
        "created_utc": _dt.datetime.now(_dt.timezone.utc).replace(microsecond=0).isoformat(),
        **({"config": dict(config)} if config is not None else {}),
        **extra,
    }


def write_json(path: Path, data: Mapping) -> None:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data, indent=2, sort_keys=False, default=str) + "\n")
