"""3D inpainting with hybrid supervision (paper Sec. 3.5 "3D Inpainting", Eq. 6; supp. B "3D Inpainting").

The scene (edited, plus the new Gaussians of the initialisation) is optimised on the inpainted
views with

    L = (1 - λ1) ‖M ⊙ (C_inp − Ĉ)‖₁ + λ1 D-SSIM(C_inp, Ĉ) + λ2 LPIPS(C_inp, Ĉ, M)

the L1 term averaged over the mask pixels, D-SSIM over the whole image (pixels whose target is
meaningful: not a hole left by a temporarily removed occluder), LPIPS on both images multiplied by
the mask, computed on the mask's bounding box (with a margin) since the rest of the product is zero.
Defaults are the paper's: λ1 = 0.2, λ2 = 0.005, 2000 iterations. ``variant="code"`` uses the
authors' public code instead (λ1 = 0.8, λ2 = 0.0005, 5000 iterations, L1 over the whole image).
``supervision="mask"`` is ablation e) (Tab. 3, "w/o 3D hybrid supervision"): only the masked L1
(and LPIPS) terms, and only Gaussians inside the masked region (new ones, and those whose centre
projects into a mask) may move — the naive scheme the paper argues against.

All Gaussian parameters train through the shared optimisation loop (:mod:`inpaint360gs.gs.loop`)
with the 3DGS learning rates; the means' rate decays over the run.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass, replace

import numpy as np
import torch

from inpaint360gs.core.errors import InputError
from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.gs.config import TrainConfig
from inpaint360gs.gs.loop import OptimizationLoop, Target, TargetList
from inpaint360gs.gs.loss import ssim_map
from inpaint360gs.gs.optim import PARAM_NAMES, learning_rates
from inpaint360gs.inpaint.conditioned import InpaintedView
from inpaint360gs.render.api import render


@dataclass
class RefineConfig:
    """3D inpainting (Eq. 6); defaults are the paper's (supp. B)."""

    variant: str = "paper"  # "paper" | "code": the authors' public code (0.8 / 0.0005 / 5000, L1 over the whole image)
    iterations: int | None = None  # None: the variant's (2000 paper, 5000 code)
    lambda_dssim: float | None = None  # λ1; None: the variant's (0.2 paper, 0.8 code)
    lambda_lpips: float | None = None  # λ2; None: the variant's (0.005 paper, 0.0005 code)
    supervision: str = "hybrid"  # "hybrid" (Eq. 6) | "mask": ablation e)
    # LPIPS network of the loss. AlexNet: VGG16 costs ~15 GMAC per 256x192 image, ~0.5 s per step for
    # the loss's forward + backward on 2 CPU cores, 10x AlexNet; the evaluation uses VGG like the paper's code.
    lpips_net: str = "alex"
    lpips_margin: int = 8  # pixels around the mask's bounding box for the LPIPS crop
    seed: int = 0
    backend: str = "auto"

    def resolved(self) -> RefineConfig:
        if self.variant not in ("paper", "code"):
            raise InputError(f"unknown 3D inpainting variant {self.variant!r} (paper, code)", "--refine-variant")
        if self.supervision not in ("hybrid", "mask"):
            raise InputError(f"unknown supervision {self.supervision!r} (hybrid, mask)", "--supervision")
        paper = self.variant == "paper"
        return replace(
            self,
            iterations=(2000 if paper else 5000) if self.iterations is None else self.iterations,
            lambda_dssim=(0.2 if paper else 0.8) if self.lambda_dssim is None else self.lambda_dssim,
            lambda_lpips=(0.005 if paper else 0.0005) if self.lambda_lpips is None else self.lambda_lpips,
        )


def _bbox(mask: torch.Tensor, margin: int) -> tuple[slice, slice]:
    rows = torch.nonzero(mask.any(1)).flatten()
    cols = torch.nonzero(mask.any(0)).flatten()
    h, w = mask.shape
    r0, r1 = max(int(rows[0]) - margin, 0), min(int(rows[-1]) + margin + 1, h)
    c0, c1 = max(int(cols[0]) - margin, 0), min(int(cols[-1]) + margin + 1, w)
    return slice(r0, r1), slice(c0, c1)


def hybrid_loss(pred: torch.Tensor, target: torch.Tensor, mask: torch.Tensor, valid: torch.Tensor, cfg: RefineConfig) -> tuple[torch.Tensor, dict[str, float]]:
    """Eq. 6 on (H, W, 3) images, ``mask`` (H, W) bool (the region filled), ``valid`` (H, W) bool."""
    from inpaint360gs.metrics.lpips import lpips

    m = mask.to(pred.dtype)[..., None]
    n_mask = m.sum().clamp_min(1.0)
    if cfg.variant == "code":  # the public code: L1 over the whole (valid) image
        v = valid.to(pred.dtype)[..., None]
        l1 = ((pred - target).abs() * v).sum() / (3 * v.sum().clamp_min(1.0))
    else:
        l1 = ((pred - target).abs() * m).sum() / (3 * n_mask)
    logs = {"l1": l1.item()}
    if cfg.supervision == "mask":
        loss = l1
    else:
        s = ssim_map(pred, target).mean(-1)
        dssim = 1.0 - s[valid].mean() if valid.any() else torch.zeros((), dtype=pred.dtype)
        loss = (1.0 - cfg.lambda_dssim) * l1 + cfg.lambda_dssim * dssim
        logs["dssim"] = dssim.item()
    if cfg.lambda_lpips > 0 and mask.any():
        rs, cs = _bbox(mask, cfg.lpips_margin)
        a = (pred * m)[rs, cs].permute(2, 0, 1)
        b = (target * m)[rs, cs].permute(2, 0, 1)
        lp = lpips(a, b, net=cfg.lpips_net)
        loss = loss + cfg.lambda_lpips * lp
        logs["lpips"] = lp.item()
    return loss, logs


def _rows_in_masks(g: Gaussians, views: Sequence[InpaintedView]) -> torch.Tensor:
    """Gaussians whose centre projects into some view's mask."""
    from inpaint360gs.views.unseen import project

    means = g.means.detach().cpu().double().numpy()
    hit = np.zeros(len(means), dtype=bool)
    for v in views:
        u, w, z = project(v.camera, means)
        cam = v.camera
        ok = (z > 1e-6) & (u >= 0) & (u < cam.width) & (w >= 0) & (w < cam.height)
        idx = np.flatnonzero(ok)
        hit[idx[v.mask[w[ok].astype(np.int64), u[ok].astype(np.int64)]]] = True
    return torch.from_numpy(hit)


def refine(scene_model: Gaussians, new: Gaussians, views: Sequence[InpaintedView], cfg: RefineConfig | None = None, *, extent: float = 1.0, progress=None) -> tuple[Gaussians, list[dict]]:
    """Optimise ``scene_model`` + ``new`` on ``views`` with Eq. 6; returns the model and a log."""
    cfg = (cfg or RefineConfig()).resolved()
    if not views:
        raise InputError("3D inpainting needs at least one view")
    if not any(v.mask.any() for v in views):
        raise InputError("every unseen mask is empty: nothing to inpaint")
    degree = scene_model.sh_degree
    if new.sh_degree != degree:
        pad = torch.zeros(len(new), (degree + 1) ** 2 - 1, 3)
        new = replace(new, shN=pad)
    model = Gaussians(**{k: torch.cat([getattr(scene_model, k).detach(), getattr(new, k).detach()], 0) for k in PARAM_NAMES})
    targets = [
        Target(v.camera.name, v.camera, {
            "image": torch.from_numpy(v.color).float(), "mask": torch.from_numpy(v.mask), "valid": torch.from_numpy(v.valid),
        })
        for v in views
    ]  # fmt: skip
    tc = TrainConfig(means_lr_max_steps=cfg.iterations)
    lrs: dict = dict(learning_rates(tc, extent))
    lr0, lr1 = tc.means_lr_init * extent, tc.means_lr_final * extent
    lrs["means"] = lambda step: math.exp(math.log(lr0) * (1 - min(step / cfg.iterations, 1.0)) + math.log(lr1) * min(step / cfg.iterations, 1.0))
    rows = None
    if cfg.supervision == "mask":  # ablation e): only what lies in the masked region moves
        rows = _rows_in_masks(model, views)
        rows[len(scene_model) :] = True

    def render_fn(g, target, step, gen):
        return render(g, target.camera, background=torch.zeros(3), backend=cfg.backend)

    def loss_fn(out, target, step):
        d = target.data
        return hybrid_loss(out.color, d["image"], d["mask"], d["valid"], cfg)

    loop = OptimizationLoop(model, train=lrs, views=TargetList(targets), render_fn=render_fn, loss_fn=loss_fn, trainable_rows=rows, seed=cfg.seed)
    log = []
    for i in range(cfg.iterations):
        res = loop.step()
        if progress is not None:
            progress(1)
        if (i + 1) % 50 == 0 or i + 1 == cfg.iterations:
            log.append({"step": i + 1, "loss": res.loss, **res.logs})
    return loop.detached(), log
