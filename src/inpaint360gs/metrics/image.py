"""Full-image PSNR and SSIM through torchmetrics' functional metrics, on (H, W, C) images.

Evaluation computes in float64 on images clamped to [0, 1] (renders can overshoot), one image at a
time; averaging over views is the caller's job (per-image mean, as in 3DGS ``metrics.py``).
SSIM is the standard Gaussian-window SSIM (11x11, sigma 1.5, K1 0.01, K2 0.03; Wang et al. 2004).
"""

from __future__ import annotations

import torch
from torchmetrics.functional.image import peak_signal_noise_ratio, structural_similarity_index_measure


def _nchw(img: torch.Tensor, ref: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    if img.shape != ref.shape:
        raise ValueError(f"image shapes differ: {tuple(img.shape)} vs {tuple(ref.shape)}")
    if img.ndim == 2:
        img, ref = img[..., None], ref[..., None]
    if img.ndim != 3:
        raise ValueError(f"expected an (H, W) or (H, W, C) image, got shape {tuple(img.shape)}")
    prep = lambda t: t.detach().to(torch.float64).clamp(0.0, 1.0).permute(2, 0, 1)[None]  # noqa: E731
    return prep(img), prep(ref)


def psnr(img: torch.Tensor, ref: torch.Tensor) -> float:
    """PSNR in dB of ``img`` against ``ref``, both in [0, 1]: 10 log10(1 / MSE)."""
    a, b = _nchw(img, ref)
    return float(peak_signal_noise_ratio(a, b, data_range=1.0))


def ssim(img: torch.Tensor, ref: torch.Tensor) -> float:
    """Mean SSIM of ``img`` against ``ref``, both in [0, 1]; 1 for identical images."""
    a, b = _nchw(img, ref)
    return float(structural_similarity_index_measure(a, b, data_range=1.0, gaussian_kernel=True, kernel_size=11, sigma=1.5))
