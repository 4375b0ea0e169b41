"""Is a selection an object? The check a removal makes of what a click selected before anything is
removed (docs/architecture.md, "A run checks itself").

A click names "the thing this pixel shows". What the selection (:mod:`.select`, then the removal's
body, hull and footprint steps in :mod:`.objects`) takes must therefore, drawn in the clicked photo
(the pixels it gives at least half of their colour, as the fill masks are drawn), be:

- **at the click**: the region covers the clicked pixel, or lies within a small radius of it;
- **not a handful of Gaussians**: at least :attr:`SelectionLimits.min_gaussians`, and a region of at
  least :attr:`SelectionLimits.min_share` of the photo;
- **not the support**: most of its opacity does not lie within the support band of the plane the
  objects stand on (the geometric segmenter's plane and tau);
- **not the backdrop**: it does not fill most of the clicked photo, nor cover a large part of it
  while running off the frame on three sides or more in most training views that see it, as a
  floor, a sheet or a wall does (an object large in frame runs off one or two).

Each click's view is checked; the verdict is the first failed test, else ``object``.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import cv2
import numpy as np
import torch

from inpaint360gs.distill.field import IdentityField
from inpaint360gs.io.scene import Scene
from inpaint360gs.remove.objects import fill_masks
from inpaint360gs.remove.select import Click

OBJECT, OFF_CLICK, TOO_SMALL, SUPPORT, BACKDROP = "object", "off the click", "too small", "support", "backdrop"


@dataclass(frozen=True)
class SelectionLimits:
    """What a selection must reach to count as an object (the module docstring's tests)."""

    min_gaussians: int = 20  # fewer Gaussians than this are a speck, not an object
    min_share: float = 0.001  # the region must cover at least this share of the clicked photo ...
    min_pixels: int = 12  # ... and at least this many pixels
    click_radius: float = 0.02  # the region must reach within this x the photo's diagonal of the click
    max_support: float = 0.5  # at most this share of its opacity may lie in the support band
    max_share: float = 0.85  # a region covering more of the clicked photo than this ...
    border_sides: int = 3  # ... or running off this many sides of the frame ...
    border_views: float = 0.5  # ... in more than this share of the training views showing it ...
    min_backdrop_share: float = 0.2  # ... while covering more than this of the clicked photo, is backdrop
    mask_share: float = 0.5  # a pixel is the selection's when it gives at least this share of its colour


@dataclass
class SelectionCheck:
    """The verdict on one selection (``passed`` when ``verdict == "object"``) and what it rests on."""

    passed: bool
    verdict: str  # object | off the click | too small | support | backdrop
    reason: str  # one line saying why, with the numbers
    gaussians: int  # Gaussians selected
    view_share: dict[str, float] = field(default_factory=dict)  # per clicked view: share of the photo the selection covers
    click_distance: dict[str, float] = field(default_factory=dict)  # per clicked view: pixels from the click to the region
    support_share: float | None = None  # opacity share in the support band (None: no plane found)
    border_views: float = 0.0  # share of training views showing it where it runs off >= border_sides sides

    def to_json(self) -> dict:
        return asdict(self)


def _touching_sides(mask: np.ndarray) -> int:
    return int(mask[0].any()) + int(mask[-1].any()) + int(mask[:, 0].any()) + int(mask[:, -1].any())


def _distance_to(mask: np.ndarray, x: int, y: int) -> float:
    if mask[y, x]:
        return 0.0
    if not mask.any():
        return float("inf")
    dist = cv2.distanceTransform((~mask).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    return float(dist[y, x])


def selection_masks(field_: IdentityField, selected: np.ndarray | torch.Tensor, scene: Scene, *, views=None, share: float = 0.5,
                    backend: str = "auto") -> dict[str, np.ndarray]:  # fmt: skip
    """Per training view (or ``views``), the pixels at least ``share`` of whose colour the
    ``selected`` Gaussians give: the selection as drawn in the photos."""
    sel = torch.as_tensor(np.asarray(selected, dtype=bool))
    return fill_masks(field_.gaussians, sel, list(views if views is not None else scene.train_views), share, backend)


def assess_selection(
    field_: IdentityField,
    scene: Scene,
    selected: np.ndarray | torch.Tensor,
    clicks: list[Click],
    *,
    heights: np.ndarray | None = None,
    radius: float = 0.0,
    limits: SelectionLimits | None = None,
    masks: dict[str, np.ndarray] | None = None,
    backend: str = "auto",
) -> SelectionCheck:
    """Check that ``selected`` ((N,) bool over ``field_.gaussians``) is an object under ``clicks``
    (the module docstring). ``heights`` above the support plane and the orbit ``radius``
    (:func:`.select.support_heights`) enable the support test; ``masks``: the selection drawn in
    every training view when already rendered (:func:`selection_masks`)."""
    lim = limits or SelectionLimits()
    sel = np.asarray(selected, dtype=bool)
    n = int(sel.sum())
    if masks is None:
        masks = selection_masks(field_, sel, scene, share=lim.mask_share, backend=backend)
    shares, dists = {}, {}
    verdict, reason = OBJECT, ""
    for c in clicks:
        view = scene.view(c.view)
        m = masks[view.name]
        x, y = c.pixel(view)
        shares[view.name] = float(m.mean())
        dists[view.name] = _distance_to(m, x, y)
    visible = [m for m in masks.values() if m.sum() >= lim.min_pixels]
    border = float(np.mean([_touching_sides(m) >= lim.border_sides for m in visible])) if visible else 0.0
    support = None
    if heights is not None and radius > 0 and n:
        from inpaint360gs.segment.cluster3d import ClusterConfig

        opac = field_.gaussians.opacities.detach().cpu().double().numpy().reshape(-1)[sel]
        band = np.abs(np.asarray(heights)[sel]) <= ClusterConfig().tau * radius
        support = float((opac * band).sum() / max(opac.sum(), 1e-12))
    # ids only: no click to place the selection by; the size, support and backdrop tests use its largest view
    named = [(scene.view(c.view), c) for c in clicks] or [(max(scene.train_views, key=lambda v: masks[v.name].sum()), None)]
    for view, c in named:
        m = masks[view.name]
        shares.setdefault(view.name, float(m.mean()))
        h, w = m.shape
        if n < lim.min_gaussians or m.sum() < max(lim.min_pixels, lim.min_share * m.size):
            verdict = TOO_SMALL
            reason = (f"the selection is {n} Gaussians covering {100 * shares[view.name]:.2f} % of {view.name} "
                      f"(an object needs >= {lim.min_gaussians} and >= {100 * lim.min_share:g} %)")  # fmt: skip
        elif c is not None and dists[view.name] > lim.click_radius * float(np.hypot(w, h)):
            verdict = OFF_CLICK
            reason = f"what was selected is drawn {dists[view.name]:.0f} px away from the click {c} in {view.name}"
        elif support is not None and support > lim.max_support:
            verdict = SUPPORT
            reason = f"{100 * support:.0f} % of the selection's opacity lies on the support surface the objects stand on"
        elif shares[view.name] > lim.max_share or (border > lim.border_views and shares[view.name] > lim.min_backdrop_share):
            verdict = BACKDROP
            reason = (f"the selection covers {100 * shares[view.name]:.0f} % of {view.name} and runs off {lim.border_sides}+ sides "
                      f"of the frame in {100 * border:.0f} % of the views showing it: a backdrop or floor, not an object")  # fmt: skip
        if verdict != OBJECT:
            break
    if verdict == OBJECT:
        reason = f"an object: {n} Gaussians, " + ", ".join(f"{100 * s:.1f} % of {k}" for k, s in shares.items())
    return SelectionCheck(verdict == OBJECT, verdict, reason, n, shares, dists, support, border)
