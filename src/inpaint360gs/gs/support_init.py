"""Initial points on the support where structure from motion found none.

3DGS starts from the SfM points (Kerbl et al. 2023, Sec. 4) and relies on densification to fill
what they miss; densification follows the photometric gradient, and a plain surface (a sheet, white
paper, a bare table) gives almost none, so a capture whose support is plain keeps a few large,
misplaced Gaussians there: right in the training views, wrong from any other angle (held-out
views, the inpainting's virtual views and support view, Sec. 3.4). 3DGS's own answers to missing
points are a random initialisation in the scene's box (its synthetic scenes) and a background
sphere; this project's captures are objects on a support that the cameras circle, so the missing
points have a known place: the support plane.

For every training view, the image is divided into cells; a cell into which no SfM point projects
(within one cell) is uncovered. Its centre ray meets the support plane (:func:`support_plane`: the
lowest well-supported plane across the cameras' up direction among the SfM points near the orbit's
axis; the largest plane may be something standing on it, a ring of texture around a toy); the hit becomes a
point coloured by the cell's pixels when it lies within the cameras' orbit around the look-at point
and no nearby SfM point standing above the plane lies clearly in front of it in that view (then
the cell shows something standing on the support, not the support). The points of all views are merged on a grid of the
cells' size on the plane, so overlapping views give one point per place.

Beyond the support (the backdrop, the floor past a sheet) no plane tells where a cell's surface
lies, but its neighbours do: a cell whose ray misses the support within reach and that holds no SfM
point gets one at the median depth of the SfM points projecting within a few cells of it in that
view, when their depths agree (one smooth surface, not an object's edge against the wall behind),
coloured by the cell; these are merged on a voxel grid of the cells' median footprint. A plain
capture's SfM points are few everywhere, and the textured backdrop far behind gets too few of them
for the short CPU budget to densify before it ends.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import torch

from inpaint360gs.core.camera import Camera
from inpaint360gs.core.support import plane_basis, plane_candidates, voxel_thin


@dataclass(frozen=True)
class SupportInit:
    """Settings of the support points (module docstring)."""

    cell_px: int = 8  # cell side in pixels (at the training resolution)
    reach: float = 1.0  # keep hits within this x the orbit radius of the look-at point, along the plane
    plane_reach: float = 1.5  # the plane is fitted to the SfM points within this x the orbit radius of the orbit's axis
    plane_tol: float = 0.005  # inlier distance, x the median camera distance from the look-at point
    plane_share: float = 0.25  # a candidate plane needs at least this share of the best candidate's inliers
    plane_tries: int = 2000  # RANSAC samples
    front_margin: float = 0.05  # a standing SfM point nearer than (1 - this) x the plane hit's depth hides it ...
    stand: float = 0.02  # ... standing: higher above the plane than this x the median camera distance
    # "auto": a support is plain when at least this share of the cells that show it (the centre ray
    # meets it within reach, unhidden) hold no SfM point
    plain_share: float = 0.5
    # beyond the support (the backdrop, the floor past the sheet): a cell holding no SfM point whose
    # ray misses the support within reach gets a point at the median depth of the SfM points that
    # project within this many cells of it in that view (0: none) ...
    backdrop_window: int = 3
    backdrop_min_points: int = 3  # ... when at least this many do ...
    backdrop_spread: float = 0.15  # ... and their depths agree: (max - min) / median at most this (one smooth surface, not an edge)


@dataclass(frozen=True)
class Orbit:
    """Where the cameras stand: the world up, the point their axes pass nearest, the median horizontal
    and 3D camera distances from it."""

    up: np.ndarray
    look_at: np.ndarray
    radius: float
    camera_distance: float


def orbit_of(cameras: Sequence[Camera]) -> Orbit:
    """The :class:`Orbit` of ``cameras`` (as the geometric segmenter's scene frame measures it)."""
    from inpaint360gs.core.camera import camera_up, nearest_point_to_axes

    up, look = camera_up(cameras), nearest_point_to_axes(cameras)
    rel = np.stack([c.center.double().numpy() for c in cameras]) - look
    return Orbit(up, look, float(np.median(np.linalg.norm(rel - np.outer(rel @ up, up), axis=1))), float(np.median(np.linalg.norm(rel, axis=1))))


def support_plane(points: np.ndarray, frame: Orbit, cfg: SupportInit, rng: np.random.Generator) -> tuple[np.ndarray, float] | None:
    """(normal, offset) of the support: among RANSAC planes through the SfM ``points`` within
    ``plane_reach`` x the orbit radius of the orbit's axis (``frame``), tilted at most 30° from up and below the look-at point, those with at least
    ``plane_share`` of the best one's inliers; the lowest of them at the look-at point, refitted
    to its inliers. None when there is no such plane."""
    up, look = frame.up, frame.look_at
    rel = points - look
    horiz = np.linalg.norm(rel - np.outer(rel @ up, up), axis=1)
    pts = points[horiz <= cfg.plane_reach * frame.radius]
    if len(pts) < 3:
        return None
    tol = cfg.plane_tol * frame.camera_distance
    n, d, ok = plane_candidates(pts, up, cfg.plane_tries, 30.0, rng)
    ok &= n @ look - d > 0
    sel = np.flatnonzero(ok)
    if not len(sel):
        return None
    counts = np.concatenate([(np.abs(pts @ n[sel[i : i + 200]].T - d[sel[i : i + 200]]) <= tol).sum(0) for i in range(0, len(sel), 200)])
    good = sel[counts >= max(3, cfg.plane_share * counts.max())]
    k = good[np.argmax(n[good] @ look - d[good])]  # the lowest: farthest below the look-at point
    normal, offset = n[k], float(d[k])
    for _ in range(2):
        inl = np.abs(pts @ normal - offset) <= tol
        if inl.sum() < 3:
            break
        cen = pts[inl].mean(0)
        _, _, vt = np.linalg.svd(pts[inl] - cen, full_matrices=False)
        normal = vt[2] if vt[2] @ up >= 0 else -vt[2]
        offset = float(normal @ cen)
    return normal, offset


def support_points(
    cameras: Sequence[Camera],
    images: Sequence[np.ndarray],
    points: np.ndarray,
    cfg: SupportInit | None = None,
    stats: dict | None = None,
    backdrop: tuple[list, list, list] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """(xyz (M, 3), rgb (M, 3) in [0, 1]) on the support plane where the SfM ``points`` (P, 3) leave
    cells of the training ``cameras``' ``images`` ((H, W, 3) floats in [0, 1], one per camera)
    uncovered. Empty arrays when the plane cannot be fitted (fewer than three points, no plane).
    ``stats``, when given, receives ``support_cells`` (cells of all views whose centre ray meets the
    support within reach, unhidden) and ``uncovered_support_cells`` (those of them no SfM point
    covers: the points' cells before merging). ``backdrop``, when given (three lists), receives per
    view the cells beyond the support given a point at their neighbours' depth (the module
    docstring): positions, colours and cell footprints, for :func:`thin_backdrop`."""
    from inpaint360gs.core.errors import InputError

    cfg = cfg or SupportInit()
    empty = (np.zeros((0, 3)), np.zeros((0, 3)))
    pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    if len(pts) < 3 or len(cameras) < 2:
        return empty
    try:
        frame = orbit_of(list(cameras))
    except InputError:
        return empty
    if not frame.radius > 0:
        return empty
    plane = support_plane(pts, frame, cfg, np.random.default_rng(0))
    if plane is None:
        return empty
    n, d = plane
    standing = pts @ n - d > cfg.stand * frame.camera_distance
    look = frame.look_at - (frame.look_at @ n - d) * n  # the look-at point dropped onto the plane
    xyz, rgb, size = [], [], []
    cells = [0, 0]  # the cells that show the support, and those of them no SfM point covers
    c = int(cfg.cell_px)
    for cam, img in zip(cameras, images):
        R, t = cam.R.double().numpy(), cam.t.double().numpy()
        W, H = cam.width, cam.height
        gw, gh = -(-W // c), -(-H // c)
        # SfM points in this view: covered cells (grown by one cell) and the nearest depth per cell
        cu, cv, cz, seen = _cells(cam, pts, c)
        up_ = standing[seen]
        near = _nearest_in_cells(cu, cv, cz, gw, gh)
        ii, jj = np.divmod(np.arange(gh * gw), gw)  # every cell (row, column); the uncovered ones are kept below
        # the cell centres' rays and their hits on the plane
        px, py = (jj + 0.5) * c, (ii + 0.5) * c
        px, py = np.minimum(px, W - 0.5), np.minimum(py, H - 0.5)
        dirs_cam = np.stack([(px - cam.cx) / cam.fx, (py - cam.cy) / cam.fy, np.ones_like(px)], -1)
        dirs = dirs_cam @ R  # world directions (R^T d), z-depth 1 per unit
        o = cam.center.double().numpy()
        denom = dirs @ n
        with np.errstate(divide="ignore", invalid="ignore"):
            depth = (d - o @ n) / denom  # camera z of the hit
        hit = o + depth[:, None] * dirs
        along = np.linalg.norm((hit - look) - np.outer((hit - look) @ n, n), axis=1)
        on_support = np.isfinite(depth) & (depth > 0) & (along <= cfg.reach * frame.radius)
        # no standing SfM point two cells around lies clearly in front of the hit (the cell then shows what stands on the support)
        front = np.full((gh + 4, gw + 4), np.inf)
        for dy in range(-2, 3):
            for dx in range(-2, 3):
                np.minimum.at(front, (cv[up_] + 2 + dy, cu[up_] + 2 + dx), cz[up_])
        on_support &= ~(front[ii + 2, jj + 2] < (1.0 - cfg.front_margin) * depth)
        keep = on_support & ~np.isfinite(near[ii, jj])  # uncovered: no SfM point within one cell
        cells[0] += int(on_support.sum())
        cells[1] += int(keep.sum())
        im = np.asarray(img, dtype=np.float64)
        if backdrop is not None and cfg.backdrop_window > 0:
            missed = ~(np.isfinite(depth) & (depth > 0) & (along <= cfg.reach * frame.radius))  # the ray misses the support within reach
            own = np.zeros((gh, gw), bool)
            own[cv, cu] = True  # cells holding an SfM point themselves: the backdrop is filled to one point per cell
            far = np.flatnonzero(missed & ~own[ii, jj])
            if len(far):
                bz = _neighbour_depth(cu, cv, cz, ii[far], jj[far], cfg)
                ok = np.isfinite(bz)
                f = far[ok]
                backdrop[0].append(o + bz[ok, None] * dirs[f])
                backdrop[1].extend(im[ii[k] * c : ii[k] * c + c, jj[k] * c : jj[k] * c + c].reshape(-1, 3).mean(0) for k in f)
                backdrop[2].append(bz[ok] * c / cam.fx)
        if not keep.any():
            continue
        for k in np.nonzero(keep)[0]:
            y0, x0 = ii[k] * c, jj[k] * c
            rgb.append(im[y0 : y0 + c, x0 : x0 + c].reshape(-1, 3).mean(0))
        xyz.append(hit[keep])
        size.append(depth[keep] * c / cam.fx)  # the cell's footprint on the plane (at normal incidence)
    if stats is not None:
        stats.update(support_cells=cells[0], uncovered_support_cells=cells[1])
    if not xyz:
        return empty
    xyz, rgb, size = np.concatenate(xyz), np.asarray(rgb), np.concatenate(size)
    # one point per cell-sized square of the plane: the mean of the hits that fall in it
    step = float(np.median(size))
    basis = np.stack([*plane_basis(n), n])  # plane coordinates, the height half a step up: one layer of voxels
    local = (xyz - look) @ basis.T + [0.0, 0.0, 0.5 * step]
    local, rgb = voxel_thin(local, rgb, step)
    return (local - [0.0, 0.0, 0.5 * step]) @ basis + look, np.clip(rgb, 0.0, 1.0)


def _neighbour_depth(cu: np.ndarray, cv: np.ndarray, cz: np.ndarray, rows: np.ndarray, cols: np.ndarray, cfg: SupportInit) -> np.ndarray:
    """(K,) camera depth for the cells (``rows``, ``cols``): the median depth of the SfM points
    (cells ``cu``, ``cv``, depths ``cz``) within ``cfg.backdrop_window`` cells, NaN where fewer than
    ``cfg.backdrop_min_points`` lie there or their depths spread more than ``cfg.backdrop_spread``."""
    from scipy.spatial import cKDTree

    out = np.full(len(rows), np.nan)
    if len(cz) < cfg.backdrop_min_points or not len(rows):
        return out
    tree = cKDTree(np.stack([cu, cv], 1).astype(np.float64))
    for k, near in enumerate(tree.query_ball_point(np.stack([cols, rows], 1).astype(np.float64), cfg.backdrop_window, p=np.inf)):
        if len(near) < cfg.backdrop_min_points:
            continue
        z = cz[near]
        med = float(np.median(z))
        if (z.max() - z.min()) <= cfg.backdrop_spread * med:
            out[k] = med
    return out


def _cells(cam: Camera, pts: np.ndarray, c: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """The cells (column, row) of ``c``-px side into which ``pts`` project in ``cam``'s image, their
    camera depths, and which of ``pts`` those are (a boolean mask)."""
    R, t = cam.R.double().numpy(), cam.t.double().numpy()
    pc = pts @ R.T + t
    z = pc[:, 2]
    ok = z > 1e-9
    u = cam.fx * pc[ok, 0] / z[ok] + cam.cx
    v = cam.fy * pc[ok, 1] / z[ok] + cam.cy
    inside = (u >= 0) & (u < cam.width) & (v >= 0) & (v < cam.height)
    seen = np.zeros(len(pts), bool)
    seen[np.flatnonzero(ok)[inside]] = True
    return (u[inside] // c).astype(int), (v[inside] // c).astype(int), z[ok][inside], seen


def _nearest_in_cells(cu: np.ndarray, cv: np.ndarray, cz: np.ndarray, gw: int, gh: int) -> np.ndarray:
    """(gh, gw) nearest depth of a point within one cell of each cell (inf: none)."""
    near = np.full((gh + 2, gw + 2), np.inf)  # padded by one
    for dy in (-1, 0, 1):
        for dx in (-1, 0, 1):
            np.minimum.at(near, (cv + 1 + dy, cu + 1 + dx), cz)
    return near[1:-1, 1:-1]


def with_support_points(scene, cfg: SupportInit | None = None, *, auto: bool = False) -> tuple[torch.Tensor, torch.Tensor, dict]:
    """The scene's SfM points and colours with :func:`support_points` appended (and the backdrop's,
    :func:`thin_backdrop`), and a report: ``support_points`` and ``backdrop_points`` (how many were
    added) and ``support_uncovered`` (the share of the cells showing the support that no SfM point
    covers). With ``auto``, the points are added only on a plain support: a share of at least
    ``plain_share``."""
    cfg = cfg or SupportInit()
    views = list(scene.train_views)
    images = [scene.load_image(v).numpy() for v in views]
    stats: dict = {}
    backdrop: tuple[list, list, list] = ([], [], [])
    xyz, rgb = support_points([v.camera for v in views], images, scene.points.double().numpy(), cfg, stats, backdrop)
    share = stats.get("uncovered_support_cells", 0) / max(stats.get("support_cells", 0), 1)
    report = {"support_uncovered": round(share, 4), "support_points": 0, "backdrop_points": 0}
    if not len(xyz) or (auto and share < cfg.plain_share):
        return scene.points, scene.point_colors, report
    bxyz, brgb = thin_backdrop(*backdrop)
    pts = torch.cat([scene.points.float(), torch.from_numpy(xyz).float(), torch.from_numpy(bxyz).float()])
    cols = torch.cat([scene.point_colors.float(), torch.from_numpy(rgb).float(), torch.from_numpy(brgb).float()])
    return pts, cols, {**report, "support_points": len(xyz), "backdrop_points": len(bxyz)}


def thin_backdrop(xyz: list, rgb: list, size: list) -> tuple[np.ndarray, np.ndarray]:
    """The backdrop points of all views (lists of per-view arrays), one per voxel of their median
    cell footprint (overlapping views give one point per place)."""
    if not xyz or not sum(len(x) for x in xyz):
        return np.zeros((0, 3)), np.zeros((0, 3))
    p, c, s = np.concatenate(xyz), np.asarray(rgb, dtype=np.float64).reshape(-1, 3), np.concatenate(size)
    p, c = voxel_thin(p, c, float(np.median(s)))
    return p, np.clip(c, 0.0, 1.0)
