"""Numba kernels that list what the forward rasterizer composites: every (pixel, Gaussian, w = alpha T).

The tile walk is the forward kernel's own (:func:`.numba_kernels._forward_tile`: same binning,
same depth order, same row ranges, and its per-Gaussian pixel loop :func:`._fwd_gaussian`, which
computes alpha with the same polynomial exp, the 0.99 clamp, the 1/255 skip and the T < 1e-4 stop),
so the weights are the ones the forward pass multiplies channels by, and ``sum_i w_i c_i`` equals
the rendered channel up to float rounding. Two passes over the tiles: count the contributions of
each tile, then fill them at the tile's offset; both parallel over tiles as in the forward kernel,
and built like it for cold/warm-cache reproducibility (the tile walk inlined, one ``nogil`` worker
kernel per Python thread, no ``prange``: see the :mod:`.numba_kernels` docstring; with a fast-math
helper called from a ``prange`` body, the distillation run that compiled the kernels and one that
loaded them from the cache gave different bits).
The result comes in (tile, depth, pixel) order; :func:`to_csr` regroups it by pixel with a stable
counting sort, so each pixel's entries stay front to back.

Everything lives in this module rather than in :mod:`.numba_kernels`, which it only imports.
"""

from __future__ import annotations

import numpy as np

import inpaint360gs.render.numba_cache  # noqa: F401  (sets the cache folder before the kernels are defined)
from numba import njit, prange  # isort: skip

from inpaint360gs.render.numba_kernels import _F_ROWS, _F_W, _OPTS, NPIX, U, _fwd_gaussian, _row_range, _run_workers, _start_forward_tile
from inpaint360gs.render.tiles import TILE

f32 = np.float32
_ZERO = f32(0.0)
_U16 = U(16)


@njit(inline="always", **_OPTS)
def _walk_tile(t, st, pk, offsets, gids, width, height, tiles_x, fill, start, pix_out, gid_out, w_out):
    """Walk tile ``t`` front to back (the forward kernel's loop); count its contributions or, with
    ``fill``, write them from index ``start``. Returns the count."""
    s, e = offsets[t], offsets[t + 1]
    x_base, y_base, xb, yb, n_alive = _start_forward_tile(t, st, width, height, tiles_x)
    n = 0
    k = s
    while k < e and n_alive > 0:
        g = gids[k]
        mx, my, ca, cb, cc, o, ext = pk[g, 0], pk[g, 1], pk[g, 2], pk[g, 3], pk[g, 4], pk[g, 5], pk[g, 6]
        kr = f32(k - s)
        k += 1
        r0, r1 = _row_range(my, ext, yb)
        if ext < _ZERO or r1 < r0:
            continue
        lo, hi = U(r0) * _U16, U(r1 + 1) * _U16
        n_stop, n_add = _fwd_gaussian(st, lo, hi, mx, my, ca, cb, cc, o, xb, yb, kr)
        n_alive -= n_stop
        if n_add == 0:
            continue
        for p in range(lo, hi):
            w = st[_F_W + p]
            if w > _ZERO:  # exactly where the Gaussian was added
                if fill:
                    pix_out[start + n] = (y_base + int(p) // TILE) * width + x_base + int(p) % TILE
                    gid_out[start + n] = g
                    w_out[start + n] = w
                n += 1
    return n


@njit(nogil=True, **_OPTS)
def _count_worker(w, n_workers, pk, offsets, gids, order, width, height, tiles_x, counts):
    st = np.empty(_F_ROWS * NPIX, np.float32)
    dummy_i = np.zeros(0, np.int32)
    dummy_f = np.zeros(0, np.float32)
    for j in range(w, order.shape[0], n_workers):
        t = order[j]
        counts[t] = _walk_tile(t, st, pk, offsets, gids, width, height, tiles_x, False, 0, dummy_i, dummy_i, dummy_f)


@njit(nogil=True, **_OPTS)
def _fill_worker(w, n_workers, pk, offsets, gids, order, width, height, tiles_x, starts, pix, gid, wts):
    st = np.empty(_F_ROWS * NPIX, np.float32)
    for j in range(w, order.shape[0], n_workers):
        t = order[j]
        _walk_tile(t, st, pk, offsets, gids, width, height, tiles_x, True, starts[t], pix, gid, wts)


def tile_counts(pk, offsets, gids, order, n_workers, width, height, tiles_x):
    """Pass 1: contributions per tile (n_tiles,), tiles dealt to workers as in the forward kernel."""
    counts = np.zeros(offsets.shape[0] - 1, np.int64)
    _run_workers(_count_worker, n_workers, (pk, offsets, gids, order, width, height, tiles_x, counts))
    return counts


def tile_fill(pk, offsets, gids, order, n_workers, width, height, tiles_x, starts, nnz):
    """Pass 2: (pixel (nnz,) int32, Gaussian (nnz,) int32, weight (nnz,) float32), tile t's entries from starts[t]."""
    pix = np.empty(nnz, np.int32)
    gid = np.empty(nnz, np.int32)
    wts = np.empty(nnz, np.float32)
    _run_workers(_fill_worker, n_workers, (pk, offsets, gids, order, width, height, tiles_x, starts, pix, gid, wts))
    return pix, gid, wts


@njit(cache=True)
def to_csr(pix, gid, wts, n_pixels):
    """Stable counting sort by pixel -> (indptr (P+1,) int64, Gaussian (nnz,) int32, weight (nnz,) float32)."""
    indptr = np.zeros(n_pixels + 1, np.int64)
    for k in range(pix.shape[0]):
        indptr[pix[k] + 1] += 1
    for p in range(n_pixels):
        indptr[p + 1] += indptr[p]
    fill = indptr[:-1].copy()
    cols = np.empty(pix.shape[0], np.int32)
    vals = np.empty(pix.shape[0], np.float32)
    for k in range(pix.shape[0]):
        p = pix[k]
        cols[fill[p]] = gid[k]
        vals[fill[p]] = wts[k]
        fill[p] += 1
    return indptr, cols, vals


@njit(parallel=True, cache=True, error_model="numpy")
def csr_matmul(indptr, cols, vals, x):
    """(P, C) = W x for W in CSR, each row summed front to back in float32 (the forward kernel's order)."""
    n_rows = indptr.shape[0] - 1
    C = x.shape[1]
    out = np.zeros((n_rows, C), np.float32)
    for r in prange(n_rows):
        for k in range(indptr[r], indptr[r + 1]):
            w = vals[k]
            g = cols[k]
            for c in range(C):
                out[r, c] += w * x[g, c]
    return out


@njit(cache=True, error_model="numpy")
def csr_matmul_t(indptr, cols, vals, y, n_cols):
    """(N, C) = W^T y for W in CSR: one thread, rows in order, so the sums are the same on every run."""
    C = y.shape[1]
    out = np.zeros((n_cols, C), np.float32)
    for r in range(indptr.shape[0] - 1):
        for k in range(indptr[r], indptr[r + 1]):
            w = vals[k]
            g = cols[k]
            for c in range(C):
                out[g, c] += w * y[r, c]
    return out
