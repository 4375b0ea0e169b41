"""Ground-truth scores of an object removal, per view and over a run (docs/architecture.md,
"Ground-truth removal scores"): arrays in, pixel counts and percentages out.

Every array of a view has the same (H, W) size; depths are camera z (the truth's in its units, the
model's in the model's: only ratios of depths of one kind are taken); colours are (H, W, 3) floats in [0, 1].

- **residual** — the object still there: a pixel of the target's true footprint (``footprint``,
  the generator's instance ids) where the edited model still shows a surface (alpha at least one
  half) within :data:`DEPTH_TOLERANCE` of the depth the model showed there before the removal (the
  object's surface as the model has it), where the true depth with the object lies more than the
  tolerance in front of the true object-free surface (``depth_free``: there the object's surface
  and what the removal should reveal differ; in the band where the object touches its support they
  do not, and a pixel there is not judged). The model's depths are compared with each other, not
  with the truth: a model's expected depth (Eq. 5 over alpha) is pulled towards the camera by
  faint floaters and a structure-from-motion frame's intrinsics differ from the true ones, both by
  more than the tolerance in some views; the truth's depths only say where to judge, as a ratio.
  Percentage of the footprint's pixels.
- **collateral** — the rest of the scene taken with it: a pixel outside the footprint grown by
  :func:`grown_footprint` whose colour changes by more than :data:`COLOUR_CHANGE` (largest channel)
  between the model before and after the removal. Percentage of the pixels outside the grown
  footprint.
- **ground-truth footprint share** — the percentage of the view's pixels in the footprint: what
  AMCR (paper supp. Eq. 1, :func:`.masked.amcr` of the removal's masks in the same views) would be
  for a removal of exactly the object.

:data:`LIMITS` are what a run must stay within; :func:`limits_exceeded` names the limits a run's
scores break, so that a table lists the run instead of averaging it away.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass

import cv2
import numpy as np

DEPTH_TOLERANCE = 0.03  # relative: a surface within 3 % of the depth the object showed is the object's
COLOUR_CHANGE = 0.1  # a pixel whose colour moves by more than this (largest channel, [0, 1]) was changed
GROW_MIN_PX = 3  # the footprint is grown by at least this many pixels (its anti-aliased edge) ...
GROW_SHARE = 0.1  # ... and by this share of its size (square root of its area): the removal's footprint column takes
#                   the support within 5 % of the footprint's size around the outline by design (docs/architecture.md,
#                   "The footprint column"), and that margin is the object's, not collateral
# the limits of a run (percent; the AMCR limit as a multiple of the ground-truth footprint share)
RESIDUAL_LIMIT = 1.0
COLLATERAL_LIMIT = 1.0
AMCR_RATIO_LIMIT = 1.5
LIMITS = {"residual": RESIDUAL_LIMIT, "collateral": COLLATERAL_LIMIT, "amcr_ratio": AMCR_RATIO_LIMIT}
LIMIT_TEXT = {
    "residual": f"residual ≤ {RESIDUAL_LIMIT:g} %",
    "collateral": f"collateral ≤ {COLLATERAL_LIMIT:g} %",
    "amcr_ratio": f"AMCR ≤ {AMCR_RATIO_LIMIT:g} × the ground-truth footprint share",
}


@dataclass
class Counts:
    """Pixel counts of one or more views (they add up over views)."""

    footprint: int = 0  # pixels of the target's true footprint
    residual: int = 0  # footprint pixels where the object still shows
    outside: int = 0  # pixels outside the grown footprint
    collateral: int = 0  # of those, pixels whose colour changed
    pixels: int = 0  # every pixel of the views
    views: int = 0
    footprint_share_sum: float = 0.0  # sum over views of 100 * footprint / pixels

    def __add__(self, other: Counts) -> Counts:
        return Counts(*(getattr(self, k) + getattr(other, k) for k in self.__dataclass_fields__))

    def scores(self) -> dict[str, float | None]:
        """``residual``, ``collateral`` (percent of their denominators; None where that is empty) and
        ``gt_footprint_share`` (mean over views of the footprint's percentage of the view)."""
        return {
            "residual": 100.0 * self.residual / self.footprint if self.footprint else None,
            "collateral": 100.0 * self.collateral / self.outside if self.outside else None,
            "gt_footprint_share": float(self.footprint_share_sum / self.views) if self.views else None,
        }


def grown_footprint(footprint: np.ndarray) -> np.ndarray:
    """``footprint`` (H, W bool) grown by a disc of radius max(:data:`GROW_MIN_PX`, :data:`GROW_SHARE`
    × sqrt(its pixel count)) pixels."""
    fp = np.asarray(footprint, dtype=bool)
    r = max(GROW_MIN_PX, int(math.ceil(GROW_SHARE * math.sqrt(int(fp.sum())))))
    disc = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))
    return cv2.dilate(fp.astype(np.uint8), disc).astype(bool)


def view_counts(footprint: np.ndarray, depth_with: np.ndarray, depth_free: np.ndarray, original_depth: np.ndarray, edited_depth: np.ndarray,
                edited_alpha: np.ndarray, before: np.ndarray, after: np.ndarray) -> Counts:
    """The :class:`Counts` of one view (module docstring).

    ``footprint``: the target's true pixels; ``depth_with`` / ``depth_free``: the true depth with
    and without the targets; ``original_depth`` / ``edited_depth``: the model's surface depth
    (alpha-normalised) before and after the removal, in the model's units; ``edited_alpha``: the
    edited model's alpha; ``before`` / ``after``: the model's colour before and after the removal."""
    fp = np.asarray(footprint, dtype=bool)
    shape = fp.shape
    for name, a in (("depth_with", depth_with), ("depth_free", depth_free), ("original_depth", original_depth), ("edited_depth", edited_depth),
                    ("edited_alpha", edited_alpha), ("before", np.asarray(before)[..., 0]), ("after", np.asarray(after)[..., 0])):
        if np.shape(a) != shape:
            raise ValueError(f"{name} is {np.shape(a)}, the footprint {shape}")
    d_with = np.asarray(depth_with, dtype=np.float64)
    d_free = np.asarray(depth_free, dtype=np.float64)
    d = np.asarray(edited_depth, dtype=np.float64)
    d_orig = np.asarray(original_depth, dtype=np.float64)
    surface = np.asarray(edited_alpha) >= 0.5
    at_object = np.abs(d - d_orig) < DEPTH_TOLERANCE * d_orig
    judged = d_with < (1.0 - DEPTH_TOLERANCE) * d_free  # the object stands clearly in front of what it hides
    residual = fp & surface & at_object & judged
    outside = ~grown_footprint(fp)
    changed = np.abs(np.asarray(after, dtype=np.float64) - np.asarray(before, dtype=np.float64)).max(axis=-1) > COLOUR_CHANGE
    return Counts(footprint=int(fp.sum()), residual=int(residual.sum()), outside=int(outside.sum()),
                  collateral=int((changed & outside).sum()), pixels=fp.size, views=1, footprint_share_sum=100.0 * float(fp.sum()) / fp.size)


def amcr_ratio(amcr: float | None, gt_footprint_share: float | None) -> float | None:
    """AMCR over the ground-truth footprint share of the same views (None when either is missing or the share is 0)."""
    if amcr is None or gt_footprint_share is None or gt_footprint_share <= 0:
        return None
    return amcr / gt_footprint_share


def limits_exceeded(scores: Mapping[str, float | None]) -> list[tuple[str, float, float]]:
    """(limit name, value, limit) for each of :data:`LIMITS` that ``scores`` break; ``amcr_ratio`` is
    computed from ``amcr`` and ``gt_footprint_share`` when not given. A missing score breaks nothing."""
    values = dict(scores)
    if values.get("amcr_ratio") is None:
        values["amcr_ratio"] = amcr_ratio(values.get("amcr"), values.get("gt_footprint_share"))
    return [(k, float(values[k]), limit) for k, limit in LIMITS.items() if values.get(k) is not None and values[k] > limit]
