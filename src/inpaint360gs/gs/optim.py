"""Per-parameter Adam optimisers and the edits densification makes to them (3DGS ``GaussianModel``).

Each Gaussian attribute is one ``nn.Parameter`` with its own Adam (its own learning rate), as in
gsplat. Adding, removing or resetting Gaussians replaces the parameter tensor and edits the Adam
moments to match: new rows get zero moments, removed rows lose theirs (3DGS
``cat_tensors_to_optimizer`` / ``_prune_optimizer`` / ``replace_tensor_to_optimizer``).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import torch

from inpaint360gs.gs.config import TrainConfig
from inpaint360gs.core.gaussians import Gaussians

PARAM_NAMES = ("means", "log_scales", "quats", "opacity_logits", "sh0", "shN")

Params = dict[str, torch.nn.Parameter]
Optimizers = dict[str, torch.optim.Adam]


def make_params(g: Gaussians) -> Params:
    """Trainable parameters (the optional object features are not part of 3DGS training)."""
    return {k: torch.nn.Parameter(getattr(g, k).detach().clone().contiguous()) for k in PARAM_NAMES}


def as_gaussians(params: Params) -> Gaussians:
    return Gaussians(**{k: params[k] for k in PARAM_NAMES})


def learning_rates(cfg: TrainConfig, scene_extent: float) -> dict[str, float]:
    """Initial learning rate of every parameter (3DGS ``training_setup``)."""
    return {
        "means": cfg.means_lr_init * scene_extent,
        "log_scales": cfg.scales_lr,
        "quats": cfg.quats_lr,
        "opacity_logits": cfg.opacity_lr,
        "sh0": cfg.sh0_lr,
        "shN": cfg.shN_lr,
    }


def make_optimizers(params: Params, lrs: dict[str, float], eps: float) -> Optimizers:
    return {k: torch.optim.Adam([params[k]], lr=lrs[k], eps=eps) for k in params}


def means_lr(step: int, cfg: TrainConfig, scene_extent: float) -> float:
    """Log-linear decay from ``means_lr_init`` to ``means_lr_final`` over ``means_lr_max_steps``,
    scaled by the scene extent (3DGS ``get_expon_lr_func``; its delay is off by default)."""
    t = min(max(step / max(cfg.means_lr_max_steps, 1), 0.0), 1.0)
    lr0, lr1 = cfg.means_lr_init * scene_extent, cfg.means_lr_final * scene_extent
    return math.exp(math.log(lr0) * (1 - t) + math.log(lr1) * t)


def _swap(opt: torch.optim.Adam, old: torch.nn.Parameter, new: torch.nn.Parameter, edit: Callable[[torch.Tensor], torch.Tensor]) -> None:
    """Point ``opt`` at ``new`` and edit the per-row moments with ``edit`` (``step`` is kept)."""
    state = opt.state.pop(old, None)
    opt.param_groups[0]["params"] = [new]
    if state:
        for key in ("exp_avg", "exp_avg_sq"):
            if key in state:
                state[key] = edit(state[key])
        opt.state[new] = state


def append_rows(params: Params, optimizers: Optimizers, new: dict[str, torch.Tensor]) -> None:
    """Append new Gaussians (zero Adam moments for them)."""
    for k in PARAM_NAMES:
        old = params[k]
        add = new[k].detach().to(old.dtype)
        p = torch.nn.Parameter(torch.cat([old.detach(), add], 0))
        _swap(optimizers[k], old, p, lambda v, a=add: torch.cat([v, torch.zeros_like(a)], 0))
        params[k] = p


def keep_rows(params: Params, optimizers: Optimizers, keep: torch.Tensor) -> None:
    """Keep only the Gaussians where the boolean mask ``keep`` is true."""
    for k in PARAM_NAMES:
        old = params[k]
        p = torch.nn.Parameter(old.detach()[keep].contiguous())
        _swap(optimizers[k], old, p, lambda v: v[keep].contiguous())
        params[k] = p


def reset_param(params: Params, optimizers: Optimizers, name: str, value: torch.Tensor) -> None:
    """Replace one parameter's values and zero its Adam moments (3DGS ``reset_opacity``)."""
    old = params[name]
    p = torch.nn.Parameter(value.detach().to(old.dtype).contiguous())
    _swap(optimizers[name], old, p, torch.zeros_like)
    params[name] = p
