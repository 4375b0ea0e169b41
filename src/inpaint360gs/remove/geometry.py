"""Geometry of the removal on arrays of Gaussian centres (docs/architecture.md, "Removal"): the
object's body in space, the convex hull, the Gaussians hanging below the removed ones, upright
shapes, and the footprint column over the object's outline on its support plane (core/support.py)."""

from __future__ import annotations

import numpy as np
import torch

from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.remove.config import FOOTPRINT_TOP, RemovalConfig


def inlier_points(points: np.ndarray, k: int, n_std: float) -> np.ndarray:
    """Statistical outlier removal: keep points whose mean distance to their k neighbours is at most
    mean + n_std * std over the set."""
    from scipy.spatial import cKDTree

    if len(points) <= k + 1:
        return points
    d, _ = cKDTree(points).query(points, k=k + 1)
    m = d[:, 1:].mean(axis=1)
    return points[m <= m.mean() + n_std * m.std()]


def object_body(points: np.ndarray, link: float, min_part: float, near: float = 0.25) -> np.ndarray:
    """Boolean mask of the ``points`` in the object's body: connected components of the graph that
    links centres closer than ``link`` x the median nearest-neighbour distance, kept when they hold
    at least ``min_part`` of the largest component's points; a smaller piece is kept too where it
    lies inside the kept body's bounding box grown by ``near`` x its size (a sparsely reconstructed
    part of the object, not a stray Gaussian elsewhere in the scene)."""
    from inpaint360gs.core.support import linked_body

    if len(points) < 3:
        return np.ones(len(points), dtype=bool)
    body = linked_body(points, link, min_part)
    lo, hi = points[body].min(axis=0), points[body].max(axis=0)
    pad = near * (hi - lo)
    return body | ((points >= lo - pad) & (points <= hi + pad)).all(axis=1)


def inside_hull(points: np.ndarray, queries: np.ndarray) -> np.ndarray:
    """Boolean mask of ``queries`` inside the convex hull of ``points`` (on or behind every facet's
    plane of qhull's hull, to a relative 1e-9 of the points' extent; degenerate sets: nothing is
    inside). Facet planes, not a point location in a Delaunay triangulation: that walk fell back to a
    brute-force search for many queries (a minute for the 50k Gaussians of a capture)."""
    from scipy.spatial import ConvexHull, QhullError

    out = np.zeros(len(queries), dtype=bool)
    if len(points) < 5:
        return out
    try:
        eq = ConvexHull(points).equations  # (F, 4): unit outward normal n and offset c, inside where n.x + c <= 0
    except QhullError:  # flat or collinear: no volume
        return out
    lo, hi = points.min(axis=0), points.max(axis=0)
    tol = 1e-9 * float(np.max(hi - lo))
    box = np.flatnonzero(((queries >= lo - tol) & (queries <= hi + tol)).all(axis=1))  # only these can be inside
    for start in range(0, len(box), 4096):  # bounded memory: a block of queries against every facet
        idx = box[start : start + 4096]
        out[idx] = (queries[idx] @ eq[:, :3].T + eq[:, 3] <= tol).all(axis=1)
    return out


def hanging_below(means: np.ndarray, heights: np.ndarray, up: np.ndarray, removed: np.ndarray, candidates: np.ndarray, r: float) -> np.ndarray:
    """Candidates reached from ``removed`` by steps down: each within horizontal distance ``d <= r``
    of a removed (or already reached) Gaussian and lower than it by between ``d`` and ``2 r``
    (see ``RemovalConfig.support_column``). A breadth-first growth over a k-d tree (scipy) of the
    candidates' horizontal positions."""
    from scipy.spatial import cKDTree

    out = np.zeros(len(means), dtype=bool)
    cand = np.flatnonzero(candidates & ~removed)
    if not len(cand) or r <= 0:
        return out
    flat = means - np.outer(means @ up, up)  # positions in the support plane's directions
    tree = cKDTree(flat[cand])
    frontier = np.flatnonzero(removed)
    while len(frontier):
        hits = tree.query_ball_point(flat[frontier], r)
        counts = np.fromiter((len(h) for h in hits), np.int64, len(hits))
        if not counts.sum():
            break
        f = np.repeat(frontier, counts)  # each (frontier Gaussian, candidate within r) pair, at once
        c = cand[np.concatenate([np.asarray(h, np.int64) for h in hits if h])]
        fresh = ~out[c]
        f, c = f[fresh], c[fresh]
        d = np.linalg.norm(flat[c] - flat[f], axis=1)
        drop = heights[f] - heights[c]
        frontier = np.unique(c[(drop >= d) & (drop > 0) & (drop <= 2 * r)])
        out[frontier] = True
    return out


def upright(gaussians: Gaussians, up: np.ndarray) -> np.ndarray:
    """Gaussians whose variance along ``up`` exceeds their variance across it (the sum over the two
    directions in the plane): shapes standing on a surface, never a splat lying in it."""
    from inpaint360gs.render.projection import covariance_3d

    with torch.no_grad():
        cov = covariance_3d(gaussians.quats.detach().double(), gaussians.log_scales.detach().double()).cpu().numpy()
    u = np.asarray(up, dtype=np.float64)
    along = np.einsum("i,nij,j->n", u, cov, u)
    return along > np.trace(cov, axis1=1, axis2=2) - along


def footprint_columns(means: np.ndarray, opacities: np.ndarray, remove: np.ndarray, bodies: list[np.ndarray], keep: np.ndarray,
                      up: np.ndarray | None, cfg: RemovalConfig, counts: dict, colours: np.ndarray | None = None,
                      silhouette_share=None) -> tuple[np.ndarray, list]:  # fmt: skip
    """Step 4 (``RemovalConfig.footprint_margin``): ``remove`` plus every Gaussian in each object's
    footprint column (not those in ``keep``: other objects), minus the support Gaussians the
    selection took outside it. ``bodies``: per object, what steps 1-2 took; ``up`` a hint of the
    support's normal (None: the cameras' up is not known and the column is skipped); ``colours``
    (N, 3) in [0, 1], None = every low selected Gaussian far enough out counts as support.
    ``silhouette_share(indices, body) -> (M,)``: the share of the training views showing each
    Gaussian in which its centre lies in the silhouette of ``body``; given, a Gaussian of the column
    higher than the object goes only when that share reaches ``cfg.column_silhouette`` (None: the
    whole column to its top; on and under the plane a Gaussian, the selection's own too, stays
    when its share of the silhouette of ``body`` standing above the plane is below
    ``cfg.plane_silhouette`` and it has the colour of the support next to it and not the object's).
    With ``cfg.low_parts``, low unselected Gaussians linked to what goes and nearer the object's
    colour go too. Returns the new
    flags and the footprints found;
    ``counts`` records what the step did (or why it did not)."""
    from inpaint360gs.core.support import STANDING, object_footprint

    remove = remove.copy()
    found = []
    if up is None:  # no support plane (removal.json's "support" says why)
        return remove, found
    for i, body in enumerate(bodies):
        try:
            fp = object_footprint(means[body], opacities[body], means[~remove], opacities[~remove], up)
        except ValueError as e:
            counts.setdefault("footprint", []).append(f"skipped: {e}")
            continue
        h = fp.heights(means)
        d = fp.distance(means)
        column = (d <= cfg.footprint_margin * fp.size) & (h > -cfg.footprint_depth * fp.height) & (h <= FOOTPRINT_TOP * fp.height) & ~keep
        # over the object's top, a faint Gaussian is the object's appearance when the views see it in
        # front of the object; one whose centre lies off its silhouette is the background's (a floater
        # that colours the room or the table beyond the footprint in the other views): it stays
        high = np.flatnonzero(column & ~remove & (h > fp.height))
        low = np.abs(h) <= cfg.support_band * fp.height
        # on the plane and under it, the same test tells the support the views see beside the object
        # (under a spout, a handle, a belly: the outline on the plane is wider than what hides the
        # support; a plain support's Gaussians placed under the plane; a piece of the support next
        # to the object that the selection took) from what is under it, which no view sees but
        # through the hole (below). The silhouette is that of the object standing above the plane:
        # a piece of support the selection took is in its own silhouette in every view.
        flat = np.flatnonzero((remove | column) & (low | (h < -cfg.support_band * fp.height)))
        # what the selection took standing outside the column, lower than the object's top, is apart
        # from the object's body (the outline is the body's, core.support.OUTLINE_LINK): Gaussians
        # a little over the support that the field labelled as the object. The same test tells
        # the support's (seen beside the object, in the support's colours: they stay) from the
        # object's own sparse parts (in its silhouette).
        apart = remove & body & (d > cfg.footprint_margin * fp.size) & (h > cfg.support_band * fp.height) & (h <= fp.height)
        flat = np.concatenate([flat, np.flatnonzero(apart)])
        dropped = 0
        beside = np.zeros_like(remove)
        if silhouette_share is not None and cfg.column_silhouette is not None and len(high) + len(flat):
            # on and under the plane nothing of the standing object is: a Gaussian there that a
            # quarter of the views see beside the object colours the support in those views (a
            # plain sheet's Gaussians spread under the plane behind the object's base), while the
            # others see it behind the object; over the top and apart from the body, half
            on_plane = np.zeros(len(high) + len(flat), dtype=bool)
            on_plane[len(high) :] = ~apart[flat]
            limit = np.where(on_plane, cfg.plane_silhouette, cfg.column_silhouette)
            off = silhouette_share(np.concatenate([high, flat]), body & (h > cfg.support_band * fp.height) & ~apart) < limit
            column[high[off[: len(high)]]] = False
            beside[flat[off[len(high) :]]] = True
            dropped = int(off[: len(high)].sum())
        apart_off = int((beside & apart).sum())
        support = remove & body & (d > cfg.support_reach * fp.size) & low
        # the support's own Gaussians around the footprint, at whatever depth the column reaches
        # (a plain support gives 3DGS no depth: its Gaussians spread below the plane)
        ring = ~remove & ~column & (h > -cfg.footprint_depth * fp.height) & (h <= cfg.support_band * fp.height)
        ring &= (d > cfg.footprint_margin * fp.size) & (d <= (cfg.support_reach + 0.25) * fp.size)
        if colours is not None and support.any():
            support[support] = support_coloured(colours[support], colours[ring])
        # What the views see beside the object's silhouette, on the support plane (the selection's
        # own Gaussians too) or under it (a plain sheet or table top gives 3DGS no depth, and part of
        # it lies under the plane), is the support when it has the colours of the support next to
        # it: it stays. The dark underside, contact shadow and print go.
        # the object as it stands, and the support beyond the reach of its low parts (the ring holds
        # them: a bucket's teeth on the mat), for which of the two a Gaussian's colour is nearer
        standing = remove & body & (h > STANDING * fp.height) & ~apart
        reach = cfg.low_parts if cfg.low_parts is not None else cfg.support_reach
        outer = ~remove & ~column & (h > -cfg.footprint_depth * fp.height) & (h <= cfg.support_band * fp.height)
        outer &= (d > reach * fp.size) & (d <= (reach + 0.25) * fp.size)
        if colours is not None and beside.any():
            beside[beside] = support_coloured_nearby(means[beside], colours[beside], means[ring], colours[ring]) & ~nearer_object(
                means[beside], colours[beside], means[outer], colours[outer], means[standing], colours[standing])
        else:
            beside[:] = False
        support |= beside
        column_added = int((column & ~remove).sum())
        remove = (remove | column) & ~support
        # The object's low parts the field gave to the background (a bucket's teeth lying on a mat,
        # a toy's feet on a sheet): beside the outline, lower than its standing share, linked to
        # what goes and nearer the object's chromaticity than the support's, they go with the object.
        low_parts = np.zeros_like(remove)
        if cfg.low_parts is not None and colours is not None:
            cand = ~remove & ~keep & (h > -cfg.support_band * fp.height) & (h <= STANDING * fp.height) & (d <= cfg.low_parts * fp.size)
            idx = np.flatnonzero(cand)
            if len(idx):
                cand[idx[~nearer_object(means[idx], colours[idx], means[outer], colours[outer], means[standing], colours[standing])]] = False
                low_parts = linked_growth(means, remove & (d <= cfg.low_parts * fp.size), cand, cfg.link * spacing(means[body]))
            remove |= low_parts
        counts.setdefault("footprint", []).append({"column": column_added, "support_kept": int(support.sum()), "height": fp.height, "size": fp.size,
                                                   "above_off_silhouette": dropped,
                                                   "support_beside": int(beside.sum()), "support_beside_under_plane": int((beside & (h < -cfg.support_band * fp.height)).sum()),
                                                   "apart": int(apart.sum()), "apart_off_silhouette": apart_off, "support_beside_apart": int((beside & apart).sum()),
                                                   "low_parts": int(low_parts.sum())})  # fmt: skip
        # The object's own low parts (a flat base, a rim lying on the support: below the outline's
        # standing share, not in the support's colours) covered support that is now empty: the
        # footprint widens to them, so the inpainting fills there on the plane (Sec. 3.4) like the
        # rest; the farthest 1 % are strays. Without colours, no low part is told from the support.
        base = remove & (body | low_parts) & (h > -cfg.footprint_depth * fp.height) & (h <= STANDING * fp.height) & (opacities > 0.1) & (d > 0)
        if colours is None:
            base[:] = False
        elif base.any():
            base[base] = ~support_coloured(colours[base], colours[ring])
        if base.any():
            base &= d <= np.quantile(d[base], 0.99)
        found.append(fp.widened(means[base]))
    return remove, found


def spacing(points: np.ndarray) -> float:
    """Median nearest-neighbour distance of ``points`` (0 for fewer than 2)."""
    from scipy.spatial import cKDTree

    if len(points) < 2:
        return 0.0
    return float(np.median(cKDTree(points).query(points, k=2)[0][:, 1]))


def linked_growth(means: np.ndarray, seeds: np.ndarray, candidates: np.ndarray, radius: float) -> np.ndarray:
    """(N,) bool: the ``candidates`` reached from the ``seeds`` by steps no longer than ``radius``
    through candidates (a breadth-first growth over a k-d tree of the candidates' centres)."""
    from scipy.spatial import cKDTree

    out = np.zeros(len(means), dtype=bool)
    cand = np.flatnonzero(candidates & ~seeds)
    if not len(cand) or not seeds.any() or radius <= 0:
        return out
    tree = cKDTree(means[cand])
    frontier = means[seeds]
    while len(frontier):
        hits = {j for near in tree.query_ball_point(frontier, radius) for j in near}
        new = np.array(sorted(j for j in hits if not out[cand[j]]), dtype=np.int64)
        if not len(new):
            break
        out[cand[new]] = True
        frontier = means[cand[new]]
    return out


TINT = 0.03  # chromaticity shares closer than this are one tint (a grey object on a grey floor)


def nearer_object(positions: np.ndarray, candidates: np.ndarray, ring_positions: np.ndarray, ring: np.ndarray, object_positions: np.ndarray,
                  object_colours: np.ndarray, k: int = 8) -> np.ndarray:  # fmt: skip
    """(M,) bool: which ``candidates`` (M, 3) colours at ``positions`` are nearer, in
    :func:`chromaticity`, the median of their ``k`` nearest Gaussians of the object
    (``object_positions``, ``object_colours``) than that of their ``k`` nearest ``ring`` Gaussians
    of the support, and tinted apart from the support (farther than :data:`TINT`: a grey object on
    a grey floor is never told from it this way). A textured support's colours
    spread as far as an object's (a tooth of a yellow bucket lying on a woven pink mat is within
    the mat's own spread), but next to the object a part of it looks like the object. Fewer than
    k Gaussians on either side: False (nothing to compare with)."""
    from scipy.spatial import cKDTree

    if len(ring) < k or len(object_colours) < k or not len(candidates):
        return np.zeros(len(candidates), dtype=bool)
    c, r, o = chromaticity(candidates), chromaticity(ring), chromaticity(object_colours)
    to_ring = np.linalg.norm(c - np.median(r[cKDTree(ring_positions).query(positions, k=k)[1]], axis=1), axis=1)
    to_object = np.linalg.norm(c - np.median(o[cKDTree(object_positions).query(positions, k=k)[1]], axis=1), axis=1)
    return (to_object < to_ring) & (to_ring > TINT)


def chromaticity(colours: np.ndarray, floor: float = 0.15) -> np.ndarray:
    """(M, 2) red and green shares of (M, 3) RGB colours, r / (r + g + b + floor): the same for a
    surface lit or in shade (an object's shaded underside and its lit parts; a mat and the shadow
    on it), while ``floor`` pulls near-black colours, whose shares are noise, towards grey's."""
    total = colours.sum(axis=1, keepdims=True) + floor
    return (colours[:, :2] + floor / 3) / total


def support_coloured(candidates: np.ndarray, ring: np.ndarray, k: int = 8, quantile: float = 0.9) -> np.ndarray:
    """(M,) bool: which ``candidates`` (M, 3) colours the support's own ``ring`` (R, 3) colours hold:
    a candidate's mean colour distance to its ``k`` nearest ring colours is within the ``quantile``
    of the same distance among the ring's colours (each without itself). Fewer than 2k ring
    colours: every candidate counts (nothing to compare with)."""
    from scipy.spatial import cKDTree

    if len(ring) < 2 * k:
        return np.ones(len(candidates), dtype=bool)
    tree = cKDTree(ring)
    own = tree.query(ring, k=k + 1)[0][:, 1:].mean(axis=1)
    return tree.query(candidates, k=k)[0].mean(axis=1) <= np.quantile(own, quantile)


def support_coloured_nearby(positions: np.ndarray, candidates: np.ndarray, ring_positions: np.ndarray, ring: np.ndarray,
                            k: int = 8, quantile: float = 0.9) -> np.ndarray:  # fmt: skip
    """(M,) bool: which ``candidates`` (M, 3) colours at ``positions`` (M, 3) hold the colours of the
    support next to them: a candidate's colour distance to the median colour of its ``k`` nearest
    ``ring`` Gaussians in space (``ring_positions`` (R, 3), colours ``ring`` (R, 3)) is within the
    ``quantile`` of the same distance among the ring's Gaussians (each without itself). A support of
    several colours (two mats, a mat's stripes, wood) makes :func:`support_coloured` hold a shadow
    on one in the colours of another; here each is compared with the support around it. Fewer than
    2k ring Gaussians: every candidate counts."""
    from scipy.spatial import cKDTree

    if len(ring) < 2 * k:
        return np.ones(len(candidates), dtype=bool)
    tree = cKDTree(ring_positions)
    own_idx = tree.query(ring_positions, k=k + 1)[1][:, 1:]
    own = np.linalg.norm(ring - np.median(ring[own_idx], axis=1), axis=1)
    idx = tree.query(positions, k=k)[1]
    return np.linalg.norm(candidates - np.median(ring[idx], axis=1), axis=1) <= np.quantile(own, quantile)
