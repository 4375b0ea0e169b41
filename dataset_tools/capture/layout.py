"""Writing parts of the Inpaint360GS scene layout (docs/architecture.md, "Scene format"): downscaled
copies, masks read from the user, provenance and JSON files. Image and mask files are read and
written by :mod:`inpaint360gs.io.images`.
"""

from __future__ import annotations

import datetime as _dt
import json
import shutil
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path

import numpy as np

from inpaint360gs.core.errors import InputError
from inpaint360gs.io.atomic import write_text
from inpaint360gs.io.images import binary_mask, read_image, resize_image, write_image


def scaled_size(width: int, height: int, factor: float) -> tuple[int, int]:
    """Size of an image downscaled by ``factor``: rounds like ``Camera.scaled`` and the original 3DGS loader."""
    return max(1, round(width / factor)), max(1, round(height / factor))


def copy_images(src_dir: Path, names: Iterable[str], dst_dir: Path) -> None:
    """Copy the named files' bytes unchanged (no re-encoding); the copies get the modes the umask asks
    for, not the source's (docs/architecture.md, "Reliability")."""
    dst_dir.mkdir(parents=True, exist_ok=True)
    for name in names:
        shutil.copyfile(src_dir / name, dst_dir / name)


def write_downscaled(
    images_dir: Path,
    names: Iterable[str],
    out_root: Path,
    factors: Iterable[int],
    on_image: Callable[[int], None] | None = None,
) -> dict[int, list[int]]:
    """Write ``out_root/images_{f}/`` for each factor; returns factor -> [width, height].
    ``on_image(k)`` is called after the k-th image (progress).

    Pixel centres stay consistent with intrinsics scaled by (new size / old size): OpenCV's area
    resampling maps continuous coordinates by that same ratio.
    """
    names = list(names)
    factors = list(factors)
    sizes: dict[int, list[int]] = {}
    for f in factors:
        if f < 1:
            raise InputError(f"downscale factor must be >= 1, got {f}", "--downscale")
        (out_root / f"images_{f}").mkdir(parents=True, exist_ok=True)
    if not factors:
        return sizes
    for k, name in enumerate(names, 1):
        img = read_image(images_dir / name)
        h, w = img.shape[:2]
        for f in factors:
            sw, sh = scaled_size(w, h, f)
            write_image(out_root / f"images_{f}" / name, resize_image(img, sw, sh))
            sizes[f] = [sw, sh]
        if on_image is not None:
            on_image(k)
    return sizes


def read_mask(path: Path) -> np.ndarray:
    """A user's mask file as boolean: inside where any colour channel is (a mask drawn in colour
    counts), by :func:`inpaint360gs.io.images.binary_mask`'s rule (> half range, or > 0 for 0/1 labels)."""
    return binary_mask(read_image(path).max(axis=2))


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
    write_text(path, json.dumps(data, indent=2, sort_keys=False, default=str) + "\n")
