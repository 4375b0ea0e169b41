"""Object selection by click or id, and removal from the object-aware Gaussian field (paper Sec. 3.4
first paragraph; supp. B "Object Removal", supp. Eq. 1 AMCR).

Selection: a click (a view and a pixel) is resolved through the id map the distilled field renders
for that view (argmax of the classifier on the rendered identity features; background where the
rendered alpha is below 0.5); an id may also be given directly. A click on the background, outside
the image or on an unknown view is refused.

Removal of a selected object (the authors' public code; Gaussian Grouping uses the same two steps):

1. every Gaussian whose own identity feature gives the object a probability above ``threshold``
   (0.7) goes — as long as it belongs to the object's body in space: Gaussians no training view
   ever rendered keep their random initial features, and some of them, anywhere in the scene, pass
   the threshold by chance. The selected centres are therefore grouped into connected components
   (centres closer than ``link`` times their median nearest-neighbour spacing are linked), and only
   components holding at least ``min_part`` of the largest one's Gaussians count as the object,
   plus smaller pieces inside that body's bounding box grown by ``body_margin`` (0.5) of its size
   (parts 3DGS reconstructed sparsely and split off the graph: the far side of a ball; the benchmark
   watering can's lower part, whose pieces lie between 25% and 50% of its height under the body's
   box, so that a 25% margin left 12% of its footprint standing);
2. so does every Gaussian inside the convex hull (Delaunay) of the object's centres, after a
   statistical outlier filter (centres whose mean distance to their k nearest selected neighbours
   is more than ``outlier_std`` standard deviations above the mean) so that a few stray
   Gaussians do not inflate the hull. Gaussians the field confidently assigns to ANOTHER object
   (probability above 0.5) are kept (``protect_others``): the hull of a fruit must not take a
   bite out of the plate it lies on. Nor does it take the floor: Gaussians within ``protect_support``
   (0.008 R) of the support plane that the field calls background stay (``protect_support``; the
   hull of an object standing on the floor reaches down to it, and the floor Gaussians under a
   wide object such as the benchmark's car otherwise go with it). Optionally (``protect_background``,
   off by default) the hull also keeps every Gaussian the field gives a background probability
   above that value, at any height;
3. background-labelled Gaussians hanging below what steps 1–2 take go with it
   (``support_column``, 0.01 R by default, None = off as in the authors' code; needs the support plane): grown step by step downwards, each within
   ``d ≤ 0.01 R`` horizontally of a removed Gaussian and lower than it by between ``d`` and
   ``0.02 R`` (a 45-degree cone, so the growth never spreads sideways along a level surface), down
   to the guard band above the floor, and inside the band only through upright Gaussians (variance
   along the plane's normal larger than across it: a floor splat is flat, a leg end standing on the
   floor is not). These are thin parts near the floor — the benchmark stool's leg ends — that the
   2D masks lose to the floor, so distillation calls them background, and that lie below the hull
   built from the object's own Gaussians.

The removed Gaussians are kept in ``removed.ply`` (with their features) so that they can be put back
(occluders are removed and reinserted around the inpainting stage).

Pixels left to fill (the AMCR masks, per training view): a pixel is to be filled when at least
``mask_share`` (half) of its colour came from removed Gaussians in the original model, i.e.
``Σ_{i removed} α_i T_i ≥ 0.5`` with the weights of the full model — the removed objects' rendered
footprint. AMCR (supp. Eq. 1) is the mean over training views of the percentage of such pixels.
"""

from __future__ import annotations

import json
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import torch

from inpaint360gs.core.errors import InputError
from inpaint360gs.core.files import read_json_object
from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.distill.field import IdentityField
from inpaint360gs.io import provenance
from inpaint360gs.io.atomic import atomic_dir, check_output_dir
from inpaint360gs.io.images import write_mask
from inpaint360gs.io.ply import write_ply
from inpaint360gs.io.scene import Scene, View
from inpaint360gs.metrics import amcr
from inpaint360gs.remove.select import Click, select, support_heights
from inpaint360gs.render.api import render


FOOTPRINT_TOP = 2.0  # the footprint column reaches this x the object's height: faint Gaussians floating just over an
# object are part of its appearance (3DGS explains view-dependent colour with them), not the scene's


@dataclass
class RemovalConfig:
    """Settings of the removal (supp. B "Object Removal"; defaults from the authors' public code)."""

    threshold: float = 0.7  # a Gaussian goes when its probability of a selected object exceeds this
    hull: bool = True  # also remove what lies inside the convex hull of the selected Gaussians
    outlier_k: int = 10  # statistical outlier filter before the hull: neighbours considered ...
    outlier_std: float = 2.0  # ... and the cut in standard deviations above the mean distance
    link: float = 4.0  # selected centres closer than this x their median nearest-neighbour spacing are one body
    min_part: float = 0.1  # components with fewer than this share of the largest one's Gaussians are not the object
    body_margin: float = 0.5  # ... unless they lie inside the body's bounding box grown by this share of its size
    protect_others: bool = True  # keep Gaussians with probability > 0.5 of another (non-background) object
    # The hull step keeps Gaussians whose background probability exceeds this (None = off, the authors'
    # code). The hull of an object standing on the floor reaches down to the floor and takes the floor
    # Gaussians under it: holes to inpaint and collateral (docs/architecture.md, "Removal").
    protect_background: float | None = None
    # The hull step keeps Gaussians within this height of the support plane (x the orbit radius R;
    # the geometric segmenter's tau) that the field calls background (probability > 0.5): the floor
    # an object stands on. None = off (the authors' code). The plane is the segmenter's (RANSAC on
    # opaque centres, segment/frame.py); without one (no orbit, no plane) the guard is skipped and
    # removal.json says why.
    protect_support: float | None = 0.008
    # Background-labelled Gaussians hanging below what is removed — within this horizontal distance
    # (x R) of a removed Gaussian, lower by at least that distance (a 45-degree cone down) and by at
    # most twice it, grown step by step down to the support guard band — go with the object: thin
    # parts near the floor (a stool's leg ends) that the 2D masks lose to the floor, so distillation
    # calls them background and the hull, built from the object's Gaussians, ends above them. Inside
    # the guard band it continues only through upright Gaussians (see ``upright``): the floor stays.
    # Needs the support plane. None = off (the authors' code; `inpaint360gs remove --no-support-column`).
    # On by default: without it the stool's leg ends stay as needles in the filled region (README,
    # "Measured numbers"), and on the other scenes it takes a handful of Gaussians at most.
    support_column: float | None = 0.01
    # The footprint column (step 4): every Gaussian over the object's outline on the support plane
    # fitted around it, grown by this x the footprint's size (sqrt of its area), from
    # ``footprint_depth`` x the object's height below the plane up to its top, goes with the object,
    # whatever the field calls it (other objects stay). Parts near the support that the masks and
    # the field lose (tracks, an underside, the dark contact region) and the support under the
    # object, which no photo saw and which holds the object's print, are left to the fill. The
    # margin stands for the paper's dilated inpainting mask (supp. B: 10 px on ~1000-px images,
    # about 5% of an object a fifth of the image wide): a contact shadow on the support is filled
    # too. None = off (the authors' code).
    footprint_margin: float | None = 0.05
    footprint_depth: float = 0.1
    # Selected Gaussians lying on the support (within ``support_band`` x the object's height of the
    # plane) farther than ``support_reach`` x the footprint's size from its outline are the support,
    # taken for the object where it touches it (a segmenter's cluster holding a blob of the mat): they
    # stay. Nearer, low parts are the object's own (a bucket's teeth, the tracks' lower edge).
    support_band: float = 0.05
    support_reach: float = 0.25
    mask_share: float = 0.5  # a pixel is to be filled when removed Gaussians gave it at least this share of its colour


@dataclass
class Removal:
    kept: Gaussians  # the edited scene
    removed: Gaussians  # what was taken out
    removed_mask: torch.Tensor  # (N,) bool over the input model
    objects: list[int]  # the selected object ids
    counts: dict = field(default_factory=dict)  # per object: by probability, by hull
    footprints: list = field(default_factory=list)  # per object: its core.support.Footprint (step 4), when found


def load_field(folder: str | Path, scene: Scene) -> IdentityField:
    """The distillation output ``folder`` (:meth:`IdentityField.load`), checked against its
    ``distill.json`` when there is one: the Gaussian count it records, and the scene it was
    distilled from, which must be ``scene`` (content hash and ``--resize``)."""
    from inpaint360gs.distill.field import MODEL_PLY
    from inpaint360gs.distill.run import DISTILL_JSON

    folder = Path(folder)
    field_ = IdentityField.load(folder)
    path = folder / DISTILL_JSON
    if not path.is_file():
        return field_
    report = read_json_object(path)
    n = report.get("num_gaussians")
    if n is not None and n != len(field_.gaussians):
        raise InputError(f"holds {len(field_.gaussians)} Gaussians but {DISTILL_JSON} records {n}: files of two runs?", folder / MODEL_PLY)
    provenance.check_scene(field_.record, scene, "distill this scene first")  # docs/architecture.md, "Provenance chain"
    return field_


def _inlier_points(points: np.ndarray, k: int, n_std: float) -> np.ndarray:
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
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    if len(points) < 3:
        return np.ones(len(points), dtype=bool)
    tree = cKDTree(points)
    d, _ = tree.query(points, k=2)
    radius = link * float(np.median(d[:, 1]))
    graph = tree.sparse_distance_matrix(tree, radius, output_type="coo_matrix")
    _, labels = connected_components(graph, directed=False)
    sizes = np.bincount(labels)
    body = sizes[labels] >= min_part * sizes.max()
    lo, hi = points[body].min(axis=0), points[body].max(axis=0)
    pad = near * (hi - lo)
    return body | ((points >= lo - pad) & (points <= hi + pad)).all(axis=1)


def inside_hull(points: np.ndarray, queries: np.ndarray) -> np.ndarray:
    """Boolean mask of ``queries`` inside the convex hull of ``points`` (Delaunay; degenerate sets:
    nothing is inside)."""
    from scipy.spatial import Delaunay, QhullError

    if len(points) < 5:
        return np.zeros(len(queries), dtype=bool)
    try:
        tri = Delaunay(points)
    except QhullError:  # flat or collinear: no volume
        return np.zeros(len(queries), dtype=bool)
    return tri.find_simplex(queries) >= 0


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
        reached = set()
        for f, hits in zip(frontier, tree.query_ball_point(flat[frontier], r)):
            if not hits:
                continue
            c = cand[hits]
            c = c[~out[c]]
            d = np.linalg.norm(flat[c] - flat[f], axis=1)
            drop = heights[f] - heights[c]
            reached.update(c[(drop >= d) & (drop > 0) & (drop <= 2 * r)].tolist())
        frontier = np.array(sorted(reached), dtype=np.int64)
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


def remove_objects(
    field_: IdentityField,
    object_ids: list[int],
    cfg: RemovalConfig | None = None,
    *,
    heights: np.ndarray | None = None,
    radius: float = 0.0,
    up: np.ndarray | None = None,
    grown: list[np.ndarray] | None = None,
) -> Removal:
    """Remove the objects ``object_ids`` from the field's Gaussians (see the module docstring);
    ``heights`` (N,) above the support plane and the orbit ``radius`` enable ``protect_support``,
    with the plane's normal ``up`` also ``support_column``. ``grown``: (N,) bool sets of Gaussians
    selected by a click where the field knows no object (:func:`.select.select`), removed like an
    object whose step 1 took them."""
    cfg = cfg or RemovalConfig()
    grown = list(grown or [])
    known = set(field_.object_ids) - {0}
    for oid in object_ids:
        if oid not in known:
            raise InputError(f"unknown object id {oid} (the field knows {sorted(known)})", "--id")
    if not object_ids and not grown:
        raise InputError("nothing selected: give at least one --click or --id")
    probs = field_.gaussian_probs()  # (N, Q)
    col = {oid: field_.object_ids.index(oid) for oid in object_ids}
    means = field_.gaussians.means.detach().cpu().double().numpy()
    others = [i for i, oid in enumerate(field_.object_ids) if oid != 0 and oid not in col]
    # what the hull step must keep: Gaussians of other objects and, when asked, confident background
    protected = (probs[:, others] > 0.5).any(dim=1).numpy() if (cfg.protect_others and others) else np.zeros(len(means), bool)
    if cfg.protect_background is not None and 0 in field_.object_ids:
        protected |= (probs[:, field_.object_ids.index(0)] > cfg.protect_background).numpy()
    kept_by_choice = protected.copy()  # what the support column must keep too (the floor guard aside)
    if cfg.protect_support is not None and heights is not None and 0 in field_.object_ids:
        floor = np.abs(heights) < cfg.protect_support * radius
        protected |= floor & (probs[:, field_.object_ids.index(0)] > 0.5).numpy()
    remove = np.zeros(len(means), dtype=bool)
    counts = {}
    bodies = []  # per object: what steps 1-2 take for it
    firsts = {str(oid): (probs[:, c] > cfg.threshold).numpy() for oid, c in col.items()}
    firsts.update({f"grown {i}": g.copy() for i, g in enumerate(grown)})
    for key, sel in firsts.items():
        idx = np.flatnonzero(sel)
        sel[idx[~object_body(means[idx], cfg.link, cfg.min_part, cfg.body_margin)]] = False
        hull = np.zeros_like(sel)
        if cfg.hull and sel.sum() >= 5:
            pts = _inlier_points(means[sel], cfg.outlier_k, cfg.outlier_std)
            hull = inside_hull(pts, means) & ~sel & ~protected
        remove |= sel | hull
        bodies.append(sel | hull)
        counts[key] = {"by_probability": int(sel.sum()), "by_hull": int(hull.sum())}
    if cfg.support_column is not None and heights is not None and up is not None and radius > 0 and 0 in field_.object_ids and remove.any():
        background = (probs[:, field_.object_ids.index(0)] > 0.5).numpy()
        band = cfg.protect_support * radius if cfg.protect_support is not None else 0.0
        up = np.asarray(up, dtype=np.float64)
        # in the guard band, only upright Gaussians (leg ends standing on the floor), never floor splats
        reachable = (heights > band) | (upright(field_.gaussians, up) & (heights > -band))
        below = hanging_below(means, heights, up, remove, background & ~kept_by_choice & reachable, cfg.support_column * radius)
        remove |= below
        counts["below"] = int(below.sum())
    if not remove.any():
        raise InputError(f"no Gaussian has probability > {cfg.threshold} for object(s) {object_ids}: nothing to remove")
    footprints = []
    if cfg.footprint_margin is not None:
        opac = field_.gaussians.opacities.detach().cpu().double().numpy()
        remove, footprints = footprint_columns(means, opac, remove, bodies, kept_by_choice, up, cfg, counts)
    mask = torch.from_numpy(remove)
    return Removal(field_.gaussians.subset(~mask), field_.gaussians.subset(mask), mask, list(object_ids), counts, footprints)


def footprint_columns(means: np.ndarray, opacities: np.ndarray, remove: np.ndarray, bodies: list[np.ndarray], keep: np.ndarray,
                      up: np.ndarray | None, cfg: RemovalConfig, counts: dict) -> tuple[np.ndarray, list]:  # fmt: skip
    """Step 4 (``RemovalConfig.footprint_margin``): ``remove`` plus every Gaussian in each object's
    footprint column (not those in ``keep``: other objects), minus the support Gaussians the
    selection took outside it. ``bodies``: per object, what steps 1-2 took; ``up`` a hint of the
    support's normal (None: the cameras' up is not known and the column is skipped). Returns the
    new flags and the footprints found; ``counts`` records what the step did (or why it did not)."""
    from inpaint360gs.core.support import object_footprint

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
        support = remove & body & (d > cfg.support_reach * fp.size) & (np.abs(h) <= cfg.support_band * fp.height)
        counts.setdefault("footprint", []).append({"column": int((column & ~remove).sum()), "support_kept": int(support.sum()), "height": fp.height, "size": fp.size})
        remove = (remove | column) & ~support
        found.append(fp)
    return remove, found


@torch.no_grad()
def fill_masks(model: Gaussians, removed_mask: torch.Tensor, views: list[View], share: float = 0.5, backend: str = "auto") -> dict[str, np.ndarray]:
    """Per view, the pixels at least ``share`` of whose colour the removed Gaussians gave in ``model``
    (see the module docstring): the removed objects' rendered footprint."""
    g = model.map(lambda t: t)
    g.features = removed_mask.to(model.means.dtype)[:, None]
    out = {}
    for v in views:
        o = render(g, v.camera, with_features=True, backend=backend)
        out[v.name] = (o.features[..., 0] >= share).numpy()
    return out


def removal_stage(
    field_: IdentityField,
    scene: Scene,
    out: str | Path,
    *,
    clicks: list[Click] | None = None,
    ids: list[int] | None = None,
    cfg: RemovalConfig | None = None,
    backend: str = "auto",
    overwrite: bool = False,
    meta: dict | None = None,
) -> dict:
    """Select (clicks and/or ids), remove, write ``out`` (docs/architecture.md, "Stage outputs");
    returns what ``removal.json`` holds."""
    cfg = cfg or RemovalConfig()
    check_output_dir(out, overwrite)  # before any work
    t0 = time.perf_counter()
    clicks = list(clicks or [])
    picked = select(field_, scene, clicks, backend=backend)
    targets = [p.object_id for p in picked if p.object_id is not None] + list(ids or [])
    targets = list(dict.fromkeys(targets))  # keep order, drop repeats
    grown = [p.gaussians for p in picked if p.gaussians is not None]
    needs_plane = cfg.protect_support is not None or cfg.support_column is not None or cfg.footprint_margin is not None
    heights, radius, support_note, up = support_heights(field_, scene) if needs_plane else (None, 0.0, "support guard off", None)
    res = remove_objects(field_, targets, cfg, heights=heights, radius=radius, up=up, grown=grown)
    views = scene.train_views
    masks = fill_masks(field_.gaussians, res.removed_mask, views, cfg.mask_share, backend)
    stack = np.stack([masks[v.name] for v in views])
    info = {
        **(meta or {}),
        "clicks": [str(c) for c in clicks],
        "objects": targets,
        "selected_by": {str(p.click): p.how for p in picked},
        "removed_gaussians": int(res.removed_mask.sum()),
        "kept_gaussians": len(res.kept),
        "counts": res.counts,
        "amcr_percent": amcr(stack),
        "mask_rule": f"a pixel is to be filled when removed Gaussians gave at least {cfg.mask_share:g} of its colour in the original model",
        "config": asdict(cfg),
        "support": support_note,
        "footprints": [fp.to_json() for fp in res.footprints],
        "seconds": round(time.perf_counter() - t0, 2),
        provenance.KEY: provenance.make("remove", scene, {"distill": field_.record.identity if field_.record else None},
                                        {"clicks": [str(c) for c in clicks], "objects": targets, "config": asdict(cfg), "backend": backend}),
    }
    with atomic_dir(out, overwrite=overwrite) as tmp:
        write_ply(tmp / "point_cloud.ply", res.kept)
        write_ply(tmp / "removed.ply", res.removed)
        np.save(tmp / "removed_index.npy", np.flatnonzero(res.removed_mask.numpy()))
        for v in views:
            write_mask(tmp / "masks" / f"{v.stem}.png", masks[v.name])
        provenance.add_outputs(info, tmp, "point_cloud.ply")
        (tmp / "removal.json").write_text(json.dumps(info, indent=1) + "\n")
    return info
