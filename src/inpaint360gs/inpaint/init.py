"""New Gaussians for the region to fill (paper Sec. 3.5 "Depth-Guided Gaussian Initialization";
supp. "Proof of the Validity of Depth Definition").

Depth-guided: the inpainted depth and colour of every view's filled pixels are fused into a point
cloud (back-projection with the camera), thinned to one point per voxel of about one pixel's
footprint, cleaned of statistical outliers, and each point becomes an isotropic Gaussian
(3DGS initialisation: radius from its 3 nearest neighbours). Because the depth is the field's own
(Eq. 5), the points land on the scene's surfaces without any scale alignment.

Naive (ablation b, "w/o depth guidance"): as many points drawn uniformly in the bounding box of
the removed Gaussians, all with the mean inpainted colour — the 3D stage must move them into place.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import torch

from inpaint360gs.core.errors import InputError
from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.inpaint.conditioned import InpaintedView
from inpaint360gs.views.unseen import backproject


def fused_points(views: Sequence[InpaintedView]) -> tuple[np.ndarray, np.ndarray, float]:
    """All filled pixels of all views as world points with their colours, and the median pixel
    footprint (depth / focal) — the natural voxel size."""
    pts, cols, foot = [], [], []
    for v in views:
        rows, cs = np.nonzero(v.mask & (v.depth > 0))
        if not len(rows):
            continue
        d = v.depth[rows, cs].astype(np.float64)
        pts.append(backproject(v.camera, d, rows, cs))
        cols.append(v.color[rows, cs])
        foot.append(np.median(d) / min(v.camera.fx, v.camera.fy))
    if not pts:
        raise InputError("no view has pixels to fill: the unseen masks are empty (nothing to initialise)")
    return np.concatenate(pts), np.concatenate(cols), float(np.median(foot))


def voxel_thin(points: np.ndarray, colors: np.ndarray, voxel: float) -> tuple[np.ndarray, np.ndarray]:
    """One point per occupied voxel: the mean position and colour of the points in it."""
    keys = np.floor(points / voxel).astype(np.int64)
    _, inv, counts = np.unique(keys, axis=0, return_inverse=True, return_counts=True)
    inv = inv.reshape(-1)
    p = np.zeros((len(counts), 3))
    c = np.zeros((len(counts), 3))
    np.add.at(p, inv, points)
    np.add.at(c, inv, colors)
    return p / counts[:, None], c / counts[:, None]


def remove_outliers(points: np.ndarray, k: int = 8, n_std: float = 2.5) -> np.ndarray:
    """Boolean mask of the points whose mean distance to their k neighbours is at most mean + n_std std."""
    from scipy.spatial import cKDTree

    if len(points) <= k + 1:
        return np.ones(len(points), dtype=bool)
    d, _ = cKDTree(points).query(points, k=k + 1)
    m = d[:, 1:].mean(axis=1)
    return m <= m.mean() + n_std * m.std()


def depth_guided_init(views: Sequence[InpaintedView], *, voxel_pixels: float = 1.5, opacity: float = 0.5, sh_degree: int = 3) -> Gaussians:
    """Gaussians from the inpainted RGB-D of ``views`` (see the module docstring)."""
    pts, cols, foot = fused_points(views)
    pts, cols = voxel_thin(pts, cols, voxel_pixels * foot)
    keep = remove_outliers(pts)
    return Gaussians.from_points(torch.from_numpy(pts[keep]).float(), torch.from_numpy(cols[keep]).float().clamp(0, 1), sh_degree=sh_degree, init_opacity=opacity)


def naive_init(views: Sequence[InpaintedView], bbox_min: np.ndarray, bbox_max: np.ndarray, count: int, *, seed: int = 0, opacity: float = 0.5, sh_degree: int = 3) -> Gaussians:
    """Ablation b): ``count`` Gaussians uniform in the box, coloured with the mean inpainted colour."""
    if count < 1:
        raise InputError("naive initialisation needs at least one point")
    rng = np.random.default_rng(seed)
    pts = rng.uniform(bbox_min, bbox_max, size=(count, 3))
    cols = np.concatenate([v.color[v.mask] for v in views if v.mask.any()] or [np.full((1, 3), 0.5)])
    rgb = np.repeat(cols.mean(axis=0, keepdims=True), count, axis=0)
    return Gaussians.from_points(torch.from_numpy(pts).float(), torch.from_numpy(rgb).float(), sh_degree=sh_degree, init_opacity=opacity)
