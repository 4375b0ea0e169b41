"""Tile rasterizer in plain torch: any device, any dtype, autograd backward; the float64 reference.

Tiles are processed in batches: each tile's depth-sorted list is padded to the batch's longest,
alphas are computed for 256 pixels x L Gaussians at once and the transmittance is a cumulative
product. The compositing rules are the CUDA rasterizer's (see :mod:`inpaint360gs.render.tiles`);
the early stop "T would drop below 1e-4" becomes a mask on the inclusive cumulative product.
"""

from __future__ import annotations

import torch

from inpaint360gs.render.backends import RasterizerBackend, Splats
from inpaint360gs.render.tiles import ALPHA_MAX, ALPHA_MIN, T_MIN, TILE, bin_gaussians, tile_grid

# elements (tiles x 256 pixels x Gaussians) per batch: bounds the forward's temporaries (~16 MB each at float32)
DEFAULT_CHUNK_ELEMS = 1 << 22


def _add_abs(into: torch.Tensor, ids: torch.Tensor):
    """A gradient hook on per-pixel offsets (B, 256, L) that adds their absolute values per Gaussian into ``into``."""

    def hook(grad: torch.Tensor) -> None:
        into.index_add_(0, ids, grad.detach().abs().sum(1).flatten().to(into.dtype))

    return hook


def rasterize_to_pixels_torch(splats: Splats, channels: torch.Tensor, chunk_elems: int = DEFAULT_CHUNK_ELEMS) -> tuple[torch.Tensor, torch.Tensor]:
    """Alpha-composite per-Gaussian ``channels`` (N, C) front to back -> ((H, W, C) sums of c*alpha*T, (H, W) alpha)."""
    means2d, conics, opacities, radii, depths = splats.means2d, splats.conics, splats.opacities, splats.radii, splats.depths
    width, height = splats.width, splats.height
    dev, dt = means2d.device, means2d.dtype
    C = channels.shape[1]
    tiles_x, tiles_y = tile_grid(width, height)
    n_tiles = tiles_x * tiles_y
    bins = bin_gaussians(means2d, radii, depths, width, height)
    counts = bins.offsets[1:] - bins.offsets[:-1]
    busy = torch.nonzero(counts > 0).flatten()
    busy = busy[torch.argsort(counts[busy], stable=True)]  # similar lengths share a batch: little padding
    busy_counts = counts[busy].tolist()

    local = torch.arange(TILE * TILE, device=dev)
    px_local = (local % TILE).to(dt) + 0.5  # pixel centres, see camera.py
    py_local = (local // TILE).to(dt) + 0.5

    tile_vals, tile_alpha, tile_index = [], [], []
    # AbsGS's statistic (gs/strategy.py): the per-pixel gradients of each centre, summed as absolute
    # values, gathered by hooks on the per-pixel offsets and left on ``means2d.absgrad``
    absgrad = None
    if splats.absgrad and means2d.requires_grad:
        absgrad = torch.zeros(means2d.shape, dtype=means2d.dtype, device=dev)
        means2d.absgrad = absgrad
    start = 0
    while start < len(busy_counts):
        # grow the batch while its padded size stays within the budget (counts ascend, so the last is the longest)
        stop = start + 1
        while stop < len(busy_counts) and (stop + 1 - start) * busy_counts[stop] * TILE * TILE <= chunk_elems:
            stop += 1
        tiles = busy[start:stop]
        length = busy_counts[stop - 1]
        slot = torch.arange(length, device=dev)
        idx = bins.offsets[tiles][:, None] + slot
        in_list = slot[None, :] < counts[tiles][:, None]  # (B, L)
        g = bins.gauss_ids[torch.where(in_list, idx, bins.offsets[tiles][:, None])]  # padding -> any real id

        px = (tiles % tiles_x * TILE).to(dt)[:, None] + px_local  # (B, 256)
        py = (tiles // tiles_x * TILE).to(dt)[:, None] + py_local
        dx = means2d[g, 0][:, None, :] - px[:, :, None]  # (B, 256, L)
        dy = means2d[g, 1][:, None, :] - py[:, :, None]
        if absgrad is not None:
            ids = g.flatten()
            dx.register_hook(_add_abs(absgrad[:, 0], ids))
            dy.register_hook(_add_abs(absgrad[:, 1], ids))
        con = conics[g]
        power = -0.5 * (con[:, None, :, 0] * dx * dx + con[:, None, :, 2] * dy * dy) - con[:, None, :, 1] * dx * dy
        alpha = torch.clamp(opacities[g][:, None, :] * torch.exp(power), max=ALPHA_MAX)
        valid = in_list[:, None, :] & (power <= 0) & (alpha >= ALPHA_MIN)
        alpha = torch.where(valid, alpha, torch.zeros_like(alpha))
        one_minus = 1.0 - alpha
        t_incl = torch.cumprod(one_minus, dim=-1)
        # the Gaussian that would take T below T_MIN ends the pixel and is not added; all later ones
        # then also have t_incl < T_MIN, so one mask expresses the CUDA early stop
        contrib = valid & (t_incl >= T_MIN)
        t_excl = torch.cat([torch.ones_like(t_incl[..., :1]), t_incl[..., :-1]], dim=-1)
        weight = torch.where(contrib, alpha * t_excl, torch.zeros_like(alpha))
        tile_vals.append(torch.bmm(weight, channels[g]))  # (B, 256, C)
        t_final = torch.prod(torch.where(contrib, one_minus, torch.ones_like(one_minus)), dim=-1)
        tile_alpha.append(1.0 - t_final)
        tile_index.append(tiles)
        start = stop

    vals = torch.zeros(n_tiles, TILE * TILE, C, device=dev, dtype=channels.dtype)
    alph = torch.zeros(n_tiles, TILE * TILE, device=dev, dtype=dt)
    if tile_index:
        ids = torch.cat(tile_index)
        vals = vals.index_copy(0, ids, torch.cat(tile_vals).to(vals.dtype))
        alph = alph.index_copy(0, ids, torch.cat(tile_alpha))
    else:  # nothing visible: keep the outputs attached to the graph (all-zero gradients) so backward() works
        anchor = sum(t[:0].sum() for t in (means2d, conics, opacities, channels) if t.requires_grad)
        vals, alph = vals + anchor, alph + anchor
    image = vals.reshape(tiles_y, tiles_x, TILE, TILE, C).permute(0, 2, 1, 3, 4).reshape(tiles_y * TILE, tiles_x * TILE, C)
    alpha_img = alph.reshape(tiles_y, tiles_x, TILE, TILE).permute(0, 2, 1, 3).reshape(tiles_y * TILE, tiles_x * TILE)
    return image[:height, :width], alpha_img[:height, :width]


class TorchBackend(RasterizerBackend):
    """Vectorised tiles in plain torch: any device and dtype, autograd backward; the float64 reference."""

    name = "torch"
    priority = 0
    device_type = "any"
    auto_dtypes = (torch.float16, torch.bfloat16, torch.float32, torch.float64)

    def available(self) -> bool:
        """Always True."""
        return True

    def rasterize(self, splats, channels):
        """See :meth:`RasterizerBackend.rasterize` (pure torch)."""
        return rasterize_to_pixels_torch(splats, channels)


BACKEND = TorchBackend()
