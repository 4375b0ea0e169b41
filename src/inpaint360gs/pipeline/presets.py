"""The run presets, defined here once, each a whole :class:`~inpaint360gs.pipeline.config.RunConfig`:
``cpu`` (the budget for two CPU cores, the CLI's default), ``gpu`` (gsplat, the original 3DGS recipe)
and ``paper`` (the paper's settings, supp. B, on any backend).

A preset fixes the 3DGS training budget and the rasterizer backend; every other setting is the
paper's default of its stage's config. Change one with ``dataclasses.replace``:

>>> import dataclasses
>>> from inpaint360gs.pipeline.presets import get_preset, with_budget
>>> cfg = dataclasses.replace(get_preset("cpu"), seed=1)     # every stage reseeded
>>> cfg.train.seed, cfg.distill.seed, cfg.inpaint.refine.seed
(1, 1, 1)
>>> with_budget(cfg, iterations=600).train.schedule_scale    # 3DGS steps, the schedule scaled to them
0.02

``inpaint360gs run --preset``, the Python API (:func:`inpaint360gs.remove_object`), the workflow
(``train: {preset: ...}``) and ``benchmarks/bench_train.py`` read them from here."""

from __future__ import annotations

import copy
from dataclasses import replace

from inpaint360gs.core.errors import InputError
from inpaint360gs.gs.config import ORIGINAL_ITERATIONS, DensifyConfig, TrainConfig
from inpaint360gs.pipeline.config import RunConfig


def _train(iterations: int, max_gaussians: int) -> TrainConfig:
    return TrainConfig(iterations=iterations, schedule_scale=iterations / ORIGINAL_ITERATIONS, densify=DensifyConfig(max_gaussians=max_gaussians))


PRESETS: dict[str, RunConfig] = {  # name -> the run's settings (templates: get_preset gives a copy to change)
    "cpu": RunConfig(train=_train(3000, 120_000), backend="auto"),
    "gpu": RunConfig(train=_train(ORIGINAL_ITERATIONS, 0), backend="gsplat"),
    "paper": RunConfig(train=_train(ORIGINAL_ITERATIONS, 0), backend="auto"),
}
SUMMARIES: dict[str, str] = {  # name -> one line for --help
    "cpu": "two CPU cores: 3DGS 3000 steps, the schedule scaled, at most 120000 Gaussians",
    "gpu": "one CUDA GPU (gsplat): the original 3DGS recipe, 30000 steps, no cap",
    "paper": "the paper's settings (supp. B) on any backend: 30000 3DGS steps, no cap",
}
DEFAULT_PRESET = "cpu"


def get_preset(name: str) -> RunConfig:
    """A copy of the preset called ``name`` (a key of :data:`PRESETS`), free to change. Raises
    :class:`InputError` for any other name."""
    if not isinstance(name, str) or name not in PRESETS:
        raise InputError(f"unknown preset {name!r} (one of {', '.join(PRESETS)})", setting="preset")
    return copy.deepcopy(PRESETS[name])


def with_budget(cfg: RunConfig, *, iterations: int | None = None, max_gaussians: int | None = None) -> RunConfig:
    """``cfg`` with another 3DGS budget: ``iterations`` steps with the step-based schedule scaled to
    them (``schedule_scale`` = iterations / 30000), at most ``max_gaussians`` (0: no cap); None keeps
    the value."""
    train = cfg.train
    if iterations is not None:
        train = replace(train, iterations=iterations, schedule_scale=iterations / ORIGINAL_ITERATIONS)
    if max_gaussians is not None:
        train = replace(train, densify=replace(train.densify, max_gaussians=max_gaussians))
    return replace(cfg, train=train)
