"""The three mask conventions of the inpainting metrics, kept apart by name, and AMCR.

Inpainting quality is scored in the unseen region of each test view (paper Sec. 4 "Metrics",
Tab. 1). Three conventions exist, and a table must never mix them:

- full image (``psnr``, ``ssim``, ``lpips``, ``lpips_alex``): the whole frame;
- ``masked_*`` (the paper's evaluation code): render and ground truth are both multiplied by the
  binary unseen mask, then the ordinary full-frame metric is computed. Pixels outside the mask are
  0 in both images and count as perfect matches, which is why the paper's masked SSIM is ~0.99;
- ``roi_*`` (strict): PSNR from the mean squared error over mask pixels only; SSIM map and LPIPS
  spatial map (LPIPS ``spatial=True``) averaged over mask pixels only.

Images are (H, W, 3) float tensors in [0, 1] (clamped, as in :mod:`.image`), masks (H, W) bool.

Undefined and infinite values:

- an empty mask has no ROI: ``roi_*`` return None (never NaN); :func:`roi_undefined_reason` gives
  the reason string. ``masked_*`` stay defined on an empty mask (both images are all zero), as in
  the paper's code; the evaluate stage scores such a view in neither convention;
- PSNR of a render equal to the ground truth on every evaluated pixel is ``+inf`` here, as in the
  paper's code. JSON cannot hold inf, so :func:`~inpaint360gs.evaluate.stage.evaluate_stage`
  stores ``null`` with the reason ``INFINITE_PSNR_REASON``, and a mean over views that include
  such a view is ``null`` too (with a reason), never a mean over fewer views.

AMCR (paper supp. Eq. 1): the average over views of the percentage of image pixels in the mask.
"""

from __future__ import annotations

import math

import torch

from inpaint360gs.metrics.image import psnr, ssim, ssim_index_map
from inpaint360gs.metrics.lpips import Net, lpips, lpips_map

EMPTY_ROI_REASON = "empty ROI: the unseen mask has no pixels"
INFINITE_PSNR_REASON = "+inf: render equals ground truth on every evaluated pixel (MSE 0)"

CONVENTIONS = {
    "full": "psnr, ssim, lpips (VGG), lpips_alex: whole frame",
    "masked": (
        "masked_*: render and ground truth both multiplied by the binary unseen mask (>127), "
        "then the full-frame metric (paper's evaluation code)"
    ),
    "roi": "roi_*: PSNR over unseen-mask pixels only; SSIM map and LPIPS spatial map averaged over unseen-mask pixels",
}


def _check_mask(img: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
    mask = torch.as_tensor(mask)
    if img.ndim != 3 or tuple(mask.shape) != tuple(img.shape[:2]):
        raise ValueError(f"mask shape {tuple(mask.shape)} does not match image shape {tuple(img.shape)}")
    return mask.to(device=img.device, dtype=torch.bool)


def apply_mask(img: torch.Tensor, mask: torch.Tensor) -> torch.Tensor:
    """``img`` (H, W, C) with pixels outside the (H, W) mask set to 0."""
    return img * _check_mask(img, mask)[..., None].to(img.dtype)


def roi_undefined_reason(mask: torch.Tensor) -> str | None:
    """Why ``roi_*`` metrics are None for ``mask`` (None when they are defined)."""
    return EMPTY_ROI_REASON if not bool(torch.as_tensor(mask).any()) else None


def roi_mean(values: torch.Tensor, mask: torch.Tensor) -> float | None:
    """Mean of a per-pixel map (H, W) or (H, W, C) over the mask's pixels (and channels); None if empty."""
    mask = _check_mask(values if values.ndim == 3 else values[..., None], mask)
    if not bool(mask.any()):
        return None
    return float(values[mask].double().mean())


def masked_psnr(img: torch.Tensor, ref: torch.Tensor, mask: torch.Tensor) -> float:
    """PSNR of the mask-multiplied images over the whole frame (``+inf`` when they are equal)."""
    return psnr(apply_mask(img, mask), apply_mask(ref, mask))


def masked_ssim(img: torch.Tensor, ref: torch.Tensor, mask: torch.Tensor) -> float:
    """SSIM of the mask-multiplied images over the whole frame."""
    return ssim(apply_mask(img, mask), apply_mask(ref, mask))


def masked_lpips(img: torch.Tensor, ref: torch.Tensor, mask: torch.Tensor, net: Net = "vgg") -> float:
    """LPIPS of the mask-multiplied images (whole frame)."""
    a, b = apply_mask(img, mask), apply_mask(ref, mask)
    with torch.inference_mode():
        return float(lpips(a.permute(2, 0, 1).float(), b.permute(2, 0, 1).float(), net))


def masked_lpips_alex(img: torch.Tensor, ref: torch.Tensor, mask: torch.Tensor) -> float:
    """:func:`masked_lpips` with the AlexNet network."""
    return masked_lpips(img, ref, mask, net="alex")


def roi_psnr(img: torch.Tensor, ref: torch.Tensor, mask: torch.Tensor) -> float | None:
    """PSNR from the MSE over mask pixels (all channels) of images clamped to [0, 1]; None if empty."""
    if img.shape != ref.shape:
        raise ValueError(f"image shapes differ: {tuple(img.shape)} vs {tuple(ref.shape)}")
    sq = (img.double().clamp(0, 1) - ref.double().clamp(0, 1)) ** 2
    mse = roi_mean(sq, mask)
    if mse is None:
        return None
    return math.inf if mse == 0 else -10.0 * math.log10(mse)


def roi_ssim(img: torch.Tensor, ref: torch.Tensor, mask: torch.Tensor) -> float | None:
    """The full-frame SSIM map (the one :func:`ssim` averages) averaged over mask pixels; None if empty."""
    return roi_mean(ssim_index_map(img, ref), mask)


def roi_lpips(img: torch.Tensor, ref: torch.Tensor, mask: torch.Tensor, net: Net = "vgg") -> float | None:
    """LPIPS spatial map averaged over mask pixels; None if the mask is empty."""
    if roi_undefined_reason(mask) is not None:
        return None
    with torch.inference_mode():
        m = lpips_map(img.permute(2, 0, 1).float(), ref.permute(2, 0, 1).float(), net)
    return roi_mean(m[0, 0], mask)


def roi_lpips_alex(img: torch.Tensor, ref: torch.Tensor, mask: torch.Tensor) -> float | None:
    """:func:`roi_lpips` with the AlexNet network."""
    return roi_lpips(img, ref, mask, net="alex")


def amcr(masks: torch.Tensor) -> float:
    """Average mask coverage ratio (paper supp. Eq. 1): mean over views of 100 * |mask| / (H * W).

    ``masks`` is an (N, H, W) stack (or a sequence of (H, W) masks of any sizes); nonzero = in mask.
    """
    if isinstance(masks, torch.Tensor) or hasattr(masks, "shape"):
        m = torch.as_tensor(masks)
        if m.ndim != 3:
            raise ValueError(f"expected an (N, H, W) stack of masks, got shape {tuple(m.shape)}")
        masks = list(m)
    if len(masks) == 0:
        raise ValueError("AMCR of no masks is undefined")
    ratios = [100.0 * float(torch.as_tensor(m).bool().sum()) / torch.as_tensor(m).numel() for m in masks]
    return sum(ratios) / len(ratios)
