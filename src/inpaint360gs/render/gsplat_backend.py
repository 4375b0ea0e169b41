"""CUDA backend: gsplat's tile binning and rasterize-to-pixels after our projection and SH (torch, on the GPU).

gsplat's CUDA rasterizer follows the same compositing rules as the original 3DGS kernels (alpha
clamp 0.99, skip below 1/255, stop at T < 1e-4), and takes any number of channels, so depth
(Eq. 5, sum z a T, "RGB+D"-style, not divided by alpha) and the object features ride along as
extra channels of one call. Imported lazily: only ``render(..., backend="gsplat")`` needs gsplat.
Handles both radius layouts of gsplat's ``isect_tiles`` ((C, N) up to 1.4, (C, N, 2) after).
"""

from __future__ import annotations

import importlib.util

import torch

from inpaint360gs.render.backends import RasterizerBackend, Splats
from inpaint360gs.render.tiles import TILE, tile_grid


def _isect_tiles(gsplat, means2d, radii, depths, tiles_x, tiles_y):
    r = radii.to(torch.int32)[None]
    try:  # gsplat >= 1.5: per-axis radii (C, N, 2)
        return gsplat.isect_tiles(means2d[None], r[..., None].expand(*r.shape, 2).contiguous(), depths[None], TILE, tiles_x, tiles_y)
    except (AssertionError, RuntimeError, TypeError, ValueError):  # older: (C, N)
        return gsplat.isect_tiles(means2d[None], r, depths[None], TILE, tiles_x, tiles_y)


def rasterize_to_pixels_gsplat(splats: Splats, channels: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Composite (N, C) channels with gsplat's CUDA kernels -> ((H, W, C), (H, W) alpha)."""
    import gsplat

    means2d, conics, opacities, radii, depths = splats.means2d, splats.conics, splats.opacities, splats.radii, splats.depths
    width, height = splats.width, splats.height
    tiles_x, tiles_y = tile_grid(width, height)
    _, isect_ids, flatten_ids = _isect_tiles(gsplat, means2d.detach(), radii, depths.detach(), tiles_x, tiles_y)
    offsets = gsplat.isect_offset_encode(isect_ids, 1, tiles_x, tiles_y)
    batched = means2d[None].contiguous()
    absgrad = splats.absgrad and means2d.requires_grad
    if absgrad:  # gsplat leaves AbsGS's statistic on the tensor it got; hand it on to ours (gs/strategy.py)
        batched.register_hook(lambda _grad: setattr(means2d, "absgrad", batched.absgrad[0]) if hasattr(batched, "absgrad") else None)
    img, alpha = gsplat.rasterize_to_pixels(
        batched, conics[None].contiguous(), channels[None].contiguous(), opacities[None].contiguous(),
        width, height, TILE, offsets, flatten_ids, absgrad=absgrad,
    )  # fmt: skip
    return img[0], alpha[0, ..., 0]


class GsplatBackend(RasterizerBackend):
    """gsplat's CUDA kernels (needs a CUDA build of torch and the ``gpu`` extra)."""

    name = "gsplat"
    priority = 20
    device_type = "cuda"

    def available(self) -> bool:
        """True when gsplat imports and CUDA is available."""
        return importlib.util.find_spec("gsplat") is not None and torch.cuda.is_available()

    def rasterize(self, splats, channels):
        """See :meth:`RasterizerBackend.rasterize` (gsplat's CUDA kernels)."""
        return rasterize_to_pixels_gsplat(splats, channels)


BACKEND = GsplatBackend()
