"""The distillation targets: the associated object ids (``objects.json``) and per-view id masks
(docs/architecture.md, "Stage outputs", ``associate/``), turned into per-pixel class indices.

Class 0 is the background (object id 0); classes 1..Q-1 are the listed object ids in increasing
order, so Q <= 256 with 8-bit masks. Every mask is decoded and checked before any optimisation
(docs/architecture.md, "Reliability"): it must exist for every training view, have the view's size
and hold only listed ids.
"""

from __future__ import annotations

import hashlib
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from inpaint360gs.core.errors import InputError
from inpaint360gs.core.files import parse_json
from inpaint360gs.io.images import find_mask, read_mask
from inpaint360gs.io.scene import View

MAX_CLASSES = 256  # background + 255 objects: what an 8-bit id mask can hold


def read_objects(path: str | Path) -> list[int]:
    """Object ids listed in an association's ``objects.json``.

    Accepted layouts: ``{"objects": [{"id": 1, ...}, ...], ...}``, ``{"ids": [1, 2]}``, a list of such
    objects, or a plain list of ids. Id 0 (background) may be listed; it is implied anyway.
    """
    path = Path(path)
    if not path.is_file():
        raise InputError("objects.json not found", path)
    data = parse_json(path)
    if isinstance(data, dict):
        data = data.get("objects", data.get("ids"))
    if not isinstance(data, list):
        raise InputError('expected a list of object ids, or an object with an "objects" or "ids" list', path)
    ids = []
    for item in data:
        v = item.get("id") if isinstance(item, dict) else item
        if isinstance(v, bool) or not isinstance(v, int):
            raise InputError(f"object id must be an integer, got {v!r}", path)
        ids.append(v)
    return check_object_ids(ids, path)


def check_object_ids(ids: Sequence[int], where: str | Path = "objects") -> list[int]:
    """Sorted distinct non-zero ids; at most 255 of them (Q <= 256 classes), each in 1..255."""
    ids = sorted({int(i) for i in ids} - {0})
    if len(ids) + 1 > MAX_CLASSES:
        raise InputError(f"{len(ids)} object ids + background is more than {MAX_CLASSES} classes (8-bit id masks)", where)
    bad = [i for i in ids if not 0 < i < MAX_CLASSES]
    if bad:
        raise InputError(f"object ids must lie in 1..{MAX_CLASSES - 1} (8-bit id masks), got {bad[:5]}", where)
    return ids


@dataclass
class Labels:
    """Per-view class indices for the training views."""

    class_ids: list[int]  # class -> object id; class 0 = background (id 0)
    views: list[View]
    labels: list[torch.Tensor]  # per view (H*W,) uint8 class index, row-major
    paths: list[Path]  # the mask file of each view
    pixel_counts: list[int]  # per class, over all views

    @property
    def num_classes(self) -> int:
        """Number of classes (object ids present in the masks)."""
        return len(self.class_ids)

    def sha256(self) -> str:
        """Digest of the mask files (names and bytes, in view order)."""
        h = hashlib.sha256()
        for p in self.paths:
            h.update(p.name.encode() + b"\0" + p.read_bytes())
        return h.hexdigest()


def load_labels(masks_dir: str | Path, views: Sequence[View], object_ids: Sequence[int]) -> Labels:
    """Read and check the id mask of every view in ``masks_dir`` (``<stem>.png``), mapped to class indices."""
    masks_dir = Path(masks_dir)
    if not masks_dir.is_dir():
        raise InputError("object mask folder not found", masks_dir)
    ids = check_object_ids(object_ids, masks_dir)
    class_ids = [0, *ids]
    lut = np.full(65536, -1, np.int32)
    lut[class_ids] = np.arange(len(class_ids))
    out, paths = [], []
    counts = np.zeros(len(class_ids), np.int64)
    for v in views:
        p = find_mask(masks_dir, [v.name])
        if p is None:
            raise InputError(f"no object mask for training view {v.name} (expected {v.stem}.png)", masks_dir)
        m = read_mask(p)
        if m.dtype not in (np.uint8, np.uint16):
            raise InputError(f"object mask must be an 8- or 16-bit id image, got {m.dtype}", p)
        if m.shape != (v.camera.height, v.camera.width):
            raise InputError(f"mask is {m.shape[1]}x{m.shape[0]} but view {v.name} is {v.camera.width}x{v.camera.height}", p)
        cls = lut[m.astype(np.int64)]
        if (cls < 0).any():
            unknown = sorted(int(i) for i in np.unique(m[cls < 0]))
            raise InputError(f"mask holds object id(s) {unknown[:5]} not listed in objects.json (listed: {ids[:10]})", p)
        counts += np.bincount(cls.ravel(), minlength=len(class_ids))
        out.append(torch.from_numpy(cls.astype(np.uint8).ravel()))
        paths.append(p)
    return Labels(class_ids, list(views), out, paths, counts.tolist())
