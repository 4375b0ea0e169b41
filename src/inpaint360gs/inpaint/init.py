"""New Gaussians for the region to fill (paper Sec. 3.5 "Depth-Guided Gaussian Initialization";
supp. "Proof of the Validity of Depth Definition").

Depth-guided: the paper initialises the region to fill from the first inpainted view's colour and
depth (supp. B "3D Inpainting"). With the recursion of :mod:`.conditioned`, a surface point is
inpainted once, by the first view that sees it: later views take it over through the condition.
So the pixels each view's 2D inpainter filled (not those it took from earlier views) are fused into
a point cloud (back-projection with the camera), thinned to one point per voxel of about one
pixel's footprint and cleaned of statistical outliers; each point becomes a flat Gaussian lying in
the surface (a surfel: its normal from the principal axes of its neighbours, its radius in the
surface from its 3 nearest neighbours as in 3DGS, a tenth of that across): the fill starts as a
skin on the surface it continues, not as isotropic blobs that the 3D stage may stretch into shards.
Because the depth is the field's own (Eq. 5), the points land on the scene's surfaces without any
scale alignment.

Naive (ablation b, "w/o depth guidance"): as many points drawn uniformly in the bounding box of
the removed Gaussians, all with the mean inpainted colour — the 3D stage must move them into place.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import torch

from inpaint360gs.core.errors import InputError
from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.core.support import voxel_thin
from inpaint360gs.inpaint.conditioned import InpaintedView
from inpaint360gs.views.unseen import backproject


def fused_points(views: Sequence[InpaintedView]) -> tuple[np.ndarray, np.ndarray, float]:
    """The pixels each view's 2D inpainter filled (in its mask, not taken from earlier views) as
    world points with their colours, and the median pixel footprint (depth / focal) — the natural
    voxel size."""
    pts, cols, foot = [], [], []
    for v in views:
        rows, cs = np.nonzero(v.mask & ~v.from_condition & (v.depth > 0) & np.isfinite(v.depth))
        if not len(rows):
            continue
        d = v.depth[rows, cs].astype(np.float64)
        pts.append(backproject(v.camera, d, rows, cs))
        cols.append(v.color[rows, cs])
        foot.append(np.median(d) / min(v.camera.fx, v.camera.fy))
    if not pts:
        raise InputError("no view has pixels to fill: the unseen masks are empty (nothing to initialise)")
    return np.concatenate(pts), np.concatenate(cols), float(np.median(foot))


def remove_outliers(points: np.ndarray, k: int = 8, n_std: float = 2.5) -> np.ndarray:
    """Boolean mask of the points whose mean distance to their k neighbours is at most mean + n_std std."""
    from scipy.spatial import cKDTree

    if len(points) <= k + 1:
        return np.ones(len(points), dtype=bool)
    d, _ = cKDTree(points).query(points, k=k + 1)
    m = d[:, 1:].mean(axis=1)
    return m <= m.mean() + n_std * m.std()


def surfels(points: np.ndarray, k: int = 8, thickness: float = 0.1) -> tuple[np.ndarray, np.ndarray]:
    """(scales (N, 3), quaternions (N, 4) w-first) of flat Gaussians at ``points``: the local z axis
    is the normal of the ``k`` nearest neighbours' principal axes (the direction of least spread),
    the radius in the surface the RMS distance to the 3 nearest neighbours (3DGS's), and
    ``thickness`` of it along the normal."""
    from scipy.spatial import cKDTree
    from scipy.spatial.transform import Rotation

    n = len(points)
    kk = min(k + 1, n)
    d, idx = cKDTree(points).query(points, k=kk)
    d = d.reshape(n, kk)
    r = np.sqrt((d[:, 1:4] ** 2).mean(axis=1)) if kk > 1 else np.ones(n)
    r = np.maximum(r, 1e-7)
    nb = points[idx.reshape(n, kk)] - points[:, None, :]
    _, vecs = np.linalg.eigh(np.einsum("nki,nkj->nij", nb, nb))  # ascending eigenvalues
    rot = vecs[:, :, [2, 1, 0]]  # columns: largest, middle spread, normal
    rot[np.linalg.det(rot) < 0, :, 0] *= -1  # right-handed
    xyzw = Rotation.from_matrix(rot).as_quat()
    scales = np.stack([r, r, thickness * r], axis=1)
    return scales, xyzw[:, [3, 0, 1, 2]]


def depth_guided_init(views: Sequence[InpaintedView], *, voxel_pixels: float = 1.5, opacity: float = 0.9, sh_degree: int = 3) -> Gaussians:
    """Gaussians from the inpainted RGB-D of ``views`` (see the module docstring). They start nearly
    opaque (``opacity``): they continue a surface, and a half-transparent skin lets whatever lies
    behind it (the underside of a table, the background) show through where the 3D stage does not
    raise it."""
    pts, cols, foot = fused_points(views)
    pts, cols = voxel_thin(pts, cols, voxel_pixels * foot)
    keep = remove_outliers(pts)
    pts, cols = pts[keep], cols[keep]
    g = Gaussians.from_points(torch.from_numpy(pts).float(), torch.from_numpy(cols).float().clamp(0, 1), sh_degree=sh_degree, init_opacity=opacity)
    if len(pts) >= 4:
        scales, quats = surfels(pts)
        g.log_scales = torch.from_numpy(np.log(scales)).float()
        g.quats = torch.from_numpy(quats).float()
    return g


def naive_init(views: Sequence[InpaintedView], bbox_min: np.ndarray, bbox_max: np.ndarray, count: int, *, seed: int = 0, opacity: float = 0.5, sh_degree: int = 3) -> Gaussians:
    """Ablation b): ``count`` Gaussians uniform in the box, coloured with the mean inpainted colour."""
    if count < 1:
        raise InputError("naive initialisation needs at least one point")
    rng = np.random.default_rng(seed)
    pts = rng.uniform(bbox_min, bbox_max, size=(count, 3))
    cols = np.concatenate([v.color[v.mask] for v in views if v.mask.any()] or [np.full((1, 3), 0.5)])
    rgb = np.repeat(cols.mean(axis=0, keepdims=True), count, axis=0)
    return Gaussians.from_points(torch.from_numpy(pts).float(), torch.from_numpy(rgb).float(), sh_degree=sh_degree, init_opacity=opacity)
