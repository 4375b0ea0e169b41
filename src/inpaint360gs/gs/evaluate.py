"""Render a model at a set of views and score it against their images (PSNR, SSIM per view)."""

from __future__ import annotations

from collections.abc import Sequence

import torch

from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.io.scene import Scene, View
from inpaint360gs.metrics import psnr, ssim


@torch.no_grad()
def evaluate_views(
    gaussians: Gaussians,
    scene: Scene,
    views: Sequence[View],
    *,
    sh_degree: int | None = None,
    background: torch.Tensor | None = None,
    backend: str = "auto",
    allow_test: bool = False,
) -> dict:
    """Mean and per-view PSNR/SSIM of renders (clamped to [0, 1]) at ``views``.

    Means are per-image averages, as in 3DGS ``metrics.py``. ``psnr``/``ssim`` are None without views.
    """
    from inpaint360gs.render.api import render

    per_view = {}
    for v in views:
        ref = scene.load_image(v, allow_test=allow_test)
        out = render(gaussians, v.camera, sh_degree=sh_degree, background=background, backend=backend)
        img = out.color.clamp(0.0, 1.0).cpu()
        per_view[v.name] = {"psnr": psnr(img, ref), "ssim": ssim(img, ref)}
    n = len(per_view)
    return {
        "psnr": sum(r["psnr"] for r in per_view.values()) / n if n else None,
        "ssim": sum(r["ssim"] for r in per_view.values()) / n if n else None,
        "num_views": n,
        "per_view": per_view,
    }
