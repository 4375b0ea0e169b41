"""The virtual trajectory's settings (paper Sec. 3.4, supp. B "Virtual Camera Views"), apart from the
camera maths of :mod:`.virtual` so that the workflow reads these defaults without importing torch."""

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
