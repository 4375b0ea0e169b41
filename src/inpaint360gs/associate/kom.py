"""Key Object Management: view-consistent object ids from per-view 2D segments (paper Sec. 3.2,
Eq. 2, Alg. 1; supp. B "Mask Association").

Raw segments (one id image per training view, ids arbitrary per view) are linked across views
through the Gaussians they cover. For each view in capture order:

1. Project the Gaussian centres into the view (Gaussians with opacity below ``min_opacity`` are
   left out: they carry no visible content and make the sets noisy).
2. Per 16 x 16 patch of every segment, split the Gaussians projecting there into a near and a far
   cluster by K-Means with K = 2 on their depth (in 1-D the optimal split is found exactly: the one
   minimising the within-cluster sum of squares over the depth-sorted Gaussians). Only the near
   cluster takes the segment's label — the far one is what the object occludes (paper Fig. 3).
   The authors' public code additionally keeps only the nearest 30% of that cluster (an option).
3. Compare each segment's Gaussian set with every object of the Key Object Database by GS-IoU
   (Eq. 2, ``|A ∩ B| / |A ∪ B|``; the public code's variant ``|A ∩ B| / (|B| + |A ∩ B|)`` is an
   option). Above the threshold σ the segment inherits the best object's id and its Gaussians join
   that object's set; otherwise it founds a new object (at most 255, paper: 256 classes with the
   background). The paper compares proposals "from different views"; a database set gathers the
   Gaussians of every view so far, while a view labels only the side it sees, so against the whole
   set the score is at most ``|A| / |B|``: once an object's set holds more than 1/σ = 5 times what
   one view labels, no view can match it any more and the object splits into new ids (the watering
   can of the benchmark's ``garden``: two ids over 29 and 21 views). By default (``compare=
   "visible"``) each set is therefore compared through the Gaussians the current view labels (the
   near clusters of all its segments): the database as seen from this view. ``compare="all"`` is
   the literal reading.
   **Parts and merges** (beyond Alg. 1; ``part_share=0, merge_share=0`` gives Alg. 1 alone: with no
   divided segment the consolidation below has nothing to join). An automatic segmenter also cuts
   objects in pieces and joins touching ones (the ``oracle`` segmenter's damage imitates both). A piece of a known object scores at most its size over the
   object's, so below σ it founds a new id, which then competes with the object's own in later
   views and takes it over (measured on ``fruits`` with damaged masks: the apple switches ids at
   view 21 and keeps the new one). So a segment below σ whose Gaussians lie mostly (``part_share``
   = 0.6) in one object's set takes that object's id. A segment covering two objects at once scores
   about 0.5 with the larger and would pour the other's Gaussians into its set, after which both
   objects match that set; so a segment holding at least ``merge_share`` = 0.5 of each of two or
   more objects' sets (as seen from this view, each also ≥ 20% of the segment) is divided: each
   Gaussian goes to the object whose set holds it, each pixel to the object of its nearest such
   projected Gaussian, and nothing joins a set it does not already belong to.
   **Pieces founded apart** (``consolidate``, beyond Alg. 1). When an object's first views cut it in
   pieces, each piece founds an object before the whole was ever seen, and every later whole segment
   is then divided between them as if it were a merge. Whether two database objects are one is
   decided by the views: after the pass, two objects are joined (ids and sets) when more views
   segmented them as one segment (a divided segment) than as two different segments; two touching
   objects that a segmenter merges now and then are seen apart in most views and stay two.
4. The view's associated mask is its segments relabelled with these ids; pixels outside any
   segment, and segments that cover no Gaussian or fewer than ``min_segment_pixels`` pixels, are
   background (0).

``method="tracker"`` is the paper's ablation a) ("w/o object association", Tab. 3): ids are carried
from one view to the next by 2D IoU of the segments, like a video tracker, without the Gaussians.
"""

from __future__ import annotations

import json
import time
from collections.abc import Sequence
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import numpy as np
import torch

from inpaint360gs.core.camera import Camera
from inpaint360gs.core.errors import InputError
from inpaint360gs.core.files import read_json_object
from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.io import provenance
from inpaint360gs.io.atomic import atomic_dir, check_output_dir
from inpaint360gs.io.images import write_labels
from inpaint360gs.io.scene import Scene

MAX_OBJECTS = 255  # ids 1..255; 0 is the background (paper supp. B: at most 256 classes)


@dataclass
class AssociationConfig:
    """Settings of the association; defaults are the paper's (supp. B "Mask Association")."""

    method: str = "kom"  # "kom": Key Object Management (Sec. 3.2); "tracker": ablation a), 2D IoU between consecutive views
    variant: str = "paper"  # "paper": sigma 0.2 on plain IoU; "code": the authors' public code (sigma 0.1, |A∩B|/(|B|+|A∩B|), nearest 30%)
    sigma: float | None = None  # GS-IoU threshold; None = the variant's (0.2 paper, 0.1 code)
    patch: int = 16  # masks are matched per patch of this many pixels (supp. B)
    keep_near: float | None = None  # keep this nearest fraction of the near cluster; None = the variant's (1.0 paper, 0.3 code)
    min_opacity: float = 0.05  # Gaussians below this opacity take no part
    min_segment_pixels: int = 16  # smaller segments are background
    tracker_iou: float = 0.3  # tracker: a segment inherits the id of the previous view's region it overlaps by at least this IoU
    # what a database set is compared through: "visible" = only its Gaussians this view can label (those
    # in the near cluster of any of its segments); "all" = the whole accumulated set (see the module docstring)
    compare: str = "visible"
    # Beyond Alg. 1 (both 0 = the paper's rule alone; see the module docstring, "Parts and merges"):
    part_share: float = 0.6  # an unmatched segment with at least this share of its Gaussians in one object's set is a part of it
    merge_share: float = 0.5  # a segment holding at least this share of each of two or more objects' sets (as seen) is a merge: split between them
    consolidate: bool = True  # after the pass, join objects that more views segmented as one than as two

    def resolved(self) -> AssociationConfig:
        if self.method not in ("kom", "tracker"):
            raise InputError(f"unknown association method {self.method!r} (kom, tracker)", "--method")
        if self.variant not in ("paper", "code"):
            raise InputError(f"unknown association variant {self.variant!r} (paper, code)", "--variant")
        if self.compare not in ("visible", "all"):
            raise InputError(f"unknown database comparison {self.compare!r} (visible, all)", "--compare")
        paper = self.variant == "paper"
        out = replace(
            self,
            sigma=(0.2 if paper else 0.1) if self.sigma is None else self.sigma,
            keep_near=(1.0 if paper else 0.3) if self.keep_near is None else self.keep_near,
        )
        if not 0 < out.sigma < 1:
            raise InputError(f"GS-IoU threshold must lie in (0, 1), got {out.sigma}", "--sigma")
        if not 0 < out.keep_near <= 1:
            raise InputError(f"near fraction must lie in (0, 1], got {out.keep_near}", "--keep-near")
        if not (0 <= out.part_share <= 1 and 0 <= out.merge_share <= 1):
            raise InputError("part and merge shares must lie in [0, 1] (0 = off)", "--part-share/--merge-share")
        if out.patch < 1:
            raise InputError(f"patch size must be >= 1, got {out.patch}", "--patch")
        return out


# --- geometry ---------------------------------------------------------------------------------------


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


# --- the association -------------------------------------------------------------------------------


@dataclass
class Association:
    masks: dict[str, np.ndarray]  # view name -> (H, W) uint8 associated ids
    objects: list[dict]  # per object id: Gaussians in its set, views and pixels labelled
    config: AssociationConfig


def _segment_ids(seg: np.ndarray, min_pixels: int) -> tuple[np.ndarray, np.ndarray]:
    ids, counts = np.unique(seg, return_counts=True)
    keep = (ids != 0) & (counts >= min_pixels)
    return ids[keep], counts[keep]


def _kom(segs: Sequence[np.ndarray], cams: Sequence[Camera], means: np.ndarray, cfg: AssociationConfig) -> tuple[list[np.ndarray], np.ndarray]:
    n = len(means)
    db = np.zeros((0, n), dtype=bool)
    db_sizes = np.zeros(0)
    out = []
    together: dict[tuple[int, int], int] = {}  # object pairs: views where one segment covered both ...
    apart: dict[tuple[int, int], int] = {}  # ... and views where two segments took them
    for seg, cam in zip(segs, cams):
        u, v, z, idx = project_centres(means, cam)
        labels = seg[v, u].astype(np.int64)
        ids, _ = _segment_ids(seg, cfg.min_segment_pixels)
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


def _tracker(segs: Sequence[np.ndarray], cfg: AssociationConfig) -> list[np.ndarray]:
    """Ablation a): carry ids between consecutive views by 2D IoU, like a video tracker."""
    out, prev, next_id = [], None, 1
    for seg in segs:
        ids, counts = _segment_ids(seg, cfg.min_segment_pixels)
        lut = np.zeros(int(seg.max()) + 1, dtype=np.uint8)
        taken: set[int] = set()
        for s, area in sorted(zip(ids, counts), key=lambda sc: -sc[1]):  # larger segments choose first
            best, best_iou = 0, 0.0
            if prev is not None:
                region = seg == s
                cand, inter = np.unique(prev[region], return_counts=True)
                for c, i in zip(cand, inter):
                    if c == 0 or c in taken:
                        continue
                    iou = i / (area + (prev == c).sum() - i)
                    if iou > best_iou:
                        best, best_iou = int(c), iou
            if best and best_iou >= cfg.tracker_iou:
                lut[s] = best
                taken.add(best)
            elif next_id <= MAX_OBJECTS:
                lut[s] = next_id
                next_id += 1
        prev = lut[seg]
        out.append(prev)
    return out


def associate(
    segments: dict[str, np.ndarray], scene: Scene, model: Gaussians, cfg: AssociationConfig | None = None, *, where: str | Path | None = None
) -> Association:
    """Associate the raw segments of ``scene``'s training views (name -> (H, W) id image) into
    view-consistent object masks, processing views in capture (name) order. ``where``: the model's
    file, named when the model covers no segment."""
    cfg = (cfg or AssociationConfig()).resolved()
    views = scene.train_views
    missing = [v.name for v in views if v.name not in segments]
    if missing:
        raise InputError(f"no segments for training view {missing[0]} ({len(missing)} missing)")
    for v in views:
        if segments[v.name].shape != (v.camera.height, v.camera.width):
            h, w = segments[v.name].shape
            raise InputError(f"segments of view {v.name} are {w}x{h}, the view is {v.camera.width}x{v.camera.height}")
    segs = [segments[v.name] for v in views]
    opac = torch.sigmoid(model.opacity_logits.detach()).cpu().numpy()
    means = model.means.detach().cpu().double().numpy()[opac >= cfg.min_opacity]
    if cfg.method == "tracker":
        masks, sizes = _tracker(segs, cfg), None
    else:
        masks, sizes = _kom(segs, [v.camera for v in views], means, cfg)
    objects = []
    n_obj = int(max((m.max() for m in masks), default=0))
    for oid in range(1, n_obj + 1):
        px = [int((m == oid).sum()) for m in masks]
        objects.append({
            "id": oid,
            "views": int(sum(p > 0 for p in px)),
            "pixels": int(sum(px)),
            **({"gaussians": int(sizes[oid - 1])} if sizes is not None else {}),
        })  # fmt: skip
    if cfg.method == "kom" and sum(len(_segment_ids(s, cfg.min_segment_pixels)[0]) for s in segs) and not objects:
        raise InputError("no segment covers any Gaussian: is the model from this scene?", where)
    return Association({v.name: m for v, m in zip(views, masks)}, objects, cfg)


# --- the stage --------------------------------------------------------------------------------------


def write_association(result: Association, scene: Scene, out: str | Path, *, meta: dict, overwrite: bool = False) -> None:
    """``OUT/object_mask/<stem>.png`` per training view and ``OUT/objects.json`` (docs/architecture.md,
    "Stage outputs"), atomically."""
    by_name = {v.name: v for v in scene.views}
    with atomic_dir(out, overwrite=overwrite) as tmp:
        for name, m in result.masks.items():
            write_labels(tmp / "object_mask" / f"{by_name[name].stem}.png", m)
        info = {**meta, "config": asdict(result.config), "objects": result.objects, "views": list(result.masks)}
        (tmp / "objects.json").write_text(json.dumps(info, indent=1) + "\n")


def associate_stage(
    scene: Scene,
    model: Gaussians,
    segment_dir: str | Path,
    out: str | Path,
    cfg: AssociationConfig | None = None,
    *,
    overwrite: bool = False,
    meta: dict | None = None,
    model_path: str | Path | None = None,
) -> Association:
    """Read the segment stage's output, associate, write ``out``; returns the association.

    The segments must be of this scene and of this model (docs/architecture.md, "Provenance chain"):
    ``segment.json`` records the scene's content hash, ``--resize`` and the model's sha256."""
    from inpaint360gs.segment.stage import SEGMENT_JSON, read_segments

    t0 = time.perf_counter()
    check_output_dir(out, overwrite)  # before any work
    info_path = Path(segment_dir) / SEGMENT_JSON
    if not info_path.is_file():
        raise InputError(f"not a segment stage output (no {SEGMENT_JSON})", segment_dir)
    info = read_json_object(info_path)
    segmenter = info.get("segmenter", "unknown")
    made = provenance.read(info_path, "segment")
    provenance.check_scene(made, scene, "segment this scene first")
    model_sha = None if model_path is None else provenance.check_model(model_path, scene)
    provenance.check_link(made, "model", model_sha, model_path, "segment with this model first, or give the model the segments were made with")
    by_stem = read_segments(segment_dir, scene)
    result = associate({v.name: by_stem[v.stem] for v in scene.train_views}, scene, model, cfg, where=model_path)
    meta = {**(meta or {}), "segmenter": segmenter, "seconds": round(time.perf_counter() - t0, 2),
            provenance.KEY: provenance.make("associate", scene, {"model": model_sha, "segment": made.identity if made else None}, asdict(result.config))}
    write_association(result, scene, out, meta=meta, overwrite=overwrite)
    return result
