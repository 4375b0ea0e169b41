"""Where a removal on a capture stops being acceptable (docs/architecture.md, "A run checks
itself"): the limits of the no-ground-truth scores (:mod:`.capture`) that ``inpaint360gs run``
checks and the capture scores print as targets. Torch-free: the run config holds them."""

from __future__ import annotations

from dataclasses import dataclass

from inpaint360gs.core.errors import InputError
from inpaint360gs.core.settings import check_fields


@dataclass(frozen=True)
class CheckLimits:
    """Where a run's result stops being acceptable (the README's targets for a capture)."""

    outside_drop_db: float = 0.2  # PSNR outside the grown footprint may drop by at most this (dB)
    standing: float = 0.02  # opacity-weighted share standing in the footprint column
    over_removal: float | None = 1.45  # the removal's masks over the standing selection's, summed over the training views (None: not judged)
    beside: float | None = 0.015  # the object's colours just outside its footprint after the inpainting, over the footprint's area (None: not judged)
    in_fill: float | None = None  # the object's colours inside its footprint after the inpainting, over its area (None: reported, not judged)
    laplacian: tuple[float, float] = (0.7, 1.3)  # fill |Laplacian| over the ring's
    luminance: float = 0.15  # fill luminance within this of the ring's
    min_ring_texture: float = 0.004  # a ring whose mean |Laplacian| (luminance in [0, 1]) is below this has no texture to compare with
    picture_width: int = 320  # width of each view in the picture

    def __post_init__(self) -> None:
        check_fields(self)

    def validate(self) -> "CheckLimits":
        """Check the ranges; returns ``self``. Raises :class:`InputError` naming the setting."""
        lo, hi = self.laplacian
        for name, ok in (("outside_drop_db", self.outside_drop_db >= 0), ("standing", 0 <= self.standing <= 1), ("over_removal", self.over_removal is None or self.over_removal >= 1), ("beside", self.beside is None or 0 <= self.beside <= 1), ("in_fill", self.in_fill is None or 0 <= self.in_fill <= 1), ("laplacian", 0 <= lo <= 1 <= hi),
                         ("luminance", 0 <= self.luminance <= 1), ("min_ring_texture", self.min_ring_texture >= 0), ("picture_width", self.picture_width >= 16)):  # fmt: skip
            if not ok:
                raise InputError(f"out of range: {getattr(self, name)!r}", setting=f"CheckLimits.{name}")
        return self
