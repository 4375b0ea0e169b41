"""Removal of selected objects from the object-aware Gaussian field (paper Sec. 3.4 first paragraph;
supp. B "Object Removal"; docs/architecture.md, "Removal"), and the pixels it leaves to fill.

Steps, each with its :class:`~.config.RemovalConfig` switch:

1. every Gaussian whose own identity feature gives a selected object a probability above
   ``threshold`` goes, if it belongs to the object's body in space (:func:`.geometry.object_body`:
   connected components of the selected centres, small pieces only inside the body's grown box);
2. so does every Gaussian inside the convex hull of the body's centres after an outlier filter,
   except Gaussians of other objects (``protect_others``), background near the support plane
   (``protect_support``) and, optionally, confident background anywhere (``protect_background``);
3. background Gaussians hanging below what steps 1-2 take (``support_column``): thin parts near the
   floor that the 2D masks lose to it, grown down a 45-degree cone, into the floor's guard band
   only through upright Gaussians;
4. every Gaussian in the footprint column over the object's outline on its support plane
   (``footprint_margin``), other objects excepted; selected support far from the outline stays,
   and so does support on or under the plane that the views see beside the object; the object's
   low parts the field gave to the background, linked to it and in its colours, go (``low_parts``).

Pixels to fill (the AMCR masks, supp. Eq. 1): per training view, the pixels at least ``mask_share``
of whose colour the removed Gaussians gave in the original model.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import torch

from inpaint360gs.core.errors import InputError
from inpaint360gs.core.gaussians import SH_C0, Gaussians
from inpaint360gs.distill.field import IdentityField
from inpaint360gs.io.scene import View
from inpaint360gs.remove.config import RemovalConfig
from inpaint360gs.remove.geometry import footprint_columns, hanging_below, inlier_points, inside_hull, object_body, upright
from inpaint360gs.render.api import render
from inpaint360gs.render.feature_cache import FeatureRenders


@dataclass
class Removal:
    kept: Gaussians  # the edited scene
    removed: Gaussians  # what was taken out
    removed_mask: torch.Tensor  # (N,) bool over the input model
    objects: list[int]  # the selected object ids
    counts: dict = field(default_factory=dict)  # per object: by probability, by hull
    footprints: list = field(default_factory=list)  # per object: its core.support.Footprint (step 4), when found
    # (N,) bool: what steps 1-2 took and the removal keeps taking that stands higher than core.support.STANDING x the object's height over
    # its footprint's plane (all of steps 1-2 without a footprint): the object as it stands, whose
    # silhouette the removal's masks are compared with (remove/stage.py, "over_removal")
    standing_mask: torch.Tensor | None = None


def remove_objects(
    field_: IdentityField,
    object_ids: list[int],
    cfg: RemovalConfig | None = None,
    *,
    heights: np.ndarray | None = None,
    radius: float = 0.0,
    up: np.ndarray | None = None,
    grown: list[np.ndarray] | None = None,
    views: list[View] | None = None,
    backend: str = "auto",
    renders: FeatureRenders | None = None,
) -> Removal:
    """Remove the objects ``object_ids`` from the field's Gaussians (steps 1-4 of the module docstring);
    ``heights`` (N,) above the support plane and the orbit ``radius`` enable ``protect_support``,
    with the plane's normal ``up`` also ``support_column``. ``grown``: (N,) bool sets of Gaussians
    selected by a click where the field knows no object (:func:`.select.select`), removed like an
    object whose step 1 took them. ``views``: the training views, for step 4's silhouette test
    over the object's top (``RemovalConfig.column_silhouette``; None: no test); ``renders`` their
    projections kept between calls (:class:`FeatureRenders`: the same test, faster)."""
    cfg = cfg or RemovalConfig()
    grown = list(grown or [])
    known = set(field_.object_ids) - {0}
    for oid in object_ids:
        if oid not in known:
            raise InputError(f"unknown object id {oid} (the field knows {sorted(known)})", setting="ids")
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
            pts = inlier_points(means[sel], cfg.outlier_k, cfg.outlier_std)
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
        colours = (SH_C0 * field_.gaussians.sh0[:, 0].detach().cpu().double().numpy() + 0.5).clip(0.0, 1.0)
        share = silhouette_share(field_.gaussians, views, backend, renders=renders) if views else None
        remove, footprints = footprint_columns(means, opac, remove, bodies, kept_by_choice, up, cfg, counts, colours, share)
    body = np.any(bodies, axis=0) if bodies else remove.copy()
    if footprints:
        from inpaint360gs.core.support import STANDING

        standing = np.zeros_like(body)
        for fp in footprints:
            standing |= body & remove & (fp.heights(means) > STANDING * fp.height)  # what stays (support beside the object) is not the object
    else:
        standing = body
    mask = torch.from_numpy(remove)
    return Removal(field_.gaussians.subset(~mask), field_.gaussians.subset(mask), mask, list(object_ids), counts, footprints,
                   torch.from_numpy(standing))


def silhouette_share(model: Gaussians, views: list[View], backend: str = "auto", grow_px: int = 2, renders: FeatureRenders | None = None):
    """``share(indices, body) -> (M,)``: for the Gaussians ``indices`` of ``model``, the share of the
    ``views`` whose frame holds a Gaussian's centre (in front of the camera) in which that centre
    lies in the silhouette of the Gaussians ``body`` ((N,) bool; drawn as the fill masks are, grown
    by ``grow_px``); 0 where no view holds it."""
    import cv2

    means = model.means.detach().double().numpy()
    kernel = np.ones((2 * grow_px + 1, 2 * grow_px + 1), np.uint8)

    def share(indices: np.ndarray, body: np.ndarray) -> np.ndarray:
        inside = np.zeros(len(indices))
        seen = np.zeros(len(indices))
        X = means[indices]
        where = {}
        for v in views:
            cam = v.camera
            xc = X @ cam.R.double().numpy().T + cam.t.double().numpy()
            z = xc[:, 2]
            front = z > 1e-6
            u = np.floor(cam.fx * xc[:, 0] / np.where(front, z, 1.0) + cam.cx).astype(np.int64)
            w = np.floor(cam.fy * xc[:, 1] / np.where(front, z, 1.0) + cam.cy).astype(np.int64)
            ok = front & (u >= 0) & (u < cam.width) & (w >= 0) & (w < cam.height)
            where[v.name] = (u, w, ok)
        # the silhouettes are read only within grow_px of the centres' pixels
        near = {n: (u[ok], w[ok]) for n, (u, w, ok) in where.items()}
        masks = fill_masks(model, torch.from_numpy(np.asarray(body, dtype=bool)), views, 0.5, backend, renders, near=near, margin=grow_px)
        for v in views:
            u, w, ok = where[v.name]
            sil = cv2.dilate(masks[v.name].astype(np.uint8), kernel).astype(bool)
            seen += ok
            inside[ok] += sil[w[ok], u[ok]]
        return np.where(seen > 0, inside / np.maximum(seen, 1), 0.0)

    return share


@torch.no_grad()
def fill_masks(model: Gaussians, removed_mask: torch.Tensor, views: list[View], share: float = 0.5, backend: str = "auto",
               renders: FeatureRenders | None = None, near: dict | None = None, margin: int = 0) -> dict[str, np.ndarray]:  # fmt: skip
    """Per view, the pixels at least ``share`` of whose colour the removed Gaussians gave in ``model``
    (see the module docstring): the removed objects' rendered footprint. ``renders``: the views'
    projections of ``model`` kept between calls (the viewer's clicks; the same masks, faster);
    with it, ``near`` (view name -> (x, y) pixel arrays) says that only the mask within ``margin``
    pixels of those is wanted (elsewhere it may be left False)."""
    feats = removed_mask.to(model.means.dtype)[:, None]
    if renders is not None and renders.gaussians is model:
        near = near or {}
        return {v.name: (renders.features(v.name, v.camera, feats, near=near.get(v.name), margin=margin)[..., 0] >= share).numpy() for v in views}
    g = model.map(lambda t: t)
    g.features = feats
    out = {}
    for v in views:
        o = render(g, v.camera, with_features=True, backend=backend)
        out[v.name] = (o.features[..., 0] >= share).numpy()
    return out
