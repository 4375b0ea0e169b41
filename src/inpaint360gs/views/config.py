"""The settings of the virtual trajectory (paper Sec. 3.4, supp. B "Virtual Camera Views") and of the
unseen masks, apart from the camera maths of :mod:`.virtual` and :mod:`.unseen` so that the workflow
and the presets read these defaults without importing torch."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass
class VirtualViewsConfig:
    """The virtual trajectory (supp. B "Virtual Camera Views")."""

    num_views: int = 30  # L, the number of virtual views, >= 1
    min_fill: float = 0.01  # the region to fill must cover at least this share of each image, in [0, 1] ...
    max_fill: float = 0.50  # ... and at most this share
    # candidate radii, as multiples of the training cameras' median distance to the object centre
    radius_factors: tuple[float, ...] = (1.0, 0.85, 0.7, 0.55, 0.4)


@dataclass
class UnseenConfig:
    """Settings of the unseen (NBS) masks (see the module docstring); shares lie in [0, 1]."""

    depth_tol: float = 0.01  # a training view sees a point when nothing there is nearer by more than this share of the distance
    min_alpha: float = 0.5  # rendered alpha, in [0, 1]: below this the edited scene shows a hole
    footprint_share: float = 0.5  # footprint: the removed Gaussians gave at least this share of the colour
    seen_object_share: float = 0.1  # a training pixel to which the removed Gaussians gave at least this share recorded them, not what lies behind or under them
    min_component: int = 8  # specks smaller than this many pixels are dropped
    dilate: int = 3  # final dilation, pixels
