"""The distillation objective (paper Sec. 3.3): L = L_obj + lambda L_space.

* L_obj: cross-entropy between softmax(Phi(F)) and the associated class of every pixel of the view.
* L_space (Eq. 4): for each Gaussian, its k nearest neighbours by centre (Euclidean, computed once:
  the geometry is frozen); ``L_space = 1 - mean_i mean_{j in kNN(i)} cos(f_i, f_j)``.

Per step L_space may be evaluated on a random sample of Gaussians (drawn with replacement from the
loop's generator): the sample mean is an unbiased estimate of the full mean and of its gradient,
at a fraction of the cost (``DistillConfig.knn_sample``).
"""

from __future__ import annotations

import numpy as np
import torch
import torch.nn.functional as F


def knn_graph(means: torch.Tensor, k: int) -> torch.Tensor:
    """(N, k') int64 indices of each centre's k' = min(k, N-1) nearest other centres (scipy cKDTree,
    ties broken by index; a duplicate centre counts as a neighbour, the point itself never does)."""
    from scipy.spatial import cKDTree

    p = means.detach().cpu().double().numpy()
    n = p.shape[0]
    k = min(k, n - 1)
    if k <= 0:
        return torch.zeros(n, 0, dtype=torch.long)
    _, idx = cKDTree(p).query(p, k=k + 1)
    idx = np.asarray(idx, np.int64).reshape(n, k + 1)
    is_self = idx == np.arange(n)[:, None]
    drop = np.where(is_self.any(1), is_self.argmax(1), k)  # the point itself, or the farthest when duplicates hid it
    keep = np.ones_like(idx, dtype=bool)
    keep[np.arange(n), drop] = False
    return torch.from_numpy(idx[keep].reshape(n, k))


COS_EPS = 1e-8  # norms are clamped to at least this in the cosine


def spatial_loss(features: torch.Tensor, neighbours: torch.Tensor, rows: torch.Tensor | None = None) -> torch.Tensor:
    """Eq. 4: 1 - mean cosine similarity between f_i and its neighbours' features, over ``rows``
    (indices of the Gaussians i to average over; None: all). Zero without neighbours.

    CPU float32: a numba kernel (:mod:`.numba_space`); otherwise torch (the reference in the tests)."""
    if neighbours.shape[1] == 0 or features.shape[0] == 0:
        return features.sum() * 0.0
    if features.device.type == "cpu" and features.dtype == torch.float32:
        return _SpatialLoss.apply(features, neighbours, rows)
    centre = features if rows is None else features[rows]
    nb = features[neighbours if rows is None else neighbours[rows]]  # (S, k, F)
    cos = F.cosine_similarity(centre[:, None, :], nb, dim=-1, eps=COS_EPS)
    return 1.0 - cos.mean()


class _SpatialLoss(torch.autograd.Function):
    @staticmethod
    def forward(ctx, features, neighbours, rows):
        from inpaint360gs.distill.numba_space import cosine_pairs

        nbr = np.ascontiguousarray(neighbours.numpy(), dtype=np.int64)
        r = np.arange(features.shape[0], dtype=np.int64) if rows is None else np.ascontiguousarray(rows.numpy(), dtype=np.int64)
        total, grad = cosine_pairs(np.ascontiguousarray(features.detach().numpy()), nbr, r, np.float32(COS_EPS))
        pairs = r.shape[0] * nbr.shape[1]
        ctx.grad = torch.from_numpy(grad)
        ctx.scale = -1.0 / pairs
        return features.new_tensor(1.0 - total / pairs)

    @staticmethod
    def backward(ctx, g):
        return ctx.grad * (g * ctx.scale), None, None


def object_loss(logits: torch.Tensor, labels: torch.Tensor) -> torch.Tensor:
    """L_obj: mean cross-entropy over pixels of logits (P, Q) against class indices (P,), the value
    of ``F.cross_entropy`` (the tests compare them in float64).

    Written out over the transposed (Q, P) logits: a scene has a handful of classes Q and some 10^5
    pixels P, and torch's CPU cross-entropy reduces along the short class axis row by row; taking
    the log-sum-exp across rows of the transposed view runs over the pixels in contiguous memory,
    about 3x cheaper forward and backward on the kitchen's 389x260 views with 14 classes
    (``benchmarks/bench_distill.py`` times the stage)."""
    t = logits.t()  # (Q, P), a view
    top = t.detach().max(dim=0).values
    lse = torch.log(torch.exp(t - top).sum(dim=0)) + top
    return (lse - t.gather(0, labels.long()[None]).squeeze(0)).mean()
