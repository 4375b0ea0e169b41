"""The fast CPU backend: numba kernels (:mod:`.numba_kernels`) wrapped as a ``torch.autograd.Function``.

Compiled kernels are cached on disk (see :mod:`.numba_cache`; the first compile takes a while).
Kernels run in float32 on ``min(torch.get_num_threads(), NUMBA_NUM_THREADS)`` threads, so torch
and numba never oversubscribe.
"""

from __future__ import annotations

import importlib.util

import numpy as np
import torch

from inpaint360gs.core.errors import InputError
from inpaint360gs.render.backends import RasterizerBackend, Splats
from inpaint360gs.render.numba_arrays import set_numba_threads, to_f32
from inpaint360gs.render.tiles import tile_grid


MAX_TILE_LIST = 1 << 24  # the kernels keep per-pixel "last contributor" as a float32 offset into the tile's list


def prepare(means2d, conics, opacities, radii, depths, width: int, height: int):
    """Pack Gaussians and bin them into tiles -> (packed (N, 8), offsets, gauss ids, tile order, tiles_x) (numpy)."""
    from inpaint360gs.render import numba_kernels as K

    m, q, o = to_f32(means2d), to_f32(conics), to_f32(opacities)
    tiles_x, tiles_y = tile_grid(width, height)
    r = np.ascontiguousarray(radii.detach().cpu().numpy(), dtype=np.int32)
    offsets, gids = K.bin_gaussians(m, r, to_f32(depths), tiles_x, tiles_y)
    counts = np.diff(offsets)
    if counts.size and int(counts.max()) >= MAX_TILE_LIST:
        raise InputError(f"more than {MAX_TILE_LIST} Gaussians overlap one 16x16 tile", "gaussians")
    order = np.argsort(-counts, kind="stable")[: int(np.count_nonzero(counts))]  # busy tiles, longest first
    return K.pack(m, q, o), offsets, gids, order, tiles_x


class _RasterizeNumba(torch.autograd.Function):
    @staticmethod
    def forward(ctx, means2d, conics, opacities, channels, radii, depths, width: int, height: int, absgrad: bool):
        import numba

        from inpaint360gs.render import numba_kernels as K

        set_numba_threads()
        pk, offsets, gids, order, tiles_x = prepare(means2d, conics, opacities, radii, depths, width, height)
        ch = to_f32(channels)
        workers = numba.get_num_threads()
        img, t_final, last, _ = K.forward(pk, ch, offsets, gids, order, workers, width, height, tiles_x)
        ctx.state = (pk, ch, offsets, gids, order, width, height, tiles_x, t_final, last)
        ctx.dtypes = (means2d.dtype, conics.dtype, opacities.dtype, channels.dtype)
        ctx.absgrad = absgrad
        if absgrad:
            ctx.save_for_backward(means2d)  # the caller's tensor: backward hangs ``absgrad`` on it
        return torch.from_numpy(img).to(channels.dtype), torch.from_numpy(1.0 - t_final).to(means2d.dtype)

    @staticmethod
    def backward(ctx, d_img, d_alpha):
        import numba

        from inpaint360gs.render import numba_kernels as K

        set_numba_threads()
        pk, ch, offsets, gids, order, width, height, tiles_x, t_final, last = ctx.state
        d_img = np.zeros((height, width, ch.shape[1]), np.float32) if d_img is None else to_f32(d_img)
        d_alpha = np.zeros((height, width), np.float32) if d_alpha is None else to_f32(d_alpha)
        workers = numba.get_num_threads()
        rows = K.backward(pk, ch, offsets, gids, order, workers, width, height, tiles_x, t_final, last, d_img, d_alpha, ctx.absgrad)
        g = torch.from_numpy(K.reduce_rows(rows, gids, pk.shape[0]))
        dm, dq, do, dc = ctx.dtypes
        C = ch.shape[1]
        if ctx.absgrad:
            (means2d,) = ctx.saved_tensors
            means2d.absgrad = g[:, 6 + C : 8 + C].to(dm)  # sum over pixels of |dL/dmean2d| (gsplat's ``absgrad``)
        return g[:, 0:2].to(dm), g[:, 2:5].to(dq), g[:, 5].to(do), g[:, 6 : 6 + C].to(dc), None, None, None, None, None


def rasterize_to_pixels_numba(splats: Splats, channels: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Composite (N, C) channels -> ((H, W, C), (H, W) alpha) with the numba kernels (CPU, float32 internally)."""
    s = splats
    if s.means2d.device.type != "cpu":
        raise InputError(f"the numba backend needs CPU tensors, got {s.means2d.device}", "backend")
    if s.opacities.numel() and not bool(((s.opacities >= 0) & (s.opacities <= 1)).all()):
        raise InputError("opacities must lie in [0, 1] (the fast exp relies on it)", "opacities")
    return _RasterizeNumba.apply(s.means2d, s.conics, s.opacities, channels, s.radii, s.depths, s.width, s.height, s.absgrad)


class NumbaBackend(RasterizerBackend):
    """Hand-written CPU tile kernels (numba), with a fused projection + SH kernel pair."""

    name = "numba"
    priority = 10
    device_type = "cpu"

    def available(self) -> bool:
        """True when numba imports."""
        return importlib.util.find_spec("numba") is not None

    def rasterize(self, splats, channels):
        """See :meth:`RasterizerBackend.rasterize` (numba CPU kernels)."""
        return rasterize_to_pixels_numba(splats, channels)

    def project_and_shade(self, gaussians, sh, camera, degree, *, near, far, eps2d):
        """See :meth:`RasterizerBackend.project_and_shade` (fused numba CPU kernels)."""
        # the same maths as projection.py + sh.py in one fused CPU kernel pair (why: numba_projection.py)
        from inpaint360gs.render.numba_projection import project_and_shade_numba

        g = gaussians
        return project_and_shade_numba(g.means, g.quats, g.log_scales, sh, camera, degree, near=near, far=far, eps2d=eps2d)


BACKEND = NumbaBackend()
