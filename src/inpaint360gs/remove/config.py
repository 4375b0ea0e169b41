"""Settings of the removal (paper Sec. 3.4, supp. B "Object Removal"; docs/architecture.md, "Removal")."""

from __future__ import annotations

from dataclasses import dataclass

FOOTPRINT_TOP = 2.0  # the footprint column reaches this x the object's height (faint Gaussians over an object are its appearance)


@dataclass
class RemovalConfig:
    """Settings of the removal; the defaults are the authors' public code's, plus the steps beyond it
    (support guard, support column, footprint column), each with a switch that turns it off (None).
    Lengths marked "x R" are fractions of the orbit radius; the steps are described in :mod:`.objects`."""

    threshold: float = 0.7  # step 1: a Gaussian goes when its probability of a selected object exceeds this
    hull: bool = True  # step 2: also what lies inside the convex hull of the selected Gaussians
    outlier_k: int = 10  # statistical outlier filter before the hull: neighbours considered ...
    outlier_std: float = 2.0  # ... and the cut in standard deviations above the mean distance
    link: float = 4.0  # selected centres closer than this x their median nearest-neighbour spacing are one body
    min_part: float = 0.1  # components with fewer than this share of the largest one's Gaussians are not the object ...
    body_margin: float = 0.5  # ... unless they lie inside the body's bounding box grown by this share of its size
    protect_others: bool = True  # the hull keeps Gaussians with probability > 0.5 of another (non-background) object
    protect_background: float | None = None  # the hull keeps Gaussians whose background probability exceeds this (None: off)
    protect_support: float | None = 0.008  # the hull keeps background Gaussians within this height (x R) of the support plane (None: off)
    support_column: float | None = 0.01  # step 3: background Gaussians hanging below the removed ones, steps of this (x R) (None: off)
    footprint_margin: float | None = 0.05  # step 4: the footprint column, the outline grown by this x the footprint's size (None: off)
    footprint_depth: float = 1.0  # step 4: the column starts this x the object's height below the support plane (below it, inside the outline, only the hole shows it)
    column_silhouette: float | None = 0.5  # step 4: over the object's top, a Gaussian goes when its centre lies in the object's silhouette in this share of the views showing it (None: all go)
    plane_silhouette: float = 0.75  # step 4: on and under the support plane, a Gaussian in the support's colours stays unless its centre lies in the standing object's silhouette in this share of the views showing it (with column_silhouette None: no test)
    support_band: float = 0.05  # step 4: selected Gaussians within this x the object's height of the plane ...
    support_reach: float = 0.25  # ... farther than this x the footprint's size from its outline, in the support's colours around it, are support: they stay
    low_parts: float | None = 0.25  # step 4: unselected Gaussians lower than core.support.STANDING x the object's height, linked to what goes, within this x the footprint's size of its outline and nearer the object's chromaticity than the support's, are the object's low parts: they go (None: off)
    mask_share: float = 0.5  # a pixel is to be filled when removed Gaussians gave it at least this share of its colour

    def validate(self) -> RemovalConfig:
        """Check every setting's type and range before any work; returns ``self``. Raises
        :class:`~inpaint360gs.core.errors.InputError` naming the setting (``RemovalConfig.threshold``)."""
        from inpaint360gs.core.errors import InputError
        from inpaint360gs.core.settings import check_fields

        check_fields(self)
        shares = ("threshold", "min_part", "protect_background", "mask_share", "column_silhouette", "plane_silhouette")  # in [0, 1]
        for name, value in vars(self).items():
            if value is None or isinstance(value, bool):
                continue
            if name in shares and not 0 <= value <= 1:
                raise InputError(f"a share lies in [0, 1], got {value}", setting=f"RemovalConfig.{name}")
            if value < 0 or (name in ("outlier_k", "link", "support_column", "mask_share") and value == 0):
                raise InputError(f"must be {'> 0' if name in ('outlier_k', 'link', 'support_column', 'mask_share') else '>= 0'}, got {value}", setting=f"RemovalConfig.{name}")
        return self
