"""Numba kernel of the 3D spatial loss (paper Eq. 4): sum of cos(f_i, f_j) over kNN pairs and its gradient.

One pass over the pairs (i, j in kNN(i)) accumulates the cosine and scatters its gradient to both
features, in a fixed order on one thread: deterministic, and much cheaper than torch's gather /
index_put backward on the CPU, which dominated a step.
"""

from __future__ import annotations

import numpy as np

import inpaint360gs.render.numba_cache  # noqa: F401  (sets the cache folder before the kernels are defined)
from numba import njit  # isort: skip


@njit(inline="always", cache=True, error_model="numpy")
def _inv_norm(f, i, eps):
    """(1 / max(|f_i|, eps), |f_i| >= eps)."""
    s = np.float32(0.0)
    for c in range(f.shape[1]):
        s += f[i, c] * f[i, c]
    nrm = np.sqrt(s)
    return np.float32(1.0) / max(nrm, eps), nrm >= eps


@njit(cache=True, error_model="numpy")
def cosine_pairs(f, nbr, rows, eps):
    """(sum over i in ``rows``, j in ``nbr[i]`` of cos(f_i, f_j) (float64), its gradient w.r.t. f (N, F) float32).

    cos = f_i . f_j / (max(|f_i|, eps) max(|f_j|, eps)); a norm below ``eps`` is held constant (as torch clamps it)."""
    n, C = f.shape
    k = nbr.shape[1]
    grad = np.zeros((n, C), np.float32)
    total = 0.0
    for r in range(rows.shape[0]):
        i = rows[r]
        ni, live_i = _inv_norm(f, i, eps)
        for q in range(k):
            j = nbr[i, q]
            nj, live_j = _inv_norm(f, j, eps)
            dot = np.float32(0.0)
            for c in range(C):
                dot += f[i, c] * f[j, c]
            cos = dot * ni * nj
            total += cos
            si = cos * ni * ni if live_i else np.float32(0.0)
            sj = cos * nj * nj if live_j else np.float32(0.0)
            nij = ni * nj
            for c in range(C):
                fi = f[i, c]
                fj = f[j, c]
                grad[i, c] += fj * nij - si * fi
                grad[j, c] += fi * nij - sj * fj
    return total, grad
