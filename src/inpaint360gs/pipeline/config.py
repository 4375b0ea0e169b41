"""Every setting of a run (:class:`RunConfig`): one config object per stage, the segmenter by name, the
run's seed and backend. Apart from the runner so that the presets (:mod:`.presets`) and the
workflow read them without importing torch."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

from inpaint360gs.associate.config import AssociationConfig
from inpaint360gs.core.errors import InputError
from inpaint360gs.core.settings import check_fields
from inpaint360gs.distill.config import DistillConfig
from inpaint360gs.gs.config import TrainConfig
from inpaint360gs.inpaint.config import InpaintConfig, RefineConfig
from inpaint360gs.pipeline.check import CheckLimits
from inpaint360gs.remove.config import RemovalConfig
from inpaint360gs.segment.base import DEFAULT_SEGMENTER, SEGMENTERS

BACKENDS = ("auto", "torch", "numba", "gsplat")


def _inpaint_default() -> InpaintConfig:
    return InpaintConfig(refine=RefineConfig().resolved())


@dataclass
class RunConfig:
    """Every setting of a run; each stage's part is that stage's own config.

    ``seed`` and ``backend`` are the run's: on construction (and so on every ``dataclasses.replace``)
    every stage config takes them, so ``replace(PRESETS["cpu"], seed=1)`` reseeds every stage (set
    them here, not in a stage's config). Every field is type-checked on construction
    (:func:`inpaint360gs.core.settings.check_fields`; :class:`InputError` naming the setting), and
    :meth:`validate` checks the ranges of every stage's settings."""

    train: TrainConfig = field(default_factory=TrainConfig)  # 3DGS training (stage "train")
    segmenter: str = DEFAULT_SEGMENTER  # 2D segmenter by name (segment.base.get_segmenter)
    segmenter_options: dict = field(default_factory=dict)  # keyword options of that segmenter's config
    association: AssociationConfig = field(default_factory=lambda: AssociationConfig().resolved())  # Key Object Management (stage "associate")
    distill: DistillConfig = field(default_factory=DistillConfig)  # object-ID distillation (stage "distill")
    removal: RemovalConfig = field(default_factory=RemovalConfig)  # object selection and removal (stage "remove")
    inpaint: InpaintConfig = field(default_factory=_inpaint_default)  # virtual views, 2D and 3D inpainting (stage "inpaint")
    seed: int = 0  # the run's seed, every stage's (see the class docstring); part of the segment signature
    backend: str = "auto"  # rasterizer backend of every stage: "auto", "torch", "numba" or "gsplat"
    check: CheckLimits = field(default_factory=CheckLimits)  # where the run's own check of its result fails it (docs/architecture.md, "A run checks itself")

    def __post_init__(self) -> None:
        check_fields(self)
        if self.backend not in BACKENDS:
            raise InputError(f"unknown backend {self.backend!r} (one of {', '.join(BACKENDS)})", setting="RunConfig.backend")
        s, b = self.seed, self.backend
        self.train = replace(self.train, seed=s, backend=b)
        self.distill = replace(self.distill, seed=s, backend=b)
        self.inpaint = replace(self.inpaint, backend=b, refine=replace(self.inpaint.refine, seed=s, backend=b))

    def validate(self) -> "RunConfig":
        """Check the types (again: the stage configs may have been changed in place) and the ranges of
        every stage's settings before any work; returns ``self``. Raises :class:`InputError` naming
        the setting (``TrainConfig.iterations``, ``RunConfig.segmenter``, ...)."""
        from inpaint360gs.inpaint.config import check_inpaint_config

        check_fields(self)
        if self.segmenter not in SEGMENTERS:
            raise InputError(f"unknown segmenter {self.segmenter!r} (one of {', '.join(SEGMENTERS)})", setting="RunConfig.segmenter")
        self.train.validate()
        self.association.resolved()
        self.distill.validate()
        self.removal.validate()
        check_inpaint_config(self.inpaint)
        self.check.validate()
        return self
