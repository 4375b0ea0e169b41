"""Rendering identity features with the geometry frozen: a cached sparse product (paper Sec. 3.3, Eq. 3).

During distillation only the features f and Phi train; every Gaussian's position, shape, opacity
and depth order stay fixed, so the compositing weights w = alpha T of each training view never
change. They are computed once per view (:func:`inpaint360gs.render.contributions.contributions`,
the rasterizer's own weights) and each step renders ``F = W f`` with backward ``W^T g``: the same
maths as rasterizing the features every step, without repeating projection, sorting and alpha.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import torch

from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.gs.loop import Target
from inpaint360gs.render.api import RenderOutput
from inpaint360gs.render.contributions import Contributions, sparse_render


def spatial_order(means: torch.Tensor, bits: int = 10) -> torch.Tensor:
    """Permutation sorting the Gaussians along a Morton (Z-order) curve of their centres (``bits`` per
    axis over the bounding box; ties keep index order), so that neighbours in space are near in memory."""
    m = means.detach().cpu().double()
    lo, hi = m.min(0).values, m.max(0).values
    q = ((m - lo) / (hi - lo).clamp_min(1e-12) * (2**bits - 1)).round().long()
    code = torch.zeros(len(m), dtype=torch.long)
    for b in range(bits):
        for axis in range(3):
            code |= ((q[:, axis] >> b) & 1) << (3 * b + axis)
    return torch.argsort(code, stable=True).to(means.device)


@dataclass
class FeatureRender(RenderOutput):
    """A cached feature render: ``features`` (H, W, F) and ``alpha`` are the rasterizer's; colour, depth
    and the per-Gaussian projection are not computed (empty tensors)."""

    gaussian_features: torch.Tensor | None = None  # (N, F) the live features that were rendered
    knn_rows: torch.Tensor | None = None  # Gaussians the spatial loss is evaluated on this step (None: all)


class CachedFeatureRenderer:
    """``render_fn`` of :class:`~inpaint360gs.gs.loop.OptimizationLoop` over cached weights, one
    :class:`Contributions` per view name. Draws this step's spatial-loss sample from the loop's generator."""

    def __init__(self, cache: Mapping[str, Contributions], knn_sample: int = 0):
        self.cache = dict(cache)
        self.knn_sample = knn_sample
        self.alpha = {k: c.alpha() for k, c in self.cache.items()}

    def __call__(self, gaussians: Gaussians, target: Target, step: int, generator: torch.Generator) -> FeatureRender:
        c = self.cache[target.name]
        f = gaussians.features
        n = f.shape[0]
        rows = None
        if 0 < self.knn_sample < n:
            rows = torch.randint(0, n, (self.knn_sample,), generator=generator).to(f.device)
        empty = torch.zeros(0, device=f.device)
        return FeatureRender(
            color=empty, depth=empty, alpha=self.alpha[target.name], features=sparse_render(c, f),
            means2d=empty, radii=empty, depths=empty, gaussian_features=f, knn_rows=rows,
        )  # fmt: skip
