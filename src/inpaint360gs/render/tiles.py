"""Compositing constants and tile binning shared by the rasterizer backends.

The constants are those of the original 3DGS CUDA rasterizer; every backend uses the same values
and the same tile rule, so their images agree up to rounding. Binning: a Gaussian goes into every
16x16 tile that its 3-sigma bounding square [u-r, u+r] x [v-r, v+r] touches (tile k covers pixels
[16k, 16k+16)); each tile's list is in front-to-back order (stable sort by depth, ties by index).
"""

from __future__ import annotations

from dataclasses import dataclass

import torch

TILE = 16  # tile side in pixels (3DGS BLOCK_X/BLOCK_Y)
ALPHA_MIN = 1.0 / 255.0  # a Gaussian with alpha below this is skipped at a pixel
ALPHA_MAX = 0.99  # alpha is clamped to this, so 1 - alpha never vanishes
T_MIN = 1e-4  # a pixel stops when its transmittance would drop below this (that Gaussian not added)


def tile_grid(width: int, height: int) -> tuple[int, int]:
    """Number of tiles along x and y."""
    return (width + TILE - 1) // TILE, (height + TILE - 1) // TILE


@dataclass
class Bins:
    """Tile/Gaussian intersections sorted by (tile, depth)."""

    gauss_ids: torch.Tensor  # (I,) int64 Gaussian index of each intersection
    tile_ids: torch.Tensor  # (I,) int64 tile index (ty * tiles_x + tx)
    offsets: torch.Tensor  # (n_tiles + 1,) int64, tile t owns intersections offsets[t]:offsets[t+1]


def tile_rects(means2d: torch.Tensor, radii: torch.Tensor, tiles_x: int, tiles_y: int) -> torch.Tensor:
    """Inclusive tile ranges (N, 4) = (x0, x1, y0, y1) touched by each Gaussian; empty when x1 < x0 or y1 < y0."""
    m = means2d.detach()
    r = radii.to(m.dtype)
    # clamp first to [-1, tiles] so huge or infinite coordinates convert to int safely
    x0 = torch.floor((m[:, 0] - r) / TILE).clamp(0, tiles_x)
    x1 = torch.floor((m[:, 0] + r) / TILE).clamp(-1, tiles_x - 1)
    y0 = torch.floor((m[:, 1] - r) / TILE).clamp(0, tiles_y)
    y1 = torch.floor((m[:, 1] + r) / TILE).clamp(-1, tiles_y - 1)
    rect = torch.stack([x0, x1, y0, y1], dim=-1).to(torch.int64)
    culled = (radii <= 0) | (rect[:, 1] < rect[:, 0]) | (rect[:, 3] < rect[:, 2]) | ~torch.isfinite(m).all(-1)
    rect[culled] = torch.tensor([0, -1, 0, -1], device=rect.device)
    return rect


def bin_gaussians(means2d: torch.Tensor, radii: torch.Tensor, depths: torch.Tensor, width: int, height: int) -> Bins:
    """Intersections of Gaussians with tiles, sorted by tile then depth (torch; any device)."""
    tiles_x, tiles_y = tile_grid(width, height)
    n_tiles = tiles_x * tiles_y
    dev = means2d.device
    rect = tile_rects(means2d, radii, tiles_x, tiles_y)
    nx = rect[:, 1] - rect[:, 0] + 1
    ny = rect[:, 3] - rect[:, 2] + 1
    counts = nx * ny  # 0 for culled Gaussians (nx == 0)
    n = counts.shape[0]
    gauss_ids = torch.repeat_interleave(torch.arange(n, device=dev), counts)
    first = torch.cumsum(counts, 0) - counts
    local = torch.arange(gauss_ids.shape[0], device=dev) - first[gauss_ids]
    tx = rect[gauss_ids, 0] + local % nx[gauss_ids]
    ty = rect[gauss_ids, 2] + local // nx[gauss_ids]
    tile_ids = ty * tiles_x + tx
    depth_rank = torch.empty(n, dtype=torch.int64, device=dev)
    depth_rank[torch.argsort(depths.detach(), stable=True)] = torch.arange(n, device=dev)
    order = torch.argsort(tile_ids * max(n, 1) + depth_rank[gauss_ids])
    tile_ids, gauss_ids = tile_ids[order], gauss_ids[order]
    per_tile = torch.bincount(tile_ids, minlength=n_tiles)
    offsets = torch.zeros(n_tiles + 1, dtype=torch.int64, device=dev)
    offsets[1:] = torch.cumsum(per_tile, 0)
    return Bins(gauss_ids=gauss_ids, tile_ids=tile_ids, offsets=offsets)
