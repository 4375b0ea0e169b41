"""Key Object Management: view-consistent object ids from per-view 2D segments (paper Sec. 3.2,
Eq. 2, Alg. 1; supp. B "Mask Association"). Design and the rules beyond Alg. 1: docs/architecture.md,
"Decisions the paper leaves open", "Association".

For each training view in capture order:

1. Project the Gaussian centres with opacity at least ``min_opacity`` into the view.
2. Per ``patch`` x ``patch`` cell of every segment, split the Gaussians projecting there into a near
   and a far cluster by exact 1-D K-Means (K = 2) on depth; only the near cluster takes the
   segment's label (paper Fig. 3). ``keep_near < 1`` keeps only that nearest fraction.
3. Compare each segment's Gaussian set with every object of the Key Object Database by GS-IoU
   (Eq. 2; ``variant="code"``: ``|A ∩ B| / (|B| + |A ∩ B|)``). At or above σ the segment takes the best
   object's id and its Gaussians join that set; below it founds a new object (at most
   :data:`~.config.MAX_OBJECTS`). ``compare="visible"`` compares each set through the Gaussians this
   view labels, ``"all"`` through the whole set.
   Beyond Alg. 1 (``part_share=0, merge_share=0`` switches the first two off): a segment below σ
   with at least ``part_share`` of its Gaussians in one object's set takes that id (a part); a
   segment holding at least ``merge_share`` of each of two or more objects' sets is divided between
   them (a merge: Gaussians by set, pixels by the nearest projected Gaussian); with ``consolidate``,
   after the pass two objects are joined when more views segmented them as one than as two.
4. The view's associated mask is its segments relabelled with these ids; pixels outside any kept
   segment (covering a Gaussian and at least ``min_segment_pixels`` pixels) are background (0).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from inpaint360gs.associate.config import MAX_OBJECTS, AssociationConfig
from inpaint360gs.core.camera import Camera


def project_centres(means: np.ndarray, camera: Camera) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Pixel column, row (integers) and camera depth of the centres in front of ``camera`` and inside
    its image, with their indices into ``means``."""
    R = camera.R.detach().cpu().double().numpy()
    t = camera.t.detach().cpu().double().numpy()
    xc = means @ R.T + t
    z = xc[:, 2]
    front = z > 1e-6
    with np.errstate(divide="ignore", invalid="ignore"):
        u = camera.fx * xc[:, 0] / z + camera.cx
        v = camera.fy * xc[:, 1] / z + camera.cy
    inside = front & (u >= 0) & (u < camera.width) & (v >= 0) & (v < camera.height)
    idx = np.flatnonzero(inside)
    return np.floor(u[idx]).astype(np.int64), np.floor(v[idx]).astype(np.int64), z[idx], idx


def near_cluster(groups: np.ndarray, depth: np.ndarray, keep_near: float = 1.0) -> np.ndarray:
    """Boolean mask of the elements in the near cluster of K-Means (K = 2) on ``depth``, per group.

    In one dimension the optimal 2-means partition is a split of the sorted values; it is found
    exactly by evaluating every split point's within-cluster sum of squares (vectorised over all
    groups). Groups of one element keep it. ``keep_near < 1`` keeps only that nearest fraction of
    each near cluster (at least one element).
    """
    n = len(depth)
    keep = np.zeros(n, dtype=bool)
    if n == 0:
        return keep
    order = np.lexsort((depth, groups))
    g, z = groups[order], depth[order].astype(np.float64)
    starts = np.flatnonzero(np.r_[True, g[1:] != g[:-1]])
    sizes = np.diff(np.r_[starts, n])
    gid = np.repeat(np.arange(len(starts)), sizes)
    pos = np.arange(n) - starts[gid]  # 0-based position inside the group
    cz, cz2 = np.cumsum(z), np.cumsum(z * z)
    base = np.r_[0.0, cz][starts][gid]
    base2 = np.r_[0.0, cz2][starts][gid]
    tot = (np.r_[cz[starts + sizes - 1]])[gid] - base
    tot2 = (np.r_[cz2[starts + sizes - 1]])[gid] - base2
    k = pos + 1.0  # left cluster = first k elements of the group
    left, left2 = cz - base, cz2 - base2
    right_n = sizes[gid] - k
    sse = left2 - left * left / k
    with np.errstate(divide="ignore", invalid="ignore"):
        sse = sse + np.where(right_n > 0, (tot2 - left2) - (tot - left) ** 2 / right_n, np.inf)
    sse[sizes[gid] == 1] = 0.0  # a lone Gaussian: it is the near cluster
    # best split per group: smallest SSE (first on ties)
    best = np.lexsort((pos, sse, gid))
    first = best[np.r_[True, gid[best][1:] != gid[best][:-1]]]
    n_near = pos[first] + 1  # size of the near cluster per group
    n_keep = np.maximum(1, np.floor(n_near * keep_near + 1e-9)).astype(np.int64)
    keep[order[pos < n_keep[gid]]] = True
    return keep


def gs_iou(db: np.ndarray, db_sizes: np.ndarray, members: np.ndarray, variant: str) -> np.ndarray:
    """GS-IoU (Eq. 2) of the proposal ``members`` (Gaussian indices) with every database object
    (rows of the boolean matrix ``db``); the public code's variant is |A∩B| / (|B| + |A∩B|)."""
    inter = db[:, members].sum(axis=1).astype(np.float64)
    if variant == "code":
        return inter / np.maximum(db_sizes + inter, 1)
    return inter / np.maximum(db_sizes + len(members) - inter, 1)


def segment_ids(seg: np.ndarray, min_pixels: int) -> tuple[np.ndarray, np.ndarray]:
    """The ids of ``seg``'s segments (0 is no segment) of at least ``min_pixels`` pixels, and their pixel counts."""
    ids, counts = np.unique(seg, return_counts=True)
    keep = (ids != 0) & (counts >= min_pixels)
    return ids[keep], counts[keep]


def kom(segs: Sequence[np.ndarray], cams: Sequence[Camera], means: np.ndarray, cfg: AssociationConfig) -> tuple[list[np.ndarray], np.ndarray]:
    """Key Object Management over the views in order (module docstring): ``segs`` (H, W) id images
    and ``cams`` their cameras, ``means`` (N, 3) the Gaussian centres taking part. Returns the
    associated (H, W) uint8 id images and the number of Gaussians in each object's set."""
    n = len(means)
    db = np.zeros((0, n), dtype=bool)
    db_sizes = np.zeros(0)
    out = []
    together: dict[tuple[int, int], int] = {}  # object pairs: views where one segment covered both ...
    apart: dict[tuple[int, int], int] = {}  # ... and views where two segments took them
    for seg, cam in zip(segs, cams):
        u, v, z, idx = project_centres(means, cam)
        labels = seg[v, u].astype(np.int64)
        ids, _ = segment_ids(seg, cfg.min_segment_pixels)
        on = np.isin(labels, ids)
        u, v, z, idx, labels = u[on], v[on], z[on], idx[on], labels[on]
        tiles_x = -(-cam.width // cfg.patch)
        group = labels * ((-(-cam.height // cfg.patch)) * tiles_x) + (v // cfg.patch) * tiles_x + (u // cfg.patch)
        near = near_cluster(group, z, cfg.keep_near)
        lut = np.zeros(int(seg.max()) + 1, dtype=np.uint8)
        if cfg.compare == "visible":  # the database seen from this view: each set restricted to what this view labels
            labelable = np.unique(idx[near])
            pos = np.full(n, -1, dtype=np.int64)
            pos[labelable] = np.arange(labelable.size)
        pieces = {}  # merged segments: segment id -> (pixel labels of its members, their projections)
        both_of = {}  # merged segments: segment id -> the database rows it was divided between
        for s in ids:
            in_s = near & (labels == s)
            members = np.unique(idx[in_s])
            if members.size == 0:
                continue  # the segment covers no Gaussian: background
            if len(db):
                if cfg.compare == "visible":
                    seen, cols = db[:, labelable], pos[members]
                else:
                    seen, cols = db, members
                sizes = seen.sum(axis=1).astype(np.float64)
                inter = seen[:, cols].sum(axis=1).astype(np.float64)
                if cfg.merge_share > 0:
                    both = np.flatnonzero((inter >= cfg.merge_share * np.maximum(sizes, 1)) & (inter >= 0.2 * members.size))
                    if both.size >= 2:  # two known objects in one segment: divide it, keep the database clean
                        owner = _merge_owner(seen[both][:, cols], inter[both])  # each Gaussian stays in a set it is in: no update
                        g_owner = np.full(n, -1, dtype=np.int64)
                        g_owner[members] = np.where(owner >= 0, both[np.maximum(owner, 0)] + 1, -1)
                        pieces[s] = (g_owner[idx[in_s]], u[in_s], v[in_s])
                        both_of[s] = [int(b) for b in both]
                        continue
                score = gs_iou(seen, sizes, cols, cfg.variant)
                j = int(np.argmax(score))
                if score[j] <= cfg.sigma and cfg.part_share > 0:  # a part of a known object (a split): mostly inside its set
                    share = inter / members.size
                    if share.max() >= cfg.part_share:
                        j = int(np.argmax(share))
                        score[j] = np.inf
                if score[j] > cfg.sigma:
                    db[j, members] = True
                    db_sizes[j] = db[j].sum()
                    lut[s] = j + 1
                    continue
            if len(db) >= MAX_OBJECTS:
                continue  # no id left: background (reported in objects.json via the counts)
            row = np.zeros((1, n), dtype=bool)
            row[0, members] = True
            db = np.vstack([db, row])
            db_sizes = np.r_[db_sizes, members.size]
            lut[s] = len(db)
        mask = lut[seg]
        for s, (g_lab, gu, gv) in pieces.items():
            mask = _split_pixels(mask, seg == s, g_lab, gu, gv)
        out.append(mask)
        if cfg.consolidate:
            _count_pairs([{int(lut[s]) - 1} for s in ids if lut[s] and s not in pieces], [set(both_of[s]) for s in pieces], together, apart)
    if cfg.consolidate and together:
        out, db = _consolidate(out, db, together, apart)
        db_sizes = db.sum(axis=1).astype(np.float64)
    return out, db_sizes


def _count_pairs(matched: list[set[int]], divided: list[set[int]], together: dict, apart: dict) -> None:
    """One view's evidence on pairs of database objects: ``together`` when one segment covered both
    (a divided segment), ``apart`` when two different segments of the view took them."""
    for ids in divided:
        for pair in {(a, b) for a in ids for b in ids if a < b}:
            together[pair] = together.get(pair, 0) + 1
    groups = matched + divided
    seen = set()
    for i, gi in enumerate(groups):
        for gj in groups[i + 1 :]:
            seen |= {(min(a, b), max(a, b)) for a in gi for b in gj if a != b}
    for pair in seen:
        apart[pair] = apart.get(pair, 0) + 1


def _consolidate(masks: list[np.ndarray], db: np.ndarray, together: dict, apart: dict) -> tuple[list[np.ndarray], np.ndarray]:
    """Join database objects that more views segmented as one than as two (pieces of one object
    founded apart), renumber the ids 1..n in their first order, relabel every view."""
    from scipy.cluster.hierarchy import DisjointSet

    groups = DisjointSet(range(len(db)))
    for (a, b), n in together.items():
        if n > apart.get((a, b), 0):
            groups.merge(a, b)
    roots = np.array([min(groups.subset(a)) for a in range(len(db))])  # each group named by its first object
    if (roots == np.arange(len(db))).all():
        return masks, db
    keep = np.unique(roots)
    new_id = np.zeros(len(db), dtype=np.int64)
    new_id[keep] = np.arange(1, len(keep) + 1)
    lut = np.zeros(len(db) + 1, dtype=np.uint8)
    lut[1:] = new_id[roots]
    merged = np.zeros((len(keep), db.shape[1]), dtype=bool)
    for a in range(len(db)):
        merged[new_id[roots[a]] - 1] |= db[a]
    return [lut[m] for m in masks], merged


def _merge_owner(sets: np.ndarray, inter: np.ndarray) -> np.ndarray:
    """For a merged segment: the candidate (row of ``sets``, (K, M) membership of its M Gaussians)
    each Gaussian belongs to; in several sets the one sharing most with the segment; in none -1."""
    owner = np.full(sets.shape[1], -1, dtype=np.int64)
    for k in np.argsort(inter, kind="stable"):  # larger overlaps written last: they win ties
        owner[sets[k]] = k
    return owner


def _split_pixels(mask: np.ndarray, region: np.ndarray, g_lab: np.ndarray, gu: np.ndarray, gv: np.ndarray) -> np.ndarray:
    """Label the pixels of ``region`` with the id of the nearest projected Gaussian that has one."""
    from scipy.spatial import cKDTree

    ok = g_lab > 0
    out = mask.copy()
    ry, rx = np.nonzero(region)
    if not ok.any():
        out[ry, rx] = 0
        return out
    _, j = cKDTree(np.stack([gu[ok], gv[ok]], axis=1)).query(np.stack([rx, ry], axis=1))
    out[ry, rx] = g_lab[ok][j].astype(out.dtype)
    return out
