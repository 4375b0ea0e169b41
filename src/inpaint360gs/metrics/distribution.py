"""Distribution distances between feature sets: Fréchet distance (FID's formula) and KID.

The paper's FID (Sec. 4 "Metrics", Tab. 1) compares rendered and ground-truth test views of a
scene through Inception pool3 features; this module holds the statistics, shared with the VGG16
substitutes ``fd_vgg16``/``kid_vgg16`` (see ``evaluate.py``).

- Fréchet distance between Gaussians fitted to two feature sets (means, unbiased covariances):
  ``|mu1 - mu2|^2 + tr(S1 + S2 - 2 (S1 S2)^(1/2))``. :func:`frechet_distance` takes the statistics
  and computes it as pytorch-fid does: matrix square root from ``scipy.linalg.sqrtm``; when it is
  not finite, ``eps * I`` is added to both covariances; a complex root whose diagonal has imaginary
  parts above 1e-3 is an error, smaller ones are dropped.
  :func:`frechet_distance_features` takes the features and by default uses an exact identity
  instead of ``sqrtm``: with centred features ``A = (F1 - mu1) / sqrt(n1 - 1)`` (so ``S1 = A^T A``)
  and likewise ``B``, the nonzero eigenvalues of ``S1 S2`` are the squared singular values of the
  small ``n1 x n2`` matrix ``A B^T``, so ``tr (S1 S2)^(1/2)`` is its nuclear norm. The value is the
  one pytorch-fid's ``sqrtm`` approximates, without its cost (results/README.md, "Metrics") and
  failure modes on the singular covariances of a scene's 8-30 views (``method="sqrtm"`` still
  selects it).
- KID: squared MMD with the polynomial kernel ``k(x, y) = (x.y / d + 1)^3`` and the unbiased
  estimator, over all features at once (a scene has only 8-30 test views, too few for subsets).
"""

from __future__ import annotations

import warnings

import numpy as np
from scipy import linalg


def _as_features(f, name: str) -> np.ndarray:
    a = np.asarray(f.detach().cpu() if hasattr(f, "detach") else f, dtype=np.float64)
    if a.ndim != 2:
        raise ValueError(f"{name}: expected an (N, D) feature array, got shape {a.shape}")
    return a


def feature_statistics(features) -> tuple[np.ndarray, np.ndarray]:
    """Mean (D,) and unbiased covariance (D, D) of (N, D) features; needs N >= 2."""
    f = _as_features(features, "features")
    if len(f) < 2:
        raise ValueError(f"need at least 2 feature vectors for a covariance, got {len(f)}")
    return f.mean(axis=0), np.cov(f, rowvar=False)


def frechet_distance(mu1, sigma1, mu2, sigma2, eps: float = 1e-6) -> float:
    """Fréchet distance between N(mu1, sigma1) and N(mu2, sigma2) (pytorch-fid's computation)."""
    mu1, mu2 = np.atleast_1d(np.asarray(mu1, np.float64)), np.atleast_1d(np.asarray(mu2, np.float64))
    s1, s2 = np.atleast_2d(np.asarray(sigma1, np.float64)), np.atleast_2d(np.asarray(sigma2, np.float64))
    if mu1.shape != mu2.shape or s1.shape != s2.shape or s1.shape != (len(mu1), len(mu1)):
        raise ValueError(f"inconsistent shapes: mu {mu1.shape}, {mu2.shape}; sigma {s1.shape}, {s2.shape}")
    diff = mu1 - mu2
    covmean = _sqrtm(s1 @ s2)
    if not np.isfinite(covmean).all():
        offset = np.eye(len(s1)) * eps
        covmean = _sqrtm((s1 + offset) @ (s2 + offset))
    if np.iscomplexobj(covmean):
        if not np.allclose(np.diagonal(covmean).imag, 0, atol=1e-3):
            raise ValueError(f"matrix square root has an imaginary component of {np.max(np.abs(covmean.imag)):.3g}")
        covmean = covmean.real
    return float(diff @ diff + np.trace(s1) + np.trace(s2) - 2.0 * np.trace(covmean))


def _sqrtm(a: np.ndarray) -> np.ndarray:
    with warnings.catch_warnings():  # singular products (few samples) warn; finiteness is checked instead
        warnings.simplefilter("ignore", RuntimeWarning)
        warnings.simplefilter("ignore", linalg.LinAlgWarning)
        return linalg.sqrtm(a)


def frechet_distance_features(f1, f2, *, method: str = "lowrank", eps: float = 1e-6) -> float:
    """Fréchet distance between Gaussians fitted to two (N, D) feature sets (N >= 2 each).

    ``method="lowrank"``: exact, via the nuclear norm of ``A B^T`` (module docstring);
    ``method="sqrtm"``: pytorch-fid's computation on the statistics (:func:`frechet_distance`).
    """
    if method == "sqrtm":
        return frechet_distance(*feature_statistics(f1), *feature_statistics(f2), eps=eps)
    if method != "lowrank":
        raise ValueError(f"method must be 'lowrank' or 'sqrtm', got {method!r}")
    x, y = _as_features(f1, "f1"), _as_features(f2, "f2")
    if x.shape[1] != y.shape[1]:
        raise ValueError(f"feature dimensions differ: {x.shape[1]} vs {y.shape[1]}")
    if len(x) < 2 or len(y) < 2:
        raise ValueError(f"need at least 2 feature vectors per set, got {len(x)} and {len(y)}")
    a = (x - x.mean(axis=0)) / np.sqrt(len(x) - 1)
    b = (y - y.mean(axis=0)) / np.sqrt(len(y) - 1)
    diff = x.mean(axis=0) - y.mean(axis=0)
    tr_covmean = np.linalg.svd(a @ b.T, compute_uv=False).sum()
    return float(diff @ diff + np.sum(a * a) + np.sum(b * b) - 2.0 * tr_covmean)


def kernel_inception_distance(f1, f2) -> float:
    """Unbiased MMD^2 of two (N, D) feature sets with the kernel ``(x.y / D + 1)^3``; needs N >= 2 each."""
    x, y = _as_features(f1, "f1"), _as_features(f2, "f2")
    if x.shape[1] != y.shape[1]:
        raise ValueError(f"feature dimensions differ: {x.shape[1]} vs {y.shape[1]}")
    m, n = len(x), len(y)
    if m < 2 or n < 2:
        raise ValueError(f"need at least 2 feature vectors per set, got {m} and {n}")
    d = x.shape[1]
    kxx = (x @ x.T / d + 1.0) ** 3
    kyy = (y @ y.T / d + 1.0) ** 3
    kxy = (x @ y.T / d + 1.0) ** 3
    within_x = (kxx.sum() - np.trace(kxx)) / (m * (m - 1))
    within_y = (kyy.sum() - np.trace(kyy)) / (n * (n - 1))
    return float(within_x + within_y - 2.0 * kxy.mean())
