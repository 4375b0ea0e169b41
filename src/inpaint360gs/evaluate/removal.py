"""AMCR (paper supp. Eq. 1) of a removal at the test cameras: ``inpaint360gs evaluate --removal``.

The paper's AMCR is the mean over views of the percentage of pixels to inpaint after the removal.
The removal stage writes those masks for the training views (``removed/masks/``, the removed
Gaussians' rendered footprint: :func:`inpaint360gs.remove.objects.fill_masks`); the tables report
AMCR in the test views, so the same footprint is rendered here at the test cameras, with the
removal's own mask rule (``mask_share``) and the rasterizer ``backend`` the removal used. The model
the removal started from (the distilled field) is put back together from the removal's output: its
kept Gaussians (``point_cloud.ply``), its removed ones (``removed.ply``) and their indices
(``removed_index.npy``) — exact subsets of it, so every Gaussian is where it was.

This is a property of each run's own removal (a method with another association, or another seed,
has another one); the ground-truth unseen masks' coverage is a different number, ``unseen_share``.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import torch

from inpaint360gs.core.errors import InputError
from inpaint360gs.core.files import check_readable
from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.io import provenance
from inpaint360gs.io.ply import read_ply
from inpaint360gs.io.scene import Scene, View
from inpaint360gs.metrics.masked import amcr
from inpaint360gs.remove.config import RemovalConfig
from inpaint360gs.remove.objects import fill_masks


def _removal_info(removed_dir: Path) -> dict:
    path = removed_dir / "removal.json"
    check_readable(path, "the removal stage's record (inpaint360gs remove)", missing="not a removal stage output (no removal.json)")
    try:
        info = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise InputError(f"not valid JSON ({e})", path) from None
    if not isinstance(info, dict):
        raise InputError("not a removal record (expected a JSON object)", path)
    return info


def original_model(removed_dir: str | Path) -> tuple[Gaussians, torch.Tensor]:
    """The model the removal in ``removed_dir`` started from and the mask of what it removed."""
    removed_dir = Path(removed_dir)
    kept, removed = read_ply(removed_dir / "point_cloud.ply"), read_ply(removed_dir / "removed.ply")
    index_path = removed_dir / "removed_index.npy"
    check_readable(index_path, "the removal's removed_index.npy", missing="not a removal stage output (no removed_index.npy)")
    try:
        index = np.load(index_path)
    except (ValueError, OSError) as e:
        raise InputError(f"unreadable index file ({type(e).__name__})", index_path) from None
    n = len(kept) + len(removed)
    if index.ndim != 1 or not np.issubdtype(index.dtype, np.integer) or index.size != len(removed):
        raise InputError(f"expected the {len(removed)} indices of removed.ply's Gaussians, got dtype {index.dtype}, shape {index.shape}", index_path)
    if index.size and (index.min() < 0 or index.max() >= n or np.unique(index).size != index.size):
        raise InputError(f"indices outside 0..{n - 1} or repeated: not this removal's index", index_path)
    a, b = kept.tensors(), removed.tensors()
    if set(a) != set(b) or any(a[k].shape[1:] != b[k].shape[1:] for k in a):
        raise InputError("point_cloud.ply and removed.ply hold different Gaussian properties: not one removal's output", removed_dir / "removed.ply")
    mask = torch.zeros(n, dtype=torch.bool)
    mask[torch.from_numpy(index.astype(np.int64))] = True
    parts = {}
    for k in a:
        t = torch.empty((n, *a[k].shape[1:]), dtype=a[k].dtype)
        t[~mask], t[mask] = a[k], b[k]
        parts[k] = t
    return Gaussians(**parts), mask


def removal_masks(removed_dir: str | Path, views: list[View], backend: str = "auto") -> dict[str, np.ndarray]:
    """Per view in ``views``: the pixels the removal in ``removed_dir`` leaves to fill (bool) — at
    the training cameras exactly the removal stage's own ``masks/``."""
    removed_dir = Path(removed_dir)
    info = _removal_info(removed_dir)
    config = info.get("config") if isinstance(info.get("config"), dict) else {}
    share = config.get("mask_share", RemovalConfig.mask_share)
    if isinstance(share, bool) or not isinstance(share, (int, float)) or not 0 < share <= 1:
        raise InputError(f"config.mask_share must be a number in (0, 1], got {share!r}", removed_dir / "removal.json")
    model, mask = original_model(removed_dir)
    return fill_masks(model, mask, views, float(share), backend)


def masks_in_test_views(removed_dir: str | Path, scene: Scene, backend: str = "auto") -> dict[str, np.ndarray]:
    """:func:`removal_masks` at ``scene``'s test cameras; the removal must be of ``scene``."""
    removed_dir = Path(removed_dir)
    _removal_info(removed_dir)  # a folder without removal.json is named as such first
    provenance.check_scene(provenance.read(removed_dir / "removal.json", "remove"), scene, "give the removal of this scene", same_resize=False)
    return removal_masks(removed_dir, scene.test_views, backend)


def removal_amcr(removed_dir: str | Path, scene: Scene, backend: str = "auto") -> float | None:
    """AMCR in percent of the removal in ``removed_dir`` over ``scene``'s test views (None without test views)."""
    masks = masks_in_test_views(removed_dir, scene, backend)
    return amcr([torch.from_numpy(m) for m in masks.values()]) if masks else None
