"""Exact visibility of surface points from capture cameras, by ray casting (unseen masks, sparse tracks, leak checks).

A point X is visible from a view when it is in front of the camera, projects inside the image
rectangle, and the segment from the camera centre to X meets no surface before X. The segment is
cast from the camera (``d = X - C``, so ``t = 1`` at X); a first hit at ``t >= 1 - eps`` is X's own
surface. ``eps`` is relative (:data:`REL_EPS`) plus an optional absolute tolerance for points that
are only near a surface (e.g. triangulated points after a similarity alignment).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from dataset_tools.synth.cameras import View
from dataset_tools.synth.raycast import World
from dataset_tools.synth.shapes import norm

REL_EPS = 1e-6  # relative to the camera-point distance: ~3 um at 3 m, far above float64 round-off
CHUNK = 1 << 17


def visible_from(world: World, view: View, points: np.ndarray, tol: float = 0.0) -> np.ndarray:
    """(P,) bool: each point is inside ``view``'s frustum and unoccluded in ``world``."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    out = np.zeros(len(points), dtype=bool)
    cand = np.nonzero(view.in_view(points))[0]
    C = view.center[None, :]
    for s in range(0, cand.size, CHUNK):
        idx = cand[s : s + CHUNK]
        d = points[idx] - C
        t, _ = world.cast(C, d)
        dist = norm(d)
        margin = np.maximum(REL_EPS, tol / np.maximum(dist, 1e-300))
        out[idx] = t >= 1.0 - margin
    return out


def seen_by_views(world: World, views: list[View], points: np.ndarray, tol: float = 0.0) -> np.ndarray:
    """(P,) bool: visible from at least one of ``views`` (stops testing a point once some view sees it)."""
    points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    seen = np.zeros(len(points), dtype=bool)
    for v in views:
        rest = np.nonzero(~seen)[0]
        if rest.size == 0:
            break
        seen[rest] = visible_from(world, v, points[rest], tol)
    return seen


def visibility_matrix(world: World, views: list[View], points: np.ndarray, tol: float = 0.0) -> np.ndarray:
    """(V, P) bool: which view sees which point (for sparse-point tracks)."""
    return np.stack([visible_from(world, v, points, tol) for v in views]) if views else np.zeros((0, len(points)), bool)


def nearest_first(views: list[View], anchor: View) -> list[View]:
    """``views`` sorted by camera-centre distance to ``anchor`` (neighbours see the same surfaces: early exit)."""
    return sorted(views, key=lambda v: (float(np.linalg.norm(v.center - anchor.center)), v.name))


def unseen_mask(scene, view: View, points: np.ndarray) -> np.ndarray:
    """(H, W) uint8 for an object-free ``view``: 255 where the removed objects hid the surface, 0 elsewhere.

    A surface point ``points[i, j]`` (what the view sees at the pixel centre without the removal targets) is
    unseen when no object-inclusive capture sees it while the objects are present, yet at least one of them
    would see it once they are gone: the objects are why it was never observed ("the unseen region after object removal",
    supp. Sec. A). Surface that no capture sees even without the objects (outside every frustum, or behind the
    room's own geometry) is no inpainting target: every method can only extrapolate there, so it is left out.
    """
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    views = nearest_first(scene.inclusive_views, view)
    seen = seen_by_views(scene.world_full, views, pts)
    rest = np.nonzero(~seen)[0]
    hidden = np.zeros(len(pts), dtype=bool)
    hidden[rest] = seen_by_views(scene.world_free, views, pts[rest])
    return np.where(hidden, 255, 0).astype(np.uint8).reshape(view.camera.height, view.camera.width)


def seen_by_object_inclusive_views(scene: "str | Path | object", points: np.ndarray, tol: float = 0.0) -> np.ndarray:
    """(P,) bool: whether each 3D surface point is visible from at least one object-inclusive capture.

    ``scene`` is a generated scene folder (``scene.json`` + ``gt/cameras.json``) or a
    :class:`~dataset_tools.synth.scene.SynthScene`. ``tol`` (metres, default 0) lets points that lie
    up to ``tol`` behind a surface along the viewing ray count as on it, for noisy (e.g. COLMAP) points.
    Used to check that a sparse model leaks no point that only the object-free test views see.
    """
    from dataset_tools.synth.scene import as_scene

    sc = as_scene(scene)
    return seen_by_views(sc.world_full, sc.inclusive_views, points, tol)


# The least unseen share (mean over a scene's test views of the share of pixels under the unseen
# mask) for a scene to enter a masked or ROI average: below it those scores rest on a handful of
# pixels (docs/guide.md, "The synthetic benchmark").
MIN_UNSEEN_SHARE = 0.01


def unseen_shares(scene_dir: str | Path) -> dict[str, float]:
    """Share of each test view's pixels under its unseen mask, read from ``scene_dir/unseen_mask/``."""
    from inpaint360gs.io.images import read_binary_mask

    folder = Path(scene_dir) / "unseen_mask"
    if not folder.is_dir():
        from inpaint360gs.core.errors import InputError

        raise InputError("no unseen_mask/ folder", folder)
    return {p.stem: float(read_binary_mask(p).mean()) for p in sorted(folder.glob("*.png"))}


def estimate_unseen_shares(scene, width: int = 64, height: int = 48) -> dict[str, float]:
    """The unseen shares of ``scene`` (a :class:`SynthScene`) with its cameras at ``width`` x ``height``.

    The masks' rule (:func:`unseen_mask`) at the pixel centres of a small image: the share is a
    ratio of areas, so a small image estimates the full-size one to within its sampling error
    (one pixel of 64x48 is 0.03 % of the image) at a fraction of the cost; nothing is shaded.
    """
    from dataset_tools.synth.cameras import View, intrinsics

    K = intrinsics(width, height)
    out = {}
    for v in scene.test_views:
        small = View.at(v.name, v.R, v.t, K, width, height, True)
        jj, ii = np.meshgrid(np.arange(width) + 0.5, np.arange(height) + 0.5)
        d = small.rays(jj.ravel(), ii.ravel())
        t, _ = scene.world_free.cast(small.center, d)
        pts = small.center[None, :] + t[:, None] * d
        out[v.stem] = float((unseen_mask(scene, small, pts) > 0).mean())
    return out
