"""Per-parameter Adam optimisers and the edits densification makes to them (3DGS ``GaussianModel``).

Every per-Gaussian tensor of a model is one ``nn.Parameter``; the trainable ones have their own
Adam (their own learning rate), as in gsplat, the frozen ones (``requires_grad=False``) none.
Adding, removing or resetting Gaussians replaces every tensor and edits the Adam moments to match:
new rows get zero moments, removed rows lose theirs (3DGS ``cat_tensors_to_optimizer`` /
``_prune_optimizer`` / ``replace_tensor_to_optimizer``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterable

import torch

from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.gs.config import TrainConfig

# The per-Gaussian attributes 3DGS optimises (the object features of paper Sec. 3.3 come on top).
PARAM_NAMES = ("means", "log_scales", "quats", "opacity_logits", "sh0", "shN")

Params = dict[str, torch.nn.Parameter]
Optimizers = dict[str, torch.optim.Adam]


def make_params(g: Gaussians, trainable: Iterable[str]) -> Params:
    """Every tensor of ``g`` as a parameter, in the model's field order; only ``trainable`` ones require grad."""
    train = set(trainable)
    unknown = train - set(g.tensors())
    if unknown:
        raise ValueError(f"no such Gaussian tensor(s) to train: {sorted(unknown)}")
    return {k: torch.nn.Parameter(t.detach().clone().contiguous(), requires_grad=k in train) for k, t in g.tensors().items()}


def as_gaussians(params: Params) -> Gaussians:
    """The parameters ``params`` (field name -> tensor) as a :class:`Gaussians`."""
    return Gaussians(**params)


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


def adam(params, lr: float, eps: float) -> torch.optim.Adam:
    """torch's Adam with its fused kernel (one pass over each tensor for the moments and the update,
    on CPU as on CUDA): the same update as the default per-op path to rounding, several times
    cheaper on CPU, where the per-op path took some 6 % of a 3DGS step on the kitchen capture
    (``benchmarks/bench_train.py`` times the stage)."""
    return torch.optim.Adam(params, lr=lr, eps=eps, fused=True)


def make_optimizers(params: Params, lrs: dict[str, float], eps: float) -> Optimizers:
    """One Adam per trainable parameter named in ``lrs`` (in ``lrs`` order)."""
    return {k: adam([params[k]], lr, eps) for k, lr in lrs.items()}


def means_lr(step: int, cfg: TrainConfig, scene_extent: float) -> float:
    """Log-linear decay from ``means_lr_init`` to ``means_lr_final`` over ``means_lr_max_steps``,
    scaled by the scene extent (3DGS ``get_expon_lr_func``; its delay is off by default)."""
    t = min(max(step / max(cfg.means_lr_max_steps, 1), 0.0), 1.0)
    lr0, lr1 = cfg.means_lr_init * scene_extent, cfg.means_lr_final * scene_extent
    return math.exp(math.log(lr0) * (1 - t) + math.log(lr1) * t)


def _swap(opt: torch.optim.Adam | None, old: torch.nn.Parameter, new: torch.nn.Parameter, edit: Callable[[torch.Tensor], torch.Tensor]) -> None:
    """Point ``opt`` at ``new`` and edit the per-row moments with ``edit`` (``step`` is kept)."""
    if opt is None:
        return
    state = opt.state.pop(old, None)
    opt.param_groups[0]["params"] = [new]
    if state:
        for key in ("exp_avg", "exp_avg_sq"):
            if key in state:
                state[key] = edit(state[key])
        opt.state[new] = state


def _replace(params: Params, optimizers: Optimizers, name: str, value: torch.Tensor, edit: Callable[[torch.Tensor], torch.Tensor]) -> None:
    old = params[name]
    p = torch.nn.Parameter(value.contiguous(), requires_grad=old.requires_grad)
    _swap(optimizers.get(name), old, p, edit)
    params[name] = p


def append_rows(params: Params, optimizers: Optimizers, new: dict[str, torch.Tensor]) -> None:
    """Append new Gaussians (zero Adam moments for them); ``new`` holds every tensor of ``params``."""
    for k in list(params):
        add = new[k].detach().to(params[k].dtype)
        _replace(params, optimizers, k, torch.cat([params[k].detach(), add], 0), lambda v, a=add: torch.cat([v, torch.zeros_like(a)], 0))


def keep_rows(params: Params, optimizers: Optimizers, keep: torch.Tensor) -> None:
    """Keep only the Gaussians where the boolean mask ``keep`` is true."""
    for k in list(params):
        _replace(params, optimizers, k, params[k].detach()[keep], lambda v: v[keep].contiguous())


def reset_param(params: Params, optimizers: Optimizers, name: str, value: torch.Tensor) -> None:
    """Replace one parameter's values and zero its Adam moments (3DGS ``reset_opacity``)."""
    _replace(params, optimizers, name, value.detach().to(params[name].dtype), torch.zeros_like)
