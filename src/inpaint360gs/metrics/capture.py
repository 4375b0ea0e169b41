"""Scores for a capture without ground truth: photos with the object only, nothing to compare the
filled region with (docs/architecture.md, "Real captures"). What can be measured:

- **outside the hole nothing changes**: PSNR against the photos over the pixels outside the removed
  object's footprint grown by a margin (:func:`psnr_outside`);
- **nothing stands where the object stood**: of the Gaussians whose centres lie in the object's
  footprint column (its centres projected onto the support plane), the opacity-weighted share
  standing higher above the plane than a fraction of the object's height (:func:`standing_share`);
- **the fill belongs**: texture energy (mean absolute Laplacian of the luminance) and mean
  luminance inside the hole against a ring around it (:func:`texture_ratios`).

Pure functions on arrays; the benchmark script ``benchmarks/bench_capture.py`` applies them to a run.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

LUMA = np.array([0.299, 0.587, 0.114])  # ITU-R BT.601 weights


def grow(mask: np.ndarray, px: int) -> np.ndarray:
    """``mask`` grown by ``px`` pixels: every pixel within Euclidean distance ``px`` of it."""
    if px <= 0 or not mask.any():
        return mask.astype(bool)
    dist = cv2.distanceTransform((~mask.astype(bool)).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    return dist <= px


def psnr_outside(render: np.ndarray, photo: np.ndarray, footprint: np.ndarray, grow_px: int = 15) -> float:
    """PSNR (images in [0, 1]) over the pixels outside ``footprint`` grown by ``grow_px``; NaN when
    no pixel is left."""
    keep = ~grow(footprint, grow_px)
    if not keep.any():
        return float("nan")
    mse = float(np.mean((render[keep].astype(np.float64) - photo[keep].astype(np.float64)) ** 2))
    return float("inf") if mse == 0 else -10.0 * np.log10(mse)


@dataclass
class TextureRatios:
    laplacian: float  # mean |Laplacian| inside the hole / in the ring
    luminance: float  # mean luminance inside / in the ring


def texture_ratios(image: np.ndarray, hole: np.ndarray, ring_px: int = 20) -> TextureRatios | None:
    """Texture energy and brightness of ``image`` (H, W, 3 in [0, 1]) inside ``hole`` against the
    ring of ``ring_px`` pixels around it; None when the hole or the ring is empty. The Laplacian is
    taken on the luminance (3x3 kernel), so a flat fill scores near 0 and a fill as detailed as its
    surroundings near 1."""
    hole = hole.astype(bool)
    ring = grow(hole, ring_px) & ~hole
    if not hole.any() or not ring.any():
        return None
    luma = image.astype(np.float64) @ LUMA
    lap = np.abs(cv2.Laplacian(luma, cv2.CV_64F, ksize=1))
    ring_lap, ring_luma = lap[ring].mean(), luma[ring].mean()
    return TextureRatios(
        laplacian=float(lap[hole].mean() / ring_lap) if ring_lap > 0 else float("nan"),
        luminance=float(luma[hole].mean() / ring_luma) if ring_luma > 0 else float("nan"),
    )


def fit_plane(points: np.ndarray, up: np.ndarray, *, trim: float = 0.8, rounds: int = 5) -> tuple[np.ndarray, float]:
    """Least-squares plane (unit normal oriented with ``up``, offset d with n.x = d) through
    ``points``, refitted ``rounds`` times on the ``trim`` share of points nearest the current plane
    (robust to what stands on the surface or lies under it)."""
    pts = np.asarray(points, dtype=np.float64)
    if len(pts) < 3:
        raise ValueError(f"a plane needs at least 3 points, got {len(pts)}")
    sel = pts
    for _ in range(rounds + 1):
        c = sel.mean(0)
        _, _, vt = np.linalg.svd(sel - c, full_matrices=False)
        n = vt[2] if vt[2] @ up >= 0 else -vt[2]
        d = float(n @ c)
        r = np.abs(pts @ n - d)
        sel = pts[r <= np.quantile(r, trim)]
        if len(sel) < 3:
            break
    return n, d


def plane_coordinates(points: np.ndarray, normal: np.ndarray) -> np.ndarray:
    """(N, 2) coordinates of ``points`` in two orthonormal directions across ``normal``."""
    a = np.array([1.0, 0.0, 0.0]) if abs(normal[0]) < 0.9 else np.array([0.0, 1.0, 0.0])
    e1 = np.cross(normal, a)
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(normal, e1)
    return np.stack([points @ e1, points @ e2], axis=1)


def inside_polygon_hull(hull_points: np.ndarray, queries: np.ndarray) -> np.ndarray:
    """Which 2D ``queries`` lie inside the convex hull of the 2D ``hull_points`` (scipy Delaunay)."""
    from scipy.spatial import Delaunay, QhullError

    if len(hull_points) < 3:
        return np.zeros(len(queries), dtype=bool)
    try:
        return Delaunay(hull_points).find_simplex(queries) >= 0
    except QhullError:
        return np.zeros(len(queries), dtype=bool)


@dataclass
class Footprint:
    """The removed object's footprint column: the support plane around it and its outline on it."""

    normal: np.ndarray  # (3,) the support plane's unit normal (up)
    offset: float  # plane: normal . x = offset
    outline: np.ndarray  # (K, 2) plane coordinates of the object's centres (their convex hull is the footprint)
    height: float  # the object's height above the plane

    def heights(self, points: np.ndarray) -> np.ndarray:
        return points @ self.normal - self.offset

    def inside(self, points: np.ndarray) -> np.ndarray:
        return inside_polygon_hull(self.outline, plane_coordinates(points, self.normal))


def object_footprint(object_means: np.ndarray, object_opacities: np.ndarray, scene_means: np.ndarray, scene_opacities: np.ndarray, up: np.ndarray,
                     *, min_opacity: float = 0.1, ring: float = 0.5, trim_share: float = 0.01) -> Footprint:  # fmt: skip
    """The footprint of an object (its Gaussians ``object_means``) standing on a surface of the
    scene (``scene_means``, the Gaussians left after removal), with ``up`` roughly the surface's
    normal (e.g. the training cameras' up). The support plane is fitted (:func:`fit_plane`) to the
    opaque scene Gaussians in a ring around the object's outline, out to ``ring`` x its size and
    below the object's middle; the outline is the object's opaque centres above that plane, minus
    the ``trim_share`` farthest from their median (stray Gaussians)."""
    up = np.asarray(up, dtype=np.float64) / np.linalg.norm(up)
    obj = object_means[object_opacities > min_opacity]
    if len(obj) < 4:
        raise ValueError(f"the object has {len(obj)} opaque Gaussians: too few for a footprint")
    flat = plane_coordinates(obj, up)
    med = np.median(flat, axis=0)
    r = np.linalg.norm(flat - med, axis=1)
    keep = r <= np.quantile(r, 1.0 - trim_share)
    size = float(np.quantile(r, 0.95))
    z = obj @ up
    lo, hi = np.quantile(z, 0.02), np.quantile(z, 0.98)
    sc = scene_means[scene_opacities > min_opacity]
    sr = np.linalg.norm(plane_coordinates(sc, up) - med, axis=1)
    sz = sc @ up
    near = (sr > size) & (sr < (1.0 + ring) * size) & (sz < 0.5 * (lo + hi)) & (sz > lo - 0.5 * (hi - lo))
    if near.sum() < 10:
        raise ValueError(f"only {int(near.sum())} scene Gaussians around the object: cannot fit its support plane")
    normal, offset = fit_plane(sc[near], up)
    hts = obj @ normal - offset
    outline = plane_coordinates(obj[keep & (hts > 0)], normal)
    return Footprint(normal, offset, outline, float(np.quantile(hts, 0.99)))


def standing_share(means: np.ndarray, opacities: np.ndarray, footprint: Footprint, height_frac: float = 0.1) -> tuple[float, int]:
    """(opacity-weighted share, count) of the Gaussians in the footprint column (any height from
    one object height below the plane to twice above) that stand higher above the plane than
    ``height_frac`` x the object's height. 0 when the column holds nothing."""
    h = footprint.heights(means)
    col = footprint.inside(means) & (h > -footprint.height) & (h < 2.0 * footprint.height)
    w = opacities[col].astype(np.float64)
    if not w.sum() > 0:
        return 0.0, 0
    up = h[col] > height_frac * footprint.height
    return float(w[up].sum() / w.sum()), int(up.sum())
