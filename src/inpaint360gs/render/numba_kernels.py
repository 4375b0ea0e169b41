"""Hand-written CPU kernels of the tile rasterizer (numba): packing, binning, forward, backward, reduction.

Written by hand because no library offers a CPU Gaussian rasterizer with a backward pass. The
algorithm is the original 3DGS CUDA one (front-to-back with early stop; back-to-front backward
that recomputes alpha and T, with the "colour accumulated behind" trick). The loop structure is
chosen for LLVM's vectoriser, which is what makes it fast:
- 16x16 tiles dealt round robin, longest list first, to one worker per thread; in a tile,
  Gaussians in the outer loop and pixels in a branch-free inner loop; a tile stops when all its
  pixels have;
- a Gaussian only visits the tile rows where its alpha can reach 1/255 (exact ellipse extent, made
  slightly conservative), a contiguous range of the row-major tile, so results equal a full scan;
- per-pixel state lives in one flat float32 array at fixed row offsets, indexed with unsigned ints:
  signed indices make numba emit negative-index wrap-around, which blocks vectorisation, and
  separate arrays need runtime alias checks;
- ``error_model="numpy"``: Python's ZeroDivisionError check, an early exit, blocks it too;
- each pass of the backward is its own small function (loop-local names reused across loops in
  one function turn into live-out values that the vectoriser rejects); numba inlines them, giving
  each inlined copy fresh names.
Gradients are summed per (tile, Gaussian) in a fixed order: deterministic for any thread count. All float32.

Every entry kernel (``bin_gaussians``, ``pack``, the forward and backward workers, ``reduce_rows``)
holds all of its floating-point code itself: the helpers are ``inline="always"`` and there is no
``prange``, so the process that compiles the kernels computes the same bits as the processes that
load them from the on-disk cache. (Numba compiles a called jitted function, or a ``prange`` body, as
a library of its own and links a copy into the caller, which LLVM optimises once more; with fastmath
the two copies round differently, and the JIT binds the call to whichever copy it loaded first.) So
forward and backward run one ``nogil`` worker kernel per thread on Python threads
(:func:`_run_workers`), and ``pack`` is serial. The projection kernels (:mod:`.numba_projection`)
keep ``prange``: without fastmath a re-optimised copy computes the same IEEE results.
``tests/render/test_numba_cold_warm.py`` checks both. Import through :mod:`.numba_backend` (it sets up the cache).
"""

from __future__ import annotations

import os
from concurrent.futures import ThreadPoolExecutor, wait

import numpy as np

import inpaint360gs.render.numba_cache  # noqa: F401  (sets the cache folder before the kernels are defined)
from numba import njit  # isort: skip

from inpaint360gs.render.tiles import ALPHA_MAX, ALPHA_MIN, T_MIN, TILE

f32 = np.float32
NPIX = TILE * TILE
_ZERO, _ONE, _HALF = f32(0.0), f32(1.0), f32(0.5)
_ALPHA_MIN, _ALPHA_MAX, _T_MIN = f32(ALPHA_MIN), f32(ALPHA_MAX), f32(T_MIN)
_INV_TILE = f32(1.0 / TILE)  # exact (power of two), so tile rects match the torch binning bit for bit

# exp(x) on [-6, 0] as p(x/8)^8 with p a degree-6 Chebyshev fit of exp on [-0.75, 0]: relative error
# 3e-8 in exact arithmetic, ~2e-6 after float32 rounding. Below -6 the value is not needed: with
# opacity <= 1, o*exp(-6) < 1/255, so the Gaussian is skipped either way (the rule of the CUDA code).
_EXP_LO = f32(-6.0)
_EXP_SCALE = f32(0.125)
_P0, _P1, _P2, _P3 = f32(1.0), f32(0.9999995827674866), f32(0.49999216198921204), f32(0.166606605052948)
_P4, _P5, _P6 = f32(0.04144344478845596), f32(0.007897733710706234), f32(0.0009497848222963512)

# fastmath without nnan/ninf: values are finite by construction, but the comparisons must stay exact
_FM = {"nsz", "contract", "reassoc", "arcp"}
_OPTS = {"fastmath": _FM, "error_model": "numpy", "cache": True}

U = np.uint64  # unsigned indices: no wrap-around code, see the module docstring
_U4, _U15, _U16, _UNPIX = U(4), U(15), U(16), U(NPIX)
_TAU_SCALE = f32(255.0)
_EXT_INFLATE, _EXT_PAD = f32(1.0001), f32(1e-3)  # margins that keep the row range conservative

# forward state rows: transmittance (negative = pixel stopped), weight a*T, last contributor (relative), then C accumulators
_F_T, _F_W, _F_L = U(0), U(NPIX), U(2 * NPIX)
_F_ROWS = 3
# backward state rows; channel c then owns rows _B_ROWS + 3c + (0: colour behind, 1: last colour, 2: dL/dpixel)
_B_T, _B_TFIN, _B_DTFIN, _B_LA, _B_L, _B_OK, _B_A, _B_G, _B_W, _B_DLA = (U(i * NPIX) for i in range(10))
_B_ROWS = 10


_pool: tuple[int, int, ThreadPoolExecutor] | None = None  # (pid that made it, size, pool); a forked child makes its own


def _run_workers(kernel, n_workers: int, args: tuple) -> None:
    """``kernel(w, n_workers, *args)`` for w = 0 .. n_workers-1 at once: w = 0 here, the others on pool threads.

    The kernels release the GIL and each worker writes only its own tiles, so the result does not depend
    on ``n_workers``. Python threads rather than ``prange``: see the module docstring.
    """
    global _pool
    if n_workers <= 1:
        kernel(0, 1, *args)
        return
    if _pool is None or _pool[0] != os.getpid() or _pool[1] < n_workers - 1:
        if _pool is not None and _pool[0] == os.getpid():
            _pool[2].shutdown(wait=False)
        _pool = (os.getpid(), n_workers - 1, ThreadPoolExecutor(max_workers=n_workers - 1, thread_name_prefix="numba-raster"))
    futures = [_pool[2].submit(kernel, w, n_workers, *args) for w in range(1, n_workers)]
    try:
        kernel(0, n_workers, *args)
    finally:
        wait(futures)  # never return (or raise) while a worker still writes into the outputs
    for f in futures:
        f.result()


@njit(inline="always", **_OPTS)
def _exp_neg(x):
    """exp(x) for x <= 0, accurate to ~2e-6 on [-6, 0] (polynomial: vectorises, unlike a libm call)."""
    y = max(min(x, _ZERO), _EXP_LO) * _EXP_SCALE
    p = ((((((_P6 * y + _P5) * y + _P4) * y + _P3) * y + _P2) * y + _P1) * y) + _P0
    p = p * p
    p = p * p
    return p * p


@njit(**_OPTS)
def bin_gaussians(means2d, radii, depths, tiles_x, tiles_y):
    """(offsets (n_tiles+1,), gauss ids (I,)) of tile intersections sorted by (tile, depth); rule of tiles.tile_rects."""
    n = means2d.shape[0]
    n_tiles = tiles_x * tiles_y
    rect = np.empty((n, 4), np.int64)
    counts = np.zeros(n_tiles + 1, np.int64)
    for i in range(n):
        r = f32(radii[i])
        mx, my = means2d[i, 0], means2d[i, 1]
        if radii[i] <= 0 or not (np.isfinite(mx) and np.isfinite(my)):
            rect[i, 0], rect[i, 1], rect[i, 2], rect[i, 3] = 0, -1, 0, -1
            continue
        x0 = int(min(max(np.floor((mx - r) * _INV_TILE), f32(0.0)), f32(tiles_x)))
        x1 = int(min(max(np.floor((mx + r) * _INV_TILE), f32(-1.0)), f32(tiles_x - 1)))
        y0 = int(min(max(np.floor((my - r) * _INV_TILE), f32(0.0)), f32(tiles_y)))
        y1 = int(min(max(np.floor((my + r) * _INV_TILE), f32(-1.0)), f32(tiles_y - 1)))
        rect[i, 0], rect[i, 1], rect[i, 2], rect[i, 3] = x0, x1, y0, y1
        for ty in range(y0, y1 + 1):
            for tx in range(x0, x1 + 1):
                counts[ty * tiles_x + tx + 1] += 1
    offsets = np.cumsum(counts)
    fill = offsets[:-1].copy()
    gids = np.empty(offsets[-1], np.int32)
    order = np.argsort(depths, kind="mergesort")  # stable: ties keep index order, like torch stable argsort
    for j in range(n):
        i = order[j]
        for ty in range(rect[i, 2], rect[i, 3] + 1):
            for tx in range(rect[i, 0], rect[i, 1] + 1):
                t = ty * tiles_x + tx
                gids[fill[t]] = i
                fill[t] += 1
    return offsets, gids


@njit(**_OPTS)
def pack(means2d, conics, opac):
    """Per-Gaussian (u, v, conic a, b, c, opacity, row extent, 0) in one cache-friendly (N, 8) array.

    The extent is the half-height of the ellipse where alpha = o*exp(-q/2) >= 1/255, i.e.
    q <= 2 ln(255 o), which is sqrt(2 ln(255 o) * cov_yy); -1 when the Gaussian can never reach 1/255.
    """
    n = means2d.shape[0]
    pk = np.empty((n, 8), np.float32)
    for i in range(n):
        a, b, c = conics[i, 0], conics[i, 1], conics[i, 2]
        o = opac[i]
        tau = f32(2.0) * np.log(_TAU_SCALE * o) if o > _ZERO else f32(-1.0)
        det = a * c - b * b  # the conic's determinant; cov_yy = a / det
        ext = np.sqrt(tau * a / det) * _EXT_INFLATE + _EXT_PAD if (tau > _ZERO and det > _ZERO and a > _ZERO) else f32(-1.0)
        pk[i, 0], pk[i, 1], pk[i, 2], pk[i, 3] = means2d[i, 0], means2d[i, 1], a, b
        pk[i, 4], pk[i, 5], pk[i, 6], pk[i, 7] = c, o, ext, _ZERO
    return pk


@njit(inline="always", **_OPTS)
def _row_range(my, ext, yb):
    """Tile rows [r0, r1] (r1 < r0: none) whose pixel centres lie within ``ext`` of ``my``; ``yb`` = first row's centre."""
    r0 = int(min(max(np.ceil(my - ext - yb), _ZERO), f32(TILE)))
    r1 = int(max(min(np.floor(my + ext - yb), f32(TILE - 1)), f32(-1.0)))
    return r0, r1


@njit(inline="always", **_OPTS)
def _power(p, mx, my, ca, cb, cc, xb, yb):
    """-q/2 at pixel p of the tile (row-major, 16 wide); xb, yb = centre of the tile's first pixel."""
    dx = mx - (xb + f32(p & _U15))
    dy = my - (yb + f32(p >> _U4))
    return -_HALF * (ca * dx * dx + cc * dy * dy) - cb * dx * dy


@njit(inline="always", **_OPTS)
def _fwd_gaussian(st, lo, hi, mx, my, ca, cb, cc, o, xb, yb, kr):
    """Composite one Gaussian over pixels [lo, hi) of a tile; returns (pixels stopped, pixels added)."""
    n_stop = 0
    n_add = 0
    for p in range(lo, hi):
        power = _power(p, mx, my, ca, cb, cc, xb, yb)
        a = min(_ALPHA_MAX, o * _exp_neg(power))
        tp = st[_F_T + p]
        test_t = tp * (_ONE - a)
        ok = (power <= _ZERO) & (a >= _ALPHA_MIN) & (tp > _ZERO)
        stop = ok & (test_t < _T_MIN)  # this Gaussian would end the pixel: it is not added (CUDA rule)
        add = ok & (test_t >= _T_MIN)
        st[_F_W + p] = a * tp if add else _ZERO
        st[_F_T + p] = test_t if add else (-tp if stop else tp)
        st[_F_L + p] = kr if add else st[_F_L + p]
        n_stop += stop
        n_add += add
    return n_stop, n_add


@njit(inline="always", **_OPTS)
def _fwd_accumulate(st, lo, hi, base, col):
    for p in range(lo, hi):
        st[base + p] += st[_F_W + p] * col


_F_A0, _F_A1, _F_A2, _F_A3 = (U((_F_ROWS + c) * NPIX) for c in range(4))


@njit(inline="always", **_OPTS)
def _fwd_accumulate4(st, lo, hi, c0, c1, c2, c3):
    """Channels 0-3 (rgb + depth, the training case) in one loop with constant row offsets."""
    for p in range(lo, hi):
        w = st[_F_W + p]
        st[_F_A0 + p] += w * c0
        st[_F_A1 + p] += w * c1
        st[_F_A2 + p] += w * c2
        st[_F_A3 + p] += w * c3


@njit(inline="always", **_OPTS)
def _start_forward_tile(t, st, width, height, tiles_x):
    """Reset the forward state ``st`` for tile ``t``: transmittance 1 inside the image (pixels outside
    start stopped, -1), no last contributor. Returns (x_base, y_base, xb, yb, pixels alive), xb and yb
    the centre of the tile's first pixel. Shared by the forward kernel and :mod:`.numba_contrib`."""
    x_base = (t % tiles_x) * TILE
    y_base = (t // tiles_x) * TILE
    st[:] = _ZERO
    n_alive = 0
    for p in range(NPIX):
        inside = (x_base + p % TILE < width) and (y_base + p // TILE < height)
        st[_F_T + U(p)] = _ONE if inside else -_ONE  # pixels outside the image start stopped
        st[_F_L + U(p)] = f32(-1.0)
        n_alive += inside
    xb = f32(x_base) + _HALF  # pixel centres, see camera.py
    yb = f32(y_base) + _HALF
    return x_base, y_base, xb, yb, n_alive


@njit(inline="always", **_OPTS)
def _forward_tile(t, st, pk, channels, offsets, gids, width, height, tiles_x, img, t_final, last_out):
    """Composite tile ``t`` front to back into the image rows it covers; returns the pixel evaluations done."""
    C = channels.shape[1]
    s, e = offsets[t], offsets[t + 1]
    x_base, y_base, xb, yb, n_alive = _start_forward_tile(t, st, width, height, tiles_x)
    evals = 0
    k = s
    while k < e and n_alive > 0:  # stop the tile once every pixel has stopped
        g = gids[k]
        mx, my, ca, cb, cc, o, ext = pk[g, 0], pk[g, 1], pk[g, 2], pk[g, 3], pk[g, 4], pk[g, 5], pk[g, 6]
        kr = f32(k - s)  # exact: tile lists are shorter than 2^24 (checked by the caller)
        k += 1
        r0, r1 = _row_range(my, ext, yb)
        if ext < _ZERO or r1 < r0:
            continue
        lo, hi = U(r0) * _U16, U(r1 + 1) * _U16
        evals += (r1 + 1 - r0) * TILE
        n_stop, n_add = _fwd_gaussian(st, lo, hi, mx, my, ca, cb, cc, o, xb, yb, kr)
        n_alive -= n_stop
        if n_add > 0:
            c_done = 0
            if C >= 4:
                _fwd_accumulate4(st, lo, hi, channels[g, 0], channels[g, 1], channels[g, 2], channels[g, 3])
                c_done = 4
            for c in range(c_done, C):
                _fwd_accumulate(st, lo, hi, U(_F_ROWS + c) * _UNPIX, channels[g, c])
    for p in range(NPIX):
        x = x_base + p % TILE
        y = y_base + p // TILE
        if x < width and y < height:
            t_final[y, x] = abs(st[_F_T + U(p)])
            lr = st[_F_L + U(p)]
            last_out[y, x] = s + int(lr) if lr >= _ZERO else -1
            for c in range(C):
                img[y, x, c] = st[U(_F_ROWS + c) * _UNPIX + U(p)]
    return evals


@njit(nogil=True, **_OPTS)
def _forward_worker(w, n_workers, pk, channels, offsets, gids, order, width, height, tiles_x, img, t_final, last_out, n_eval):
    """Worker ``w`` of ``n_workers``: tiles order[w], order[w + n_workers], ... (see :func:`forward`)."""
    C = channels.shape[1]
    st = np.empty((_F_ROWS + C) * NPIX, np.float32)
    for j in range(w, order.shape[0], n_workers):
        t = order[j]
        n_eval[t] = _forward_tile(t, st, pk, channels, offsets, gids, width, height, tiles_x, img, t_final, last_out)


def forward(pk, channels, offsets, gids, order, n_workers, width, height, tiles_x):
    """Front-to-back compositing -> (image (H,W,C), T_final (H,W), last contributor (H,W), evaluations per tile).

    ``order`` lists the non-empty tiles, longest list first; worker w takes tiles w, w + n_workers, ...
    (a static round robin over cost-sorted tiles balances the threads without a scheduler).
    """
    img = np.zeros((height, width, channels.shape[1]), np.float32)
    t_final = np.ones((height, width), np.float32)
    last_out = np.full((height, width), -1, np.int64)
    n_eval = np.zeros(offsets.shape[0] - 1, np.int64)
    _run_workers(_forward_worker, n_workers, (pk, channels, offsets, gids, order, width, height, tiles_x, img, t_final, last_out, n_eval))
    return img, t_final, last_out, n_eval


@njit(inline="always", **_OPTS)
def _bwd_pass1(st, lo, hi, mx, my, ca, cb, cc, o, xb, yb, kr):
    """Recompute alpha where this Gaussian contributed and undo its factor of T; returns how many pixels."""
    n_ok = 0
    for p in range(lo, hi):
        power = _power(p, mx, my, ca, cb, cc, xb, yb)
        gv = _exp_neg(power)
        a = min(_ALPHA_MAX, o * gv)
        ok = (kr <= st[_B_L + p]) & (power <= _ZERO) & (a >= _ALPHA_MIN)
        tp = st[_B_T + p]
        tn = tp / (_ONE - a) if ok else tp  # T in front of this Gaussian
        st[_B_T + p] = tn
        st[_B_OK + p] = _ONE if ok else _ZERO
        st[_B_A + p] = a if ok else _ZERO
        st[_B_G + p] = gv
        st[_B_W + p] = a * tn if ok else _ZERO
        st[_B_DLA + p] = _ZERO
        n_ok += ok
    return n_ok


@njit(inline="always", **_OPTS)
def _bwd_pass2(st, lo, hi, base, col):
    """One channel: its gradient sum_p a*T*dL/dpix, and its share of dL/dalpha via the colour behind (CUDA trick)."""
    gsum = _ZERO
    for p in range(lo, hi):
        okp = st[_B_OK + p] > _ZERO
        la = st[_B_LA + p]
        behind_old = st[base + p]
        behind = la * st[base + _UNPIX + p] + (_ONE - la) * behind_old
        dp = st[base + U(2) * _UNPIX + p]
        st[base + p] = behind if okp else behind_old
        st[base + _UNPIX + p] = col if okp else st[base + _UNPIX + p]
        st[_B_DLA + p] += (col - behind) * dp if okp else _ZERO
        gsum += st[_B_W + p] * dp
    return gsum


_B_C = tuple(U((_B_ROWS + 3 * c + j) * NPIX) for c in range(4) for j in range(3))  # (behind, last, dL/dpix) x 4


@njit(inline="always", **_OPTS)
def _bwd_pass2_4(st, lo, hi, c0, c1, c2, c3):
    """_bwd_pass2 for channels 0-3 in one loop with constant row offsets; returns their four gradients."""
    g0 = _ZERO
    g1 = _ZERO
    g2 = _ZERO
    g3 = _ZERO
    for p in range(lo, hi):
        okp = st[_B_OK + p] > _ZERO
        la = st[_B_LA + p]
        w = st[_B_W + p]
        b0 = la * st[_B_C[1] + p] + (_ONE - la) * st[_B_C[0] + p]
        b1 = la * st[_B_C[4] + p] + (_ONE - la) * st[_B_C[3] + p]
        b2 = la * st[_B_C[7] + p] + (_ONE - la) * st[_B_C[6] + p]
        b3 = la * st[_B_C[10] + p] + (_ONE - la) * st[_B_C[9] + p]
        d0, d1, d2, d3 = st[_B_C[2] + p], st[_B_C[5] + p], st[_B_C[8] + p], st[_B_C[11] + p]
        st[_B_C[0] + p] = b0 if okp else st[_B_C[0] + p]
        st[_B_C[3] + p] = b1 if okp else st[_B_C[3] + p]
        st[_B_C[6] + p] = b2 if okp else st[_B_C[6] + p]
        st[_B_C[9] + p] = b3 if okp else st[_B_C[9] + p]
        st[_B_C[1] + p] = c0 if okp else st[_B_C[1] + p]
        st[_B_C[4] + p] = c1 if okp else st[_B_C[4] + p]
        st[_B_C[7] + p] = c2 if okp else st[_B_C[7] + p]
        st[_B_C[10] + p] = c3 if okp else st[_B_C[10] + p]
        dla = (c0 - b0) * d0 + (c1 - b1) * d1 + (c2 - b2) * d2 + (c3 - b3) * d3
        st[_B_DLA + p] += dla if okp else _ZERO
        g0 += w * d0
        g1 += w * d1
        g2 += w * d2
        g3 += w * d3
    return g0, g1, g2, g3


@njit(inline="always", **_OPTS)
def _bwd_pass3(st, lo, hi, mx, my, ca, cb, cc, o, xb, yb):
    """dL/dalpha -> gradients of opacity, 2D mean and conic, summed over the pixels."""
    s_mx = _ZERO
    s_my = _ZERO
    s_ca = _ZERO
    s_cb = _ZERO
    s_cc = _ZERO
    s_o = _ZERO
    for p in range(lo, hi):
        okp = st[_B_OK + p] > _ZERO
        a = st[_B_A + p]
        # T_final enters the alpha output and the background term: dT_final/da = -T_final / (1 - a)
        dla = st[_B_DLA + p] * st[_B_T + p] - st[_B_TFIN + p] / (_ONE - a) * st[_B_DTFIN + p]
        st[_B_LA + p] = a if okp else st[_B_LA + p]
        gv = st[_B_G + p]
        live = okp & (o * gv < _ALPHA_MAX)  # alpha clamped at 0.99 passes no gradient
        dla = dla if live else _ZERO
        d_pow = o * gv * dla  # dL/d(-q/2)
        dx = mx - (xb + f32(p & _U15))
        dy = my - (yb + f32(p >> _U4))
        s_o += gv * dla
        s_mx += d_pow * (-ca * dx - cb * dy)
        s_my += d_pow * (-cc * dy - cb * dx)
        s_ca += d_pow * (-_HALF * dx * dx)
        s_cb += d_pow * (-dx * dy)
        s_cc += d_pow * (-_HALF * dy * dy)
    return s_mx, s_my, s_ca, s_cb, s_cc, s_o


@njit(inline="always", **_OPTS)
def _bwd_abs(st, lo, hi, mx, my, ca, cb, cc, o, xb, yb):
    """The sums over the pixels of |dL/du| and |dL/dv| of the 2D mean, each pixel's gradient taken
    before summing (AbsGS's densification statistic). Reads the state :func:`_bwd_pass3` read; a
    separate loop, so the plain gradients keep their bits when it is not asked for."""
    a_mx = _ZERO
    a_my = _ZERO
    for p in range(lo, hi):
        okp = st[_B_OK + p] > _ZERO
        a = st[_B_A + p]
        dla = st[_B_DLA + p] * st[_B_T + p] - st[_B_TFIN + p] / (_ONE - a) * st[_B_DTFIN + p]
        gv = st[_B_G + p]
        live = okp & (o * gv < _ALPHA_MAX)
        d_pow = o * gv * (dla if live else _ZERO)
        dx = mx - (xb + f32(p & _U15))
        dy = my - (yb + f32(p >> _U4))
        a_mx += abs(d_pow * (-ca * dx - cb * dy))
        a_my += abs(d_pow * (-cc * dy - cb * dx))
    return a_mx, a_my


@njit(inline="always", **_OPTS)
def _backward_tile(t, st, rows, pk, channels, offsets, gids, width, height, tiles_x, t_final, last_idx, d_img, d_alpha, with_abs):
    """Back-to-front gradient of tile ``t``: fills the rows of its intersections (with ``with_abs``,
    also the absolute sums of :func:`_bwd_abs` in the last two columns)."""
    C = channels.shape[1]
    s, e = offsets[t], offsets[t + 1]
    x_base = (t % tiles_x) * TILE
    y_base = (t // tiles_x) * TILE
    st[:] = _ZERO
    k_max = -1
    for p in range(NPIX):
        x = x_base + p % TILE
        y = y_base + p // TILE
        up = U(p)
        st[_B_L + up] = f32(-1.0)
        st[_B_T + up] = _ONE
        if x < width and y < height:
            st[_B_T + up] = t_final[y, x]
            st[_B_TFIN + up] = t_final[y, x]
            st[_B_DTFIN + up] = -d_alpha[y, x]  # alpha = 1 - T_final
            if last_idx[y, x] >= 0:
                st[_B_L + up] = f32(last_idx[y, x] - s)
            k_max = max(k_max, last_idx[y, x])
            for c in range(C):
                st[U(_B_ROWS + 3 * c + 2) * _UNPIX + up] = d_img[y, x, c]
    xb = f32(x_base) + _HALF
    yb = f32(y_base) + _HALF
    for k in range(k_max, s - 1, -1):
        g = gids[k]
        mx, my, ca, cb, cc, o, ext = pk[g, 0], pk[g, 1], pk[g, 2], pk[g, 3], pk[g, 4], pk[g, 5], pk[g, 6]
        r0, r1 = _row_range(my, ext, yb)
        if ext < _ZERO or r1 < r0:
            continue
        lo, hi = U(r0) * _U16, U(r1 + 1) * _U16
        if _bwd_pass1(st, lo, hi, mx, my, ca, cb, cc, o, xb, yb, f32(k - s)) == 0:
            continue
        c_done = 0
        if C >= 4:
            g0, g1, g2, g3 = _bwd_pass2_4(st, lo, hi, channels[g, 0], channels[g, 1], channels[g, 2], channels[g, 3])
            rows[k, 6], rows[k, 7], rows[k, 8], rows[k, 9] = g0, g1, g2, g3
            c_done = 4
        for c in range(c_done, C):
            rows[k, 6 + c] = _bwd_pass2(st, lo, hi, U(_B_ROWS + 3 * c) * _UNPIX, channels[g, c])
        s_mx, s_my, s_ca, s_cb, s_cc, s_o = _bwd_pass3(st, lo, hi, mx, my, ca, cb, cc, o, xb, yb)
        if with_abs:  # pass 3 changed only _B_LA, which _bwd_abs does not read
            rows[k, 6 + C], rows[k, 7 + C] = _bwd_abs(st, lo, hi, mx, my, ca, cb, cc, o, xb, yb)
        rows[k, 0] = s_mx
        rows[k, 1] = s_my
        rows[k, 2] = s_ca
        rows[k, 3] = s_cb
        rows[k, 4] = s_cc
        rows[k, 5] = s_o


@njit(nogil=True, **_OPTS)
def _backward_worker(w, n_workers, pk, channels, offsets, gids, order, width, height, tiles_x, t_final, last_idx, d_img, d_alpha, rows, with_abs):
    """Worker ``w`` of ``n_workers`` of :func:`backward` (tiles dealt as in :func:`forward`)."""
    C = channels.shape[1]
    st = np.empty((_B_ROWS + 3 * C) * NPIX, np.float32)
    for j in range(w, order.shape[0], n_workers):
        _backward_tile(order[j], st, rows, pk, channels, offsets, gids, width, height, tiles_x, t_final, last_idx, d_img, d_alpha, with_abs)


def backward(pk, channels, offsets, gids, order, n_workers, width, height, tiles_x, t_final, last_idx, d_img, d_alpha, with_abs=False):
    """Back-to-front gradient -> rows (I, 6+C): intersection k's gradient w.r.t. (u, v, conic a, b, c, opacity, channels);
    with ``with_abs``, (I, 8+C): then the sums over its pixels of |dL/du| and |dL/dv| (AbsGS).

    Work is split over tiles as in :func:`forward`.
    """
    rows = np.zeros((gids.shape[0], (8 if with_abs else 6) + channels.shape[1]), np.float32)
    args = (pk, channels, offsets, gids, order, width, height, tiles_x, t_final, last_idx, d_img, d_alpha, rows, bool(with_abs))
    _run_workers(_backward_worker, n_workers, args)
    return rows


@njit(**_OPTS)
def reduce_rows(rows, gids, n):
    """Sum intersection rows into per-Gaussian gradients (N, columns of ``rows``) in a fixed order (deterministic, no atomics)."""
    out = np.zeros((n, rows.shape[1]), np.float64)
    for k in range(rows.shape[0]):
        g = gids[k]
        for j in range(rows.shape[1]):
            out[g, j] += rows[k, j]
    return out.astype(np.float32)
