"""Reading, resizing and writing images, masks and depth maps (OpenCV).

Images are kept in their stored integer type (uint8 / uint16) until they are used, so a scene's
training images cost one byte per channel in memory; :func:`to_float` converts to [0, 1].
Every reader raises :class:`~inpaint360gs.core.errors.InputError` naming the file on bad input, and every
writer writes atomically (docs/architecture.md, "Reliability").
"""

from __future__ import annotations

import os
from collections.abc import Iterable
from pathlib import Path

import cv2
import numpy as np
import torch

from inpaint360gs.core.errors import InputError
from inpaint360gs.core.files import path_problem
from inpaint360gs.core.layout import MASK_SUFFIXES
from inpaint360gs.io.atomic import atomic_path

# OpenCV's decoders print a "[ WARN:...]" line of their own on a corrupt file (a truncated PNG),
# before the one-line error the readers below raise naming the file: keep only errors.
if hasattr(cv2.utils, "logging"):  # OpenCV >= 4.5 with the logging module (not every build has it)
    cv2.utils.logging.setLogLevel(cv2.utils.logging.LOG_LEVEL_ERROR)


def read_image(path: str | Path) -> np.ndarray:
    """RGB image as (H, W, 3) uint8 or uint16, as stored; grey is replicated, alpha is dropped."""
    path = Path(path)
    problem = path_problem(path)
    if problem is not None:
        raise InputError(problem.replace("file not found", "image file not found"), path)
    data = path.read_bytes()
    if not data:
        raise InputError("empty file (0 bytes), not an image", path)
    # libjpeg decodes a truncated JPEG to a grey-filled image with only a warning: check the EOI marker
    # (entropy-coded data never holds FF D9, so a complete file has an EOI after its last SOS FF DA)
    if data[:2] == b"\xff\xd8" and data.rfind(b"\xff\xd9") < data.rfind(b"\xff\xda"):
        raise InputError("truncated JPEG (no end-of-image marker)", path)
    img = cv2.imdecode(np.frombuffer(data, dtype=np.uint8), cv2.IMREAD_UNCHANGED)
    if img is None:
        raise InputError("cannot decode image (corrupt or unsupported format)", path)
    if img.dtype not in (np.uint8, np.uint16):
        raise InputError(f"unsupported image sample type {img.dtype} (expected 8 or 16 bit)", path)
    if img.ndim == 2:
        img = np.repeat(img[:, :, None], 3, axis=2)
    elif img.shape[2] == 4:
        img = cv2.cvtColor(img, cv2.COLOR_BGRA2RGB)
    elif img.shape[2] == 3:
        img = cv2.cvtColor(img, cv2.COLOR_BGR2RGB)
    else:
        raise InputError(f"unsupported number of channels {img.shape[2]}", path)
    return np.ascontiguousarray(img)


def read_mask(path: str | Path) -> np.ndarray:
    """Single-channel mask as stored, (H, W) uint8/uint16 (first channel of a colour file)."""
    path = Path(path)
    problem = path_problem(path)
    if problem is not None:
        raise InputError(problem.replace("file not found", "mask file not found"), path)
    m = cv2.imread(str(path), cv2.IMREAD_UNCHANGED)
    if m is None:
        raise InputError("cannot decode mask (corrupt or unsupported format)", path)
    if m.ndim == 3:
        m = m[:, :, 0]
    return np.ascontiguousarray(m)


def binary_mask(labels: np.ndarray) -> np.ndarray:
    """Boolean mask from stored values: above half the type's range (0/255 masks, the paper's
    evaluation rule "> 127" for 8 bit), or above 0 for masks stored as 0/1 labels."""
    if labels.size and labels.max() <= 1:
        return labels > 0
    top = np.iinfo(labels.dtype).max if np.issubdtype(labels.dtype, np.integer) else 1.0
    return labels > top / 2


def read_binary_mask(path: str | Path) -> np.ndarray:
    """(H, W) bool mask of a mask file (see :func:`binary_mask`)."""
    return binary_mask(read_mask(path))


def find_mask(mask_dir: str | Path, candidates: Iterable[str]) -> Path | None:
    """First mask file in ``mask_dir`` for the candidate names: each as given (an image's own file
    name), then its stem with every mask suffix of the layout."""
    mask_dir = Path(mask_dir)
    for name in candidates:
        for cand in (mask_dir / name, *(mask_dir / f"{Path(name).stem}{s}" for s in MASK_SUFFIXES)):
            if cand.is_file() or (os.path.lexists(cand) and not cand.is_dir()):  # a named pipe or a broken link: the reader says so
                return cand
    return None


def image_size(path: str | Path) -> tuple[int, int]:
    """(width, height) from the file header only, without decoding pixels (PIL opens lazily)."""
    from PIL import Image, UnidentifiedImageError

    path = Path(path)
    problem = path_problem(path)
    if problem is not None:
        raise InputError(problem, path)
    try:
        with Image.open(path) as im:
            return int(im.width), int(im.height)
    except FileNotFoundError:
        raise InputError("file not found", path) from None
    except (UnidentifiedImageError, OSError, SyntaxError) as e:
        raise InputError(f"cannot read image header ({e.__class__.__name__})", path) from None


def resize_image(img: np.ndarray, width: int, height: int) -> np.ndarray:
    """Downscale with area averaging (what 3DGS's PIL resize approximates; alias-free)."""
    if img.shape[1] == width and img.shape[0] == height:
        return img
    return cv2.resize(img, (width, height), interpolation=cv2.INTER_AREA)


def resize_mask(mask: np.ndarray, width: int, height: int) -> np.ndarray:
    """Resize a label/binary mask with nearest neighbour so no new label values appear."""
    if mask.shape[1] == width and mask.shape[0] == height:
        return mask
    return cv2.resize(mask, (width, height), interpolation=cv2.INTER_NEAREST)


def to_float(img: np.ndarray | torch.Tensor) -> torch.Tensor:
    """Integer image -> float32 tensor in [0, 1] (uint8 / 255, uint16 / 65535)."""
    if isinstance(img, np.ndarray):
        if img.dtype == np.uint16:
            return torch.from_numpy(img.astype(np.float32) / 65535.0)
        img = torch.from_numpy(img)
    if img.dtype == torch.uint8:
        return img.float().div_(255.0)
    if img.dtype == torch.uint16:
        return img.to(torch.float32).div_(65535.0)
    return img.float()


def _encode_params(path: Path) -> list[int]:
    return [cv2.IMWRITE_JPEG_QUALITY, 95] if path.suffix.lower() in (".jpg", ".jpeg") else []


def write_image(path: str | Path, img: np.ndarray | torch.Tensor) -> None:
    """Write an RGB image: float in [0, 1] is clipped and stored as 8 bit; uint8/uint16 as is."""
    path = Path(path)
    a = img.detach().cpu().numpy() if isinstance(img, torch.Tensor) else np.asarray(img)
    if a.dtype.kind == "f":
        a = (np.clip(a, 0.0, 1.0) * 255.0 + 0.5).astype(np.uint8)
    if a.ndim == 3:
        a = cv2.cvtColor(a, cv2.COLOR_RGB2BGR)
    with atomic_path(path) as tmp:
        if not cv2.imwrite(str(tmp), a, _encode_params(path)):
            raise InputError("cannot write image", path)


def write_mask(path: str | Path, mask: np.ndarray | torch.Tensor) -> None:
    """Binary mask as an 8-bit PNG (255 inside, 0 outside), atomically."""
    m = mask.detach().cpu().numpy() if isinstance(mask, torch.Tensor) else np.asarray(mask)
    write_labels(path, np.where(m.astype(bool), 255, 0).astype(np.uint8))


def write_labels(path: str | Path, labels: np.ndarray) -> None:
    """Single-channel label image (uint8 or uint16 PNG), atomically."""
    path = Path(path)
    if labels.dtype not in (np.uint8, np.uint16):
        raise ValueError(f"label images are uint8 or uint16, got {labels.dtype}")
    with atomic_path(path) as tmp:
        if not cv2.imwrite(str(tmp), np.ascontiguousarray(labels)):
            raise InputError("cannot write mask", path)


def write_depth(path_stem: str | Path, depth: np.ndarray | torch.Tensor) -> float:
    """Write ``<stem>.npy`` (float32, exact) and ``<stem>.png`` (16 bit, ``png / scale = depth``).

    The scale maps the view's largest depth to 65535 and is returned so callers can record it.
    """
    stem = Path(path_stem)
    d = depth.detach().cpu().numpy() if isinstance(depth, torch.Tensor) else np.asarray(depth)
    d = np.nan_to_num(d.astype(np.float32), nan=0.0, posinf=0.0, neginf=0.0).clip(min=0.0)
    top = float(d.max()) if d.size else 0.0
    scale = 65535.0 / top if top > 0 else 1.0
    with atomic_path(stem.with_suffix(".npy")) as tmp:
        np.save(tmp, d)
    png = np.round(d * scale).clip(0, 65535).astype(np.uint16)
    with atomic_path(stem.with_suffix(".png")) as tmp:
        if not cv2.imwrite(str(tmp), png):
            raise InputError("cannot write depth image", stem.with_suffix(".png"))
    return scale
