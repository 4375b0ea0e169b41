"""Settings of the association (paper Sec. 3.2, supp. B "Mask Association")."""

from __future__ import annotations

from dataclasses import dataclass, replace

from inpaint360gs.core.errors import InputError

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
        """A copy with the variant's ``sigma`` and ``keep_near`` filled in; raises :class:`InputError`
        (naming the CLI option) for an unknown method, variant or comparison, or a value out of range."""
        if self.method not in ("kom", "tracker"):
            raise InputError(f"unknown association method {self.method!r} (kom, tracker)", setting="AssociationConfig.method")
        if self.variant not in ("paper", "code"):
            raise InputError(f"unknown association variant {self.variant!r} (paper, code)", setting="AssociationConfig.variant")
        if self.compare not in ("visible", "all"):
            raise InputError(f"unknown database comparison {self.compare!r} (visible, all)", setting="AssociationConfig.compare")
        paper = self.variant == "paper"
        out = replace(
            self,
            sigma=(0.2 if paper else 0.1) if self.sigma is None else self.sigma,
            keep_near=(1.0 if paper else 0.3) if self.keep_near is None else self.keep_near,
        )
        if not 0 < out.sigma < 1:
            raise InputError(f"GS-IoU threshold must lie in (0, 1), got {out.sigma}", setting="AssociationConfig.sigma")
        if not 0 < out.keep_near <= 1:
            raise InputError(f"near fraction must lie in (0, 1], got {out.keep_near}", setting="AssociationConfig.keep_near")
        if not (0 <= out.part_share <= 1 and 0 <= out.merge_share <= 1):
            raise InputError("part and merge shares must lie in [0, 1] (0 = off)", setting="AssociationConfig.part_share/AssociationConfig.merge_share")
        if out.patch < 1:
            raise InputError(f"patch size must be >= 1, got {out.patch}", setting="AssociationConfig.patch")
        return out
