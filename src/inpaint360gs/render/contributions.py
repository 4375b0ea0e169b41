"""Per-pixel contributions: the exact (pixel, Gaussian, weight) list the rasterizer composites.

For a model and a camera, the forward pass of every backend computes one weight
``w_i(p) = alpha_i(p) T_i(p)`` per (pixel, Gaussian) it adds, and every rendered channel is
``sum_i w_i(p) c_i`` (colour Eq. 1, depth Eq. 5, identity features Eq. 3). :func:`contributions`
returns those weights as a sparse matrix W (pixels x Gaussians, CSR, rows ``y * width + x``, each
row front to back), so that with the geometry fixed, rendering any per-Gaussian channels is the
product ``W @ c`` (and its gradient w.r.t. the channels is ``W^T g``) without rasterizing again.
The distillation stage (Sec. 3.3) caches W per training view this way; removal and visibility ask
"how much of this pixel comes from these Gaussians" as ``W @ indicator``.

Two implementations, each matching its rasterizer backend: ``numba`` replays the forward kernel's
tile walk (:mod:`.numba_contrib`); ``torch`` (any device) the torch backend's batched tiles.
``min_weight`` drops entries with w below it; the rendered channels then lose exactly the dropped
terms (``|W c - W_pruned c| <= sum of the dropped w * max |c|``), which :attr:`Contributions.dropped`
bounds per pixel.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import torch

from inpaint360gs.core.camera import Camera
from inpaint360gs.core.errors import InputError
from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.render.backends import Splats, resolve_backend
from inpaint360gs.render.projection import project_gaussians
from inpaint360gs.render.tiles import ALPHA_MAX, ALPHA_MIN, T_MIN, TILE, bin_gaussians, tile_grid


@dataclass
class Contributions:
    """W in CSR form: row ``p = y * width + x`` holds ``cols[indptr[p]:indptr[p+1]]`` (Gaussian indices,
    front to back) with weights ``vals[...]`` = alpha T. Tensors on the CPU (numba) or the model's device (torch)."""

    indptr: torch.Tensor  # (H*W + 1,) int64
    cols: torch.Tensor  # (nnz,) int32 Gaussian index
    vals: torch.Tensor  # (nnz,) weight alpha * T: float32 (numba), the model's dtype (torch)
    width: int
    height: int
    num_gaussians: int
    dropped: torch.Tensor | None = None  # (H, W) sum of the weights dropped by min_weight (None: nothing dropped)

    @property
    def nnz(self) -> int:
        """Number of stored (pixel, Gaussian) weights."""
        return int(self.cols.shape[0])

    @property
    def nbytes(self) -> int:
        """Bytes held by the sparse arrays."""
        return sum(t.element_size() * t.numel() for t in (self.indptr, self.cols, self.vals))

    def rows(self) -> torch.Tensor:
        """(nnz,) pixel index of every entry."""
        counts = self.indptr[1:] - self.indptr[:-1]
        return torch.repeat_interleave(torch.arange(self.height * self.width, device=self.indptr.device), counts)

    def alpha(self) -> torch.Tensor:
        """(H, W) sum of the weights: the rendered alpha 1 - T_final (minus what was dropped)."""
        return self.render(torch.ones(self.num_gaussians, 1, device=self.vals.device, dtype=self.vals.dtype))[..., 0]

    def matrix(self) -> torch.Tensor:
        """W as a torch sparse CSR tensor (H*W, N)."""
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", UserWarning)  # "sparse CSR support is in beta"
            return torch.sparse_csr_tensor(self.indptr, self.cols.long(), self.vals, (self.height * self.width, self.num_gaussians), check_invariants=False)

    def render(self, values: torch.Tensor) -> torch.Tensor:
        """(H, W, C) = W @ values for per-Gaussian ``values`` (N, C); not differentiable (see :func:`sparse_render`)."""
        return self.matmul(values).reshape(self.height, self.width, -1)

    def matmul(self, values: torch.Tensor) -> torch.Tensor:
        """(H*W, C) = W @ values, computed in the weights' dtype."""
        if values.ndim != 2 or values.shape[0] != self.num_gaussians:
            raise ValueError(f"values must have shape ({self.num_gaussians}, C), got {tuple(values.shape)}")
        x = values.detach().to(self.vals.dtype)
        if self._numba():
            from inpaint360gs.render.numba_contrib import csr_matmul

            return torch.from_numpy(csr_matmul(*self._numpy(), np.ascontiguousarray(x.numpy())))
        rows = self.rows()
        return torch.zeros(self.height * self.width, x.shape[1], device=x.device, dtype=x.dtype).index_add_(0, rows, self.vals[:, None] * x[self.cols.long()])

    def matmul_t(self, grad: torch.Tensor) -> torch.Tensor:
        """(N, C) = W^T @ grad for per-pixel ``grad`` (H*W, C), in the weights' dtype, summed in a fixed order
        (numba; torch's ``index_add_`` is deterministic on the CPU, not necessarily on CUDA)."""
        y = grad.detach().to(self.vals.dtype).reshape(self.height * self.width, -1)
        if self._numba():
            from inpaint360gs.render.numba_contrib import csr_matmul_t

            return torch.from_numpy(csr_matmul_t(*self._numpy(), np.ascontiguousarray(y.numpy()), self.num_gaussians))
        out = torch.zeros(self.num_gaussians, y.shape[1], device=y.device, dtype=y.dtype)
        return out.index_add_(0, self.cols.long(), self.vals[:, None] * y[self.rows()])

    def _numba(self) -> bool:
        return self.vals.device.type == "cpu" and self.vals.dtype == torch.float32

    def _numpy(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        return self.indptr.numpy(), self.cols.numpy(), self.vals.numpy()

    def per_gaussian_weight(self) -> torch.Tensor:
        """(N,) total weight of each Gaussian over the image (0: it adds to no pixel)."""
        return torch.zeros(self.num_gaussians, dtype=torch.float64, device=self.vals.device).index_add_(0, self.cols.long(), self.vals.double())


class _SparseRender(torch.autograd.Function):
    @staticmethod
    def forward(ctx, values, contrib: Contributions):
        ctx.contrib = contrib
        ctx.dtype = values.dtype
        return contrib.matmul(values).to(values.dtype)

    @staticmethod
    def backward(ctx, grad):
        return ctx.contrib.matmul_t(grad).to(ctx.dtype), None


def sparse_render(contrib: Contributions, values: torch.Tensor) -> torch.Tensor:
    """(H, W, C) = W @ values, differentiable w.r.t. ``values`` (backward: W^T g): rendering per-Gaussian
    channels with the geometry frozen, the same maths as rasterizing them (paper Eq. 3)."""
    return _SparseRender.apply(values, contrib).reshape(contrib.height, contrib.width, -1)


def _project(g: Gaussians, camera: Camera, backend: str, near: float, far: float, eps2d: float) -> Splats:
    """Splats exactly as :func:`render.api.render` projects them for ``backend`` (its fused kernel or the shared torch projection)."""
    dev, dt = g.means.device, g.means.dtype
    rasterizer = resolve_backend(backend, dev, dt)
    cam = camera.to(device=dev, dtype=dt)
    with torch.no_grad():
        fused = rasterizer.project_and_shade(g, g.sh0, cam, 0, near=near, far=far, eps2d=eps2d)
        if fused is not None:
            means2d, conics, depths, radii, _ = fused
        else:
            p = project_gaussians(g.means, g.quats, g.log_scales, cam, near=near, far=far, eps2d=eps2d)
            means2d, conics, depths, radii = p.means2d, p.conics, p.depths, p.radii
        opac = torch.sigmoid(g.opacity_logits)
    return Splats(means2d, conics, opac, radii, depths, cam.width, cam.height)


def contributions(
    gaussians: Gaussians,
    camera: Camera,
    *,
    backend: str = "auto",
    min_weight: float = 0.0,
    near: float = 0.01,
    far: float = 1e10,
    eps2d: float = 0.3,
) -> Contributions:
    """The weights ``alpha T`` that ``render(gaussians, camera, backend=backend)`` composites, as CSR.

    ``backend``: "numba" replays the numba kernels (CPU); "torch" the torch backend (any device);
    "auto" and other names use numba for CPU float32 models, torch otherwise (gsplat shares the torch
    projection and the compositing rules, so its weights agree up to its own rounding). Entries
    with weight below ``min_weight`` are dropped (their sum per pixel is kept in ``dropped``).
    """
    if not (min_weight >= 0.0 and np.isfinite(min_weight)):
        raise InputError(f"min_weight must be finite and >= 0, got {min_weight}", "min_weight")
    dev = gaussians.means.device
    use_numba = backend == "numba" or (backend not in ("numba", "torch") and dev.type == "cpu" and gaussians.means.dtype == torch.float32)
    splats = _project(gaussians, camera, "numba" if use_numba else "torch", near, far, eps2d)
    if use_numba:
        return _contributions_numba(splats, len(gaussians), min_weight)
    return _contributions_torch(splats, len(gaussians), min_weight)


def _contributions_numba(s: Splats, n: int, min_weight: float) -> Contributions:
    import numba

    from inpaint360gs.render import numba_contrib as NC
    from inpaint360gs.render.numba_arrays import set_numba_threads
    from inpaint360gs.render.numba_backend import prepare

    set_numba_threads()
    pk, offsets, gids, order, tiles_x = prepare(s.means2d, s.conics, s.opacities, s.radii, s.depths, s.width, s.height)
    args = (pk, offsets, gids, order, numba.get_num_threads(), s.width, s.height, tiles_x)
    starts = np.concatenate([[0], np.cumsum(NC.tile_counts(*args))]).astype(np.int64)
    pix, gid, wts = NC.tile_fill(*args, starts, int(starts[-1]))
    dropped = None
    if min_weight > 0:
        small = wts < np.float32(min_weight)
        dropped = torch.from_numpy(np.bincount(pix[small], weights=wts[small], minlength=s.width * s.height).astype(np.float32).reshape(s.height, s.width))
        pix, gid, wts = pix[~small], gid[~small], wts[~small]
    indptr, cols, vals = NC.to_csr(pix, gid, wts, s.width * s.height)
    t = torch.from_numpy
    return Contributions(t(indptr), t(cols), t(vals), s.width, s.height, n, dropped)


def _contributions_torch(s: Splats, n: int, min_weight: float) -> Contributions:
    """The torch backend's batched tiles (:mod:`.torch_backend`), keeping the weights instead of summing them."""
    dev, dt = s.means2d.device, s.means2d.dtype
    tiles_x, _ = tile_grid(s.width, s.height)
    bins = bin_gaussians(s.means2d, s.radii, s.depths, s.width, s.height)
    counts = (bins.offsets[1:] - bins.offsets[:-1]).tolist()
    local = torch.arange(TILE * TILE, device=dev)
    pix_l, gid_l, w_l, drop_l = [], [], [], []
    for t in [i for i, c in enumerate(counts) if c > 0]:
        start, length = int(bins.offsets[t]), counts[t]
        g = bins.gauss_ids[start : start + length]
        px = (t % tiles_x) * TILE + (local % TILE)
        py = (t // tiles_x) * TILE + (local // TILE)
        dx = s.means2d[g, 0][None, :] - (px.to(dt)[:, None] + 0.5)  # (256, L); pixel centres, see camera.py
        dy = s.means2d[g, 1][None, :] - (py.to(dt)[:, None] + 0.5)
        con = s.conics[g]
        power = -0.5 * (con[None, :, 0] * dx * dx + con[None, :, 2] * dy * dy) - con[None, :, 1] * dx * dy
        alpha = torch.clamp(s.opacities[g][None, :] * torch.exp(power), max=ALPHA_MAX)
        valid = (power <= 0) & (alpha >= ALPHA_MIN) & ((px < s.width) & (py < s.height))[:, None]
        alpha = torch.where(valid, alpha, torch.zeros_like(alpha))
        t_incl = torch.cumprod(1.0 - alpha, dim=-1)
        contrib = valid & (t_incl >= T_MIN)  # the CUDA early stop as a mask (see torch_backend)
        t_excl = torch.cat([torch.ones_like(t_incl[:, :1]), t_incl[:, :-1]], dim=-1)
        weight = torch.where(contrib, alpha * t_excl, torch.zeros_like(alpha))
        keep = contrib & (weight >= min_weight)
        p_idx, k_idx = torch.nonzero(keep, as_tuple=True)
        pix_l.append(py[p_idx] * s.width + px[p_idx])
        gid_l.append(g[k_idx])
        w_l.append(weight[p_idx, k_idx])
        if min_weight > 0:
            lost = torch.where(contrib & ~keep, weight, torch.zeros_like(weight)).sum(-1)
            inside = (px < s.width) & (py < s.height)
            drop_l.append((py[inside] * s.width + px[inside], lost[inside]))
    P = s.width * s.height
    pix = torch.cat(pix_l) if pix_l else torch.zeros(0, dtype=torch.long, device=dev)
    gid = torch.cat(gid_l) if gid_l else torch.zeros(0, dtype=torch.long, device=dev)
    w = torch.cat(w_l) if w_l else torch.zeros(0, device=dev, dtype=dt)
    order = torch.argsort(pix, stable=True)  # by pixel; within a pixel the tile list's front-to-back order
    indptr = torch.zeros(P + 1, dtype=torch.int64, device=dev)
    indptr[1:] = torch.cumsum(torch.bincount(pix, minlength=P), 0)
    dropped = None
    if min_weight > 0:
        dropped = torch.zeros(P, device=dev, dtype=dt)
        for idx, lost in drop_l:
            dropped[idx] = lost
        dropped = dropped.reshape(s.height, s.width)
    return Contributions(indptr, gid[order].to(torch.int32), w[order], s.width, s.height, n, dropped)
