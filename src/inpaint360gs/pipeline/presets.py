"""The run presets, defined here once: ``cpu`` (the budget for two CPU cores, the CLI's default), ``gpu``
(gsplat, the original 3DGS recipe) and ``paper`` (the paper's settings, supp. B, on any backend).

A preset fixes the 3DGS training budget and the rasterizer backend; every other setting is the
paper's default of its stage's config. ``inpaint360gs run --preset``, the Python API
(:func:`inpaint360gs.remove_object`) and ``benchmarks/bench_train.py`` read them from here."""

from __future__ import annotations

from dataclasses import dataclass

from inpaint360gs.core.errors import InputError
from inpaint360gs.gs.config import ORIGINAL_ITERATIONS, DensifyConfig, TrainConfig


@dataclass(frozen=True)
class Preset:
    """A training budget and a backend; :meth:`run_config` makes the whole run's settings."""

    name: str
    summary: str
    iterations: int  # 3DGS steps, the step-based schedule scaled to them
    max_gaussians: int  # densification cap, largest gradients first (0: none)
    backend: str  # rasterizer backend (auto | torch | numba | gsplat)

    def train_config(self, *, seed: int = 0, iterations: int | None = None, max_gaussians: int | None = None, backend: str | None = None) -> TrainConfig:
        """3DGS settings: the preset's budget, each value replaced by the argument given (not None).

        Returns a :class:`TrainConfig` whose schedule is scaled to its iterations."""
        iterations = self.iterations if iterations is None else iterations
        return TrainConfig(
            iterations=iterations, seed=seed, backend=self.backend if backend is None else backend, schedule_scale=iterations / ORIGINAL_ITERATIONS,
            densify=DensifyConfig(max_gaussians=self.max_gaussians if max_gaussians is None else max_gaussians),
        )  # fmt: skip

    def run_config(self, *, seed: int = 0, backend: str | None = None, iterations: int | None = None, max_gaussians: int | None = None,
                   distill_iterations: int | None = None, segmenter: str | None = None, association: str = "kom", inpaint=None):  # fmt: skip
        """Every setting of a run (:class:`inpaint360gs.pipeline.run.RunConfig`) under this preset.

        Arguments left None take the preset's value (``iterations``, ``max_gaussians``, ``backend``)
        or the stage's default (``distill_iterations``, ``segmenter``, ``inpaint``: an
        :class:`InpaintConfig`, built with ``seed`` and the backend when None). ``association`` is
        ``"kom"`` or ``"tracker"``. Raises :class:`InputError` for an unknown association method."""
        from inpaint360gs.associate.config import AssociationConfig
        from inpaint360gs.distill.config import DistillConfig
        from inpaint360gs.inpaint.refine import RefineConfig
        from inpaint360gs.inpaint.stage import InpaintConfig
        from inpaint360gs.pipeline.run import RunConfig
        from inpaint360gs.segment.base import DEFAULT_SEGMENTER

        backend = self.backend if backend is None else backend
        distill = DistillConfig(**({} if distill_iterations is None else {"iterations": distill_iterations}), seed=seed, backend=backend)
        if inpaint is None:
            inpaint = InpaintConfig(refine=RefineConfig(seed=seed, backend=backend).resolved(), backend=backend)
        return RunConfig(
            train=self.train_config(seed=seed, iterations=iterations, max_gaussians=max_gaussians, backend=backend),
            segmenter=DEFAULT_SEGMENTER if segmenter is None else segmenter, association=AssociationConfig(method=association).resolved(),
            distill=distill, inpaint=inpaint, seed=seed, backend=backend,
        )  # fmt: skip


PRESETS: dict[str, Preset] = {
    p.name: p
    for p in (
        Preset("cpu", "two CPU cores: 3DGS 3000 steps, the schedule scaled, at most 120000 Gaussians", 3000, 120_000, "auto"),
        Preset("gpu", "one CUDA GPU (gsplat): the original 3DGS recipe, 30000 steps, no cap", ORIGINAL_ITERATIONS, 0, "gsplat"),
        Preset("paper", "the paper's settings (supp. B) on any backend: 30000 3DGS steps, no cap", ORIGINAL_ITERATIONS, 0, "auto"),
    )
}
DEFAULT_PRESET = "cpu"


def get_preset(name: str) -> Preset:
    """The preset called ``name`` (a key of :data:`PRESETS`). Raises :class:`InputError` for any other name."""
    if name not in PRESETS:
        raise InputError(f"unknown preset {name!r} (one of {', '.join(PRESETS)})", setting="preset")
    return PRESETS[name]
