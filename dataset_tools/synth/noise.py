"""Lattice value noise and its band-limited fractal sum, compiled with numba.

Texture evaluation dominates rendering (most surfaces need ~10 octaves), too slow in numpy one
octave at a time; this kernel does the same per-sample work in a single pass. Single-threaded
and without fastmath, so results are bit-reproducible; compiled once and cached on disk.
"""

from __future__ import annotations

import numba
import numpy as np

_MASK = np.uint64(0xFFFFFFFF)

# Per-octave rotations break the lattice alignment of value noise (fixed: outputs are reproducible).
_ROTS = np.zeros((8, 3, 3))
for _k in range(8):
    _a, _b = 0.7 + 0.91 * _k, 0.3 + 1.37 * _k
    _rz = np.array([[np.cos(_a), -np.sin(_a), 0], [np.sin(_a), np.cos(_a), 0], [0, 0, 1]])
    _rx = np.array([[1, 0, 0], [0, np.cos(_b), -np.sin(_b)], [0, np.sin(_b), np.cos(_b)]])
    _ROTS[_k] = _rz @ _rx
MAX_OCTAVES = 8


@numba.njit(cache=True)
def _hash(ix: np.int64, iy: np.int64, iz: np.int64, seed: np.int64) -> float:
    """Integer lattice point -> uniform [0, 1): multiply-xorshift mix on 32 bits."""
    m = np.uint64(0xFFFFFFFF)
    h = (np.uint64(ix & 0xFFFFFFFF) * np.uint64(0x8DA6B343)) & m
    h ^= (np.uint64(iy & 0xFFFFFFFF) * np.uint64(0xD8163841)) & m
    h ^= (np.uint64(iz & 0xFFFFFFFF) * np.uint64(0xCB1AB31F)) & m
    h ^= (np.uint64(seed & 0xFFFFFFFF) * np.uint64(0x9E3779B9) + np.uint64(0x632BE5AB)) & m
    h ^= h >> np.uint64(16)
    h = (h * np.uint64(0x7FEB352D)) & m
    h ^= h >> np.uint64(15)
    h = (h * np.uint64(0x846CA68B)) & m
    h ^= h >> np.uint64(16)
    return float(h) * (1.0 / 4294967296.0)


@numba.njit(cache=True)
def _value(x: float, y: float, z: float, seed: np.int64) -> float:
    """Quintic-interpolated value noise at one point (unit lattice), in [0, 1]."""
    fx, fy, fz = np.floor(x), np.floor(y), np.floor(z)
    ix, iy, iz = np.int64(fx), np.int64(fy), np.int64(fz)
    tx, ty, tz = x - fx, y - fy, z - fz
    wx = tx * tx * tx * (tx * (tx * 6.0 - 15.0) + 10.0)
    wy = ty * ty * ty * (ty * (ty * 6.0 - 15.0) + 10.0)
    wz = tz * tz * tz * (tz * (tz * 6.0 - 15.0) + 10.0)
    out = 0.0
    for cx in range(2):
        ax = wx if cx else 1.0 - wx
        for cy in range(2):
            ay = wy if cy else 1.0 - wy
            for cz in range(2):
                az = wz if cz else 1.0 - wz
                out += ax * ay * az * _hash(ix + cx, iy + cy, iz + cz, seed)
    return out


@numba.njit(cache=True)
def _fbm(p, fp, seed, octaves, rots, out):
    n = p.shape[0]
    for i in range(n):
        total = 0.0
        norm = 0.0
        freq = 1.0
        amp = 1.0
        for k in range(octaves):
            # fade the octave to its mean once its period (1/freq) is below ~4 footprints
            s = (freq * fp[i] - 0.25) / 0.25
            s = min(max(s, 0.0), 1.0)
            keep = 1.0 - s * s * (3.0 - 2.0 * s)
            v = 0.5
            if keep > 0.0:
                x = p[i, 0] * freq
                y = p[i, 1] * freq
                z = p[i, 2] * freq
                qx = rots[k, 0, 0] * x + rots[k, 0, 1] * y + rots[k, 0, 2] * z + 17.31 * k
                qy = rots[k, 1, 0] * x + rots[k, 1, 1] * y + rots[k, 1, 2] * z + 17.31 * k
                qz = rots[k, 2, 0] * x + rots[k, 2, 1] * y + rots[k, 2, 2] * z + 17.31 * k
                v = 0.5 + keep * (_value(qx, qy, qz, seed + 101 * k) - 0.5)
            total += amp * v
            norm += amp
            freq *= 2.0
            amp *= 0.5
        out[i] = total / norm


def fbm(p: np.ndarray, fp: np.ndarray, seed: int, octaves: int = 4) -> np.ndarray:
    """Fractal value noise (period-1 base lattice, ``octaves`` doublings) in [0, 1] at points ``p`` (n, 3).

    Each octave fades to 0.5 once its period is shorter than ~4 footprints ``fp`` (same units as p),
    which band-limits the texture per sample.
    """
    if not 1 <= octaves <= MAX_OCTAVES:
        raise ValueError(f"octaves must be in 1..{MAX_OCTAVES}")
    p = np.ascontiguousarray(p, dtype=np.float64).reshape(-1, 3)
    fp = np.ascontiguousarray(np.broadcast_to(np.asarray(fp, dtype=np.float64), (len(p),)))
    out = np.empty(len(p))
    _fbm(p, fp, np.int64(seed), np.int64(octaves), _ROTS, out)
    return out


def value_noise(p: np.ndarray, seed: int) -> np.ndarray:
    """Single octave of value noise (no rotation, no filtering) at points ``p`` (n, 3)."""
    p = np.ascontiguousarray(p, dtype=np.float64).reshape(-1, 3)
    out = np.empty(len(p))
    _fbm(p, np.zeros(len(p)), np.int64(seed), np.int64(1), np.eye(3)[None].repeat(8, 0), out)
    return out


@numba.njit(cache=True)
def _hash_cells(cells, seed, out):
    for i in range(cells.shape[0]):
        out[i] = _hash(cells[i, 0], cells[i, 1], cells[i, 2], seed)


def cell_random(cells: np.ndarray, seed: int) -> np.ndarray:
    """Uniform [0, 1) value per integer cell (n, 3): e.g. a colour per tile or board."""
    cells = np.ascontiguousarray(cells, dtype=np.int64).reshape(-1, 3)
    out = np.empty(len(cells))
    _hash_cells(cells, np.int64(seed), out)
    return out


def lattice_hash(ix: int, iy: int, iz: int, seed: int) -> float:
    """The lattice hash (exposed for tests and per-cell random values)."""
    return float(_hash(np.int64(ix), np.int64(iy), np.int64(iz), np.int64(seed)))
