"""Configuration of 3DGS training: the original recipe's values as defaults (Kerbl et al. 2023,
``arguments/__init__.py``), used by the paper for its Gaussian field (paper supp. Sec. C).

Iteration-based schedule fields are given for the original 30k-iteration run. ``schedule_scale``
multiplies them (densification window, opacity-reset period, SH degree steps, position
learning-rate decay; not the densification interval, see ``DensifyConfig.scaled``) so a shorter
run keeps the same shape; it is explicit and 1.0 by
default, never applied silently (``--schedule-scale auto`` sets it to iterations / 30000).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

ORIGINAL_ITERATIONS = 30_000
SUPPORT_INIT_MODES = ("auto", "on", "off")
DENSIFY_GRADIENTS = ("auto", "mean", "abs")


def _scale_steps(steps: int, scale: float) -> int:
    return max(1, round(steps * scale))


@dataclass
class DensifyConfig:
    """Adaptive density control (3DGS Sec. 5.2 and ``densify_and_prune``)."""

    grad_threshold: float = 2e-4  # mean view-space gradient norm, NDC units, above which to densify
    # Not in the original: "abs" thresholds the sums of the per-pixel gradients' absolute values
    # (AbsGS; gs/strategy.py) at ``abs_grad_threshold`` instead; "auto" does so when 3DGS starts
    # from a sparse capture (support points added, TrainConfig.support_init), else "mean" (3DGS)
    gradient: str = "auto"  # auto | mean | abs
    abs_grad_threshold: float = 4e-4  # mean absolute view-space gradient norm, NDC units
    percent_dense: float = 0.01  # clone if max scale <= this x scene extent, else split
    split_children: int = 2  # N in 3DGS ``densify_and_split``
    split_scale_divisor: float = 0.8  # children's scales = parent / (0.8 N)
    min_opacity: float = 0.005  # prune below this opacity
    max_screen_size: float = 20.0  # prune if the 2D radius ever exceeded this many pixels ...
    max_world_size: float = 0.1  # ... or the largest scale exceeds this x scene extent (after 1st reset)
    densify_from: int = 500  # first step that may densify (exclusive)
    densify_until: int = 15_000  # statistics, densification and opacity resets stop here
    densify_every: int = 100  # steps between two densifications (not scaled, see ``scaled``)
    opacity_reset_every: int = 3000  # steps between opacity resets
    opacity_reset_value: float = 0.01  # opacities are clamped to at most this at a reset
    # Not in the original (0 = no cap, its behaviour): at most this many Gaussians after a
    # densification; when the candidates would exceed it, those with the largest gradients win.
    # Bounds the per-step cost of a CPU run with a fixed time budget (cf. gsplat MCMC's cap_max).
    max_gaussians: int = 0  # count, >= 0

    def scaled(self, scale: float) -> "DensifyConfig":
        """The same schedule for a run ``scale`` times as long as the original.

        The densification window and the opacity-reset period scale; the interval between two
        densifications does not: it is the optimisation time new Gaussians get to settle before the
        next gradient test, and shrinking it makes the count explode (results/README.md, "3DGS
        reconstruction").
        """
        if scale == 1.0:
            return dataclasses.replace(self)
        return dataclasses.replace(
            self,
            densify_from=_scale_steps(self.densify_from, scale),
            densify_until=_scale_steps(self.densify_until, scale),
            opacity_reset_every=_scale_steps(self.opacity_reset_every, scale),
        )


@dataclass
class TrainConfig:
    """Everything that determines a 3DGS training run (with ``seed``, it is deterministic)."""

    iterations: int = ORIGINAL_ITERATIONS  # optimiser steps, >= 1
    seed: int = 0  # seeds the optimisation loop (view order, random backgrounds)
    backend: str = "auto"  # rasterizer backend: auto | torch | numba | gsplat
    # SH colour: degree raised by one every ``sh_degree_interval`` steps up to ``sh_degree``
    sh_degree: int = 3  # final SH degree, 0..3
    sh_degree_interval: int = 1000  # steps
    init_opacity: float = 0.1  # initial opacity of every Gaussian, in (0, 1)
    # Not in the original: also start from points on the support plane where the SfM points leave
    # cells of the training photos uncovered (a plain sheet or table; gs/support_init.py): "on",
    # "off", or "auto" (on when the support is plain: most of the cells that show it uncovered)
    support_init: str = "auto"  # auto | on | off
    # Adam learning rates per parameter; positions decay exponentially and scale with the scene extent
    means_lr_init: float = 1.6e-4  # x scene extent, at step 0
    means_lr_final: float = 1.6e-6  # x scene extent, at ``means_lr_max_steps``
    means_lr_max_steps: int = ORIGINAL_ITERATIONS  # steps of the exponential decay
    sh0_lr: float = 2.5e-3  # SH degree-0 (base colour) coefficients
    shN_lr: float = 2.5e-3 / 20  # higher-degree SH coefficients
    opacity_lr: float = 0.05  # opacity logits
    scales_lr: float = 5e-3  # log scales
    quats_lr: float = 1e-3  # quaternions (unnormalised)
    adam_eps: float = 1e-15  # Adam epsilon
    # loss (1 - lambda) L1 + lambda (1 - SSIM)
    ssim_lambda: float = 0.2  # lambda above, in [0, 1]
    background: tuple[float, float, float] = (0.0, 0.0, 0.0)  # RGB in [0, 1] behind the Gaussians
    random_background: bool = False  # a fresh uniform background colour each step
    densify: DensifyConfig = field(default_factory=DensifyConfig)
    schedule_scale: float = 1.0  # multiplies every step-based schedule field (see module docstring)
    # bookkeeping
    checkpoint_every: int = 1000  # steps between atomic checkpoints (0: only at the end)
    eval_every: int = 0  # held-out evaluation every N steps into train_log.csv (0: only at the end)
    log_every: int = 50  # steps between rows of train_log.csv

    def validate(self) -> None:
        """Raise :class:`InputError` (naming the CLI option) for a setting out of range."""
        from inpaint360gs.core.errors import InputError

        if self.iterations < 1:
            raise InputError(f"iterations must be >= 1, got {self.iterations}", setting="TrainConfig.iterations")
        if not self.schedule_scale > 0:
            raise InputError(f"schedule scale must be > 0, got {self.schedule_scale}", setting="TrainConfig.schedule_scale")
        if not self.densify.grad_threshold > 0:
            raise InputError(f"densification gradient threshold must be > 0, got {self.densify.grad_threshold}", setting="DensifyConfig.grad_threshold")
        if self.densify.gradient not in DENSIFY_GRADIENTS:
            raise InputError(f"densify gradient must be one of {', '.join(DENSIFY_GRADIENTS)}, got {self.densify.gradient!r}", setting="DensifyConfig.gradient")
        if not self.densify.abs_grad_threshold > 0:
            raise InputError(f"absolute-gradient threshold must be > 0, got {self.densify.abs_grad_threshold}", setting="DensifyConfig.abs_grad_threshold")
        if self.densify.max_gaussians < 0:
            raise InputError(f"max Gaussians must be >= 0 (0: no cap), got {self.densify.max_gaussians}", setting="DensifyConfig.max_gaussians")
        if not 0 <= self.sh_degree <= 3:
            raise InputError(f"SH degree must be in 0..3, got {self.sh_degree}", setting="TrainConfig.sh_degree")
        if self.support_init not in SUPPORT_INIT_MODES:
            raise InputError(f"support init must be one of {', '.join(SUPPORT_INIT_MODES)}, got {self.support_init!r}", setting="TrainConfig.support_init")
        if self.backend not in ("auto", "torch", "numba", "gsplat"):
            raise InputError(f"unknown backend {self.backend!r}", setting="TrainConfig.backend")

    def effective(self) -> "TrainConfig":
        """This config with ``schedule_scale`` applied to the step-based fields (and reset to 1)."""
        s = self.schedule_scale
        if s == 1.0:
            return dataclasses.replace(self, densify=dataclasses.replace(self.densify))
        return dataclasses.replace(
            self,
            sh_degree_interval=_scale_steps(self.sh_degree_interval, s),
            means_lr_max_steps=_scale_steps(self.means_lr_max_steps, s),
            densify=self.densify.scaled(s),
            schedule_scale=1.0,
        )

    def to_dict(self) -> dict:
        """JSON-ready dict of every field (nested ``densify``; ``background`` as a list)."""
        d = dataclasses.asdict(self)
        d["background"] = list(self.background)
        return d

    @staticmethod
    def from_dict(d: dict) -> "TrainConfig":
        """Inverse of :meth:`to_dict`; raises TypeError for an unknown key."""
        d = dict(d)
        dens = DensifyConfig(**d.pop("densify", {}))
        if "background" in d:
            d["background"] = tuple(d["background"])
        if isinstance(d.get("support_init"), bool):  # written before "auto" existed
            d["support_init"] = "on" if d["support_init"] else "off"
        return TrainConfig(densify=dens, **d)
