"""Adaptive density control of 3DGS (Kerbl et al. 2023, Sec. 5.2; ``densify_and_prune``).

Per step, while ``step < densify_until``: the norm of each visible Gaussian's view-space (means2d)
gradient, converted to NDC units, is accumulated with a visit count, and the largest 2D radius is
kept. Every ``densify_every`` steps after ``densify_from``: Gaussians whose mean gradient reaches
``grad_threshold`` are cloned when small (max scale <= percent_dense x extent) or split into
``split_children`` samples when large; then low-opacity Gaussians are pruned, and after the first
opacity reset also those that grew too big on screen or in the world. Every ``opacity_reset_every``
steps opacities are clamped to ``opacity_reset_value``. The structure follows gsplat's
``DefaultStrategy``: an object with its state in a dict, called after the optimiser step.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch

from inpaint360gs.core.gaussians import quat_to_rotmat
from inpaint360gs.gs.config import DensifyConfig
from inpaint360gs.gs.optim import Optimizers, Params, append_rows, keep_rows, reset_param


@dataclass
class DensifyStats:
    """What one densification step did (logged)."""

    cloned: int = 0
    split: int = 0
    pruned: int = 0
    reset_opacity: bool = False


class Strategy:
    """How the set of Gaussians changes during an optimisation (gsplat's strategy objects).

    The base class changes nothing: object-ID distillation (paper Sec. 3.3) trains features of a
    fixed set of Gaussians. Subclasses edit ``params``/``optimizers``/``state`` in place after each
    optimiser step.
    """

    def initialize_state(self, n: int, device: torch.device | str = "cpu") -> dict[str, torch.Tensor]:
        """Per-Gaussian running state for ``n`` Gaussians on ``device``; none by default."""
        return {}

    def step_post_backward(
        self,
        params: Params,
        optimizers: Optimizers,
        state: dict[str, torch.Tensor],
        step: int,
        out,
        camera,
        generator: torch.Generator | None = None,
    ) -> DensifyStats:
        """Run after the optimiser step of 0-based ``step``; ``out`` is that step's render output
        (``means2d.grad``, ``radii``) and ``camera`` the view it rendered."""
        return DensifyStats()


class DensifyStrategy(Strategy):
    """The 3DGS clone/split/prune/reset schedule for a scene of radius ``scene_extent``."""

    def __init__(self, cfg: DensifyConfig, scene_extent: float, *, sparse_start: bool = False):
        """``sparse_start``: the Gaussians start from a sparse capture's points (3DGS added support
        points, gs/support_init.py); with ``cfg.gradient == "auto"`` the absolute gradient is then
        thresholded (:meth:`view_gradient`), else the mean one."""
        self.cfg = cfg
        self.extent = float(scene_extent)
        self.gradient = "abs" if cfg.gradient == "abs" or (cfg.gradient == "auto" and sparse_start) else "mean"

    def initialize_state(self, n: int, device: torch.device | str = "cpu") -> dict[str, torch.Tensor]:
        """Zeroed per-Gaussian gradient sums, visibility counts and max 2D radii."""
        return {
            "grad2d": torch.zeros(n, device=device),  # accumulated NDC-space gradient norms
            "count": torch.zeros(n, device=device),  # steps each Gaussian was visible
            "max_radii": torch.zeros(n, device=device),  # largest 2D radius (pixels) since the last densification
        }

    def view_gradient(self, means2d: torch.Tensor) -> torch.Tensor | None:
        """The per-Gaussian view-space gradient this schedule thresholds, (N, 2), or None before a backward.

        ``gradient="mean"``: dLoss/d(pixel position), the sum over the Gaussian's pixels (3DGS).
        ``gradient="abs"``: the sum over its pixels of each pixel's gradient's absolute value
        (AbsGS, Ye et al. 2024, "homodirectional" gradient): a large Gaussian over detail whose
        pixels pull its centre in opposite directions has a small sum and a large absolute sum, so
        it still splits. The rasterizer leaves it on ``means2d.absgrad``.
        """
        if self.gradient == "abs" and means2d.grad is not None:
            if getattr(means2d, "absgrad", None) is None:  # a render without absgrad=True: never densify silently
                raise RuntimeError("densifying on the absolute gradient needs render(..., absgrad=True)")
            return means2d.absgrad
        return means2d.grad

    def accumulate(self, state: dict[str, torch.Tensor], means2d_grad: torch.Tensor, radii: torch.Tensor, width: int, height: int) -> None:
        """Add one view's statistics. ``means2d_grad`` is dLoss/d(pixel position), (N, 2).

        The original thresholds gradients w.r.t. NDC coordinates; d pixel / d ndc = size / 2.
        """
        visible = radii > 0
        g = means2d_grad.detach()[visible]
        g = torch.stack([g[:, 0] * (width / 2.0), g[:, 1] * (height / 2.0)], dim=-1)
        state["grad2d"][visible] += g.norm(dim=-1).to(state["grad2d"].dtype)
        state["count"][visible] += 1
        r = radii.detach()[visible].to(state["max_radii"].dtype)
        state["max_radii"][visible] = torch.maximum(state["max_radii"][visible], r)

    def step_post_backward(self, params, optimizers, state, step, out, camera, generator=None) -> DensifyStats:
        """Accumulate the view-space gradients, then densify and prune and reset opacities on the 3DGS schedule; returns
        what changed."""
        cfg = self.cfg
        stats = DensifyStats()
        if step >= cfg.densify_until:
            return stats
        grad = self.view_gradient(out.means2d)
        if grad is not None:
            # the render may have drawn fixed Gaussians after the trained ones (3D inpainting draws
            # the static scene behind them): the first rows are the params'
            n = params["means"].shape[0]
            self.accumulate(state, grad[:n], out.radii[:n], camera.width, camera.height)
        if step > cfg.densify_from and step % cfg.densify_every == 0:
            stats = self.densify_and_prune(params, optimizers, state, prune_big=step > cfg.opacity_reset_every, generator=generator)
        if step > 0 and step % cfg.opacity_reset_every == 0:
            self.reset_opacity(params, optimizers)
            stats.reset_opacity = True
        return stats

    def densify_and_prune(
        self,
        params: Params,
        optimizers: Optimizers,
        state: dict[str, torch.Tensor],
        *,
        prune_big: bool,
        generator: torch.Generator | None = None,
    ) -> DensifyStats:
        """Clone small and split large high-gradient Gaussians, then prune transparent ones (and, with ``prune_big``,
        too large ones); returns the counts."""
        cfg = self.cfg
        n = params["means"].shape[0]
        grads = state["grad2d"] / state["count"].clamp_min(1)
        high = grads >= (cfg.abs_grad_threshold if self.gradient == "abs" else cfg.grad_threshold)
        max_scale = params["log_scales"].detach().exp().max(dim=-1).values
        small = max_scale <= cfg.percent_dense * self.extent
        if cfg.max_gaussians > 0:
            high = self._within_cap(high, small, grads, n)
        clone = high & small
        split = high & ~small

        # clones: identical copies (3DGS ``densify_and_clone``)
        new = {k: params[k].detach()[clone] for k in params}
        # split children: positions sampled from the parent Gaussian, scales shrunk (``densify_and_split``)
        k_ = cfg.split_children
        sel = {k: params[k].detach()[split] for k in params}
        scales = sel["log_scales"].exp().repeat(k_, 1)
        # drawn on the CPU generator whatever the device: the same seed gives the same children
        samples = torch.randn(scales.shape, generator=generator, dtype=scales.dtype).to(scales.device) * scales
        rots = quat_to_rotmat(sel["quats"]).repeat(k_, 1, 1)
        children = {k: sel[k].repeat(k_, *([1] * (sel[k].ndim - 1))) for k in params}
        children["means"] = torch.bmm(rots, samples[..., None])[..., 0] + children["means"]
        children["log_scales"] = torch.log(scales / (cfg.split_scale_divisor * k_))
        new = {k: torch.cat([new[k], children[k]], 0) for k in params}
        append_rows(params, optimizers, new)

        n_new = new["means"].shape[0]
        remove = torch.cat([split, torch.zeros(n_new, dtype=torch.bool, device=split.device)])
        # prune (after densification, over all Gaussians, as the original)
        opac = torch.sigmoid(params["opacity_logits"].detach())
        remove |= opac < cfg.min_opacity
        if prune_big:
            radii = torch.cat([state["max_radii"], torch.zeros(n_new, device=state["max_radii"].device)])
            too_big_screen = radii > cfg.max_screen_size
            too_big_world = params["log_scales"].detach().exp().max(dim=-1).values > cfg.max_world_size * self.extent
            remove |= too_big_screen | too_big_world
        keep_rows(params, optimizers, ~remove)

        m = params["means"].shape[0]
        for key in state:
            state[key] = torch.zeros(m, dtype=state[key].dtype, device=state[key].device)
        return DensifyStats(cloned=int(clone.sum()), split=int(split.sum()), pruned=int(remove.sum()) - int(split.sum()))

    def _within_cap(self, high: torch.Tensor, small: torch.Tensor, grads: torch.Tensor, n: int) -> torch.Tensor:
        """Keep the largest-gradient candidates whose growth (clone +1, split +children-1) fits the cap."""
        room = self.cfg.max_gaussians - n
        if room <= 0:
            return torch.zeros_like(high)
        idx = torch.nonzero(high).flatten()
        growth = torch.where(small[idx], 1, self.cfg.split_children - 1)
        if int(growth.sum()) <= room:
            return high
        order = torch.argsort(grads[idx], descending=True, stable=True)
        fits = torch.cumsum(growth[order], 0) <= room
        out = torch.zeros_like(high)
        out[idx[order[fits]]] = True
        return out

    def reset_opacity(self, params: Params, optimizers: Optimizers) -> None:
        """Clamp opacities to at most ``opacity_reset_value`` and zero their Adam moments."""
        cap = torch.logit(torch.tensor(self.cfg.opacity_reset_value, dtype=params["opacity_logits"].dtype))
        reset_param(params, optimizers, "opacity_logits", torch.minimum(params["opacity_logits"].detach(), cap))
