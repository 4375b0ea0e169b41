"""Full-image PSNR and SSIM on (H, W, C) images.

Evaluation computes in float64 on images clamped to [0, 1] (renders can overshoot), one image at a
time; averaging over views is the caller's job (per-image mean, as in 3DGS ``metrics.py``).
SSIM is the standard Gaussian-window SSIM (11x11, sigma 1.5, K1 0.01, K2 0.03; Wang et al. 2004)
as torchmetrics computes it (reflection padding, variances clamped at 0). PSNR goes through
torchmetrics; the SSIM map is computed here with the separable window (scipy ``correlate1d``,
``mirror`` = torch's ``reflect``): the same numbers as torchmetrics' SSIM to ~1e-14, far cheaper
than its float64 grouped 2D convolution, which matters for the scene evaluation (``evaluate.py``;
timings in results/README.md, "Metrics").
"""

from __future__ import annotations

import numpy as np
import torch
from scipy import ndimage
from torchmetrics.functional.image import peak_signal_noise_ratio

SSIM_K1, SSIM_K2 = 0.01, 0.03
_g = np.exp(-(np.arange(-5, 6, dtype=np.float64) ** 2) / (2 * 1.5**2))  # 11 taps, sigma 1.5
SSIM_WINDOW_1D = _g / _g.sum()


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
    return float(ssim_index_map(img, ref).mean())


def ssim_index_map(img: torch.Tensor, ref: torch.Tensor) -> torch.Tensor:
    """Per-pixel SSIM (H, W, C) float64, same size as the image; :func:`ssim` is its mean."""
    a, b = (t[0].permute(1, 2, 0).cpu().numpy() for t in _nchw(img, ref))
    stats = np.stack([a, b, a * a, b * b, a * b])  # (5, H, W, C)
    for axis in (1, 2):  # separable Gaussian window, reflection at the borders
        stats = ndimage.correlate1d(stats, SSIM_WINDOW_1D, axis=axis, mode="mirror")
    mx, my, xx, yy, xy = stats
    c1, c2 = SSIM_K1**2, SSIM_K2**2
    vx, vy, cxy = np.maximum(xx - mx * mx, 0.0), np.maximum(yy - my * my, 0.0), xy - mx * my
    s = ((2 * mx * my + c1) * (2 * cxy + c2)) / ((mx * mx + my * my + c1) * (vx + vy + c2))
    return torch.from_numpy(s)
