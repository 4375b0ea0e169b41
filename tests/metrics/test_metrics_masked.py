"""The three mask conventions (full, masked_*, roi_*) and AMCR against hand computations."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch
from torchmetrics.functional.image import structural_similarity_index_measure

from inpaint360gs.metrics import (
    amcr,
    lpips,
    lpips_map,
    masked_lpips,
    masked_lpips_alex,
    masked_psnr,
    masked_ssim,
    psnr,
    roi_lpips,
    roi_lpips_alex,
    roi_psnr,
    roi_ssim,
    roi_undefined_reason,
    ssim,
    ssim_index_map,
)
from inpaint360gs.metrics.masked import EMPTY_ROI_REASON

H, W = 48, 64


def rand_img(seed: int) -> torch.Tensor:
    return torch.rand(H, W, 3, generator=torch.Generator().manual_seed(seed), dtype=torch.float64) * 0.8 + 0.1


def box_mask(y0: int, y1: int, x0: int, x1: int) -> torch.Tensor:
    m = torch.zeros(H, W, dtype=torch.bool)
    m[y0:y1, x0:x1] = True
    return m


def test_psnr_conventions_by_hand():
    ref, delta = rand_img(0), 0.05
    img = ref + delta  # off by delta everywhere (stays inside [0, 1])
    mask = box_mask(10, 20, 5, 35)  # 300 of 3072 pixels
    k = int(mask.sum())
    # full frame: MSE = delta^2 (torchmetrics' PSNR carries ~1e-6 dB of rounding)
    assert psnr(img, ref) == pytest.approx(-10 * math.log10(delta**2), abs=1e-5)
    # masked (paper's code): outside the mask both images are 0, so MSE = delta^2 * k / (H W)
    assert masked_psnr(img, ref, mask) == pytest.approx(-10 * math.log10(delta**2 * k / (H * W)), abs=1e-5)
    # roi: MSE over the mask pixels only, whatever happens outside
    wild = torch.where(mask[..., None], img, 1.0 - ref)
    assert roi_psnr(wild, ref, mask) == pytest.approx(-10 * math.log10(delta**2), abs=1e-9)
    # equal on every evaluated pixel: +inf, as in the paper's code
    assert masked_psnr(ref, ref, mask) == math.inf
    assert roi_psnr(torch.where(mask[..., None], ref, 0.0), ref, mask) == math.inf
    assert masked_psnr(torch.where(mask[..., None], ref, 0.0), ref, mask) == math.inf


def test_ssim_matches_torchmetrics_and_roi_averages_its_map():
    x, y = rand_img(1), rand_img(1) * 0.6 + rand_img(2) * 0.4
    _, full = structural_similarity_index_measure(
        x.permute(2, 0, 1)[None], y.permute(2, 0, 1)[None], data_range=1.0, kernel_size=11, sigma=1.5, return_full_image=True
    )
    smap = ssim_index_map(x, y)
    assert smap.shape == (H, W, 3)
    assert torch.allclose(smap, full[0].permute(1, 2, 0), atol=1e-12)
    assert ssim(x, y) == pytest.approx(full.mean().item(), abs=1e-12)
    everything = torch.ones(H, W, dtype=torch.bool)
    assert roi_ssim(x, y, everything) == pytest.approx(ssim(x, y), abs=1e-12)
    mask = box_mask(3, 30, 7, 50)
    assert roi_ssim(x, y, mask) == pytest.approx(smap[mask].mean().item(), abs=1e-12)


def test_ssim_conventions_by_hand():
    # images equal on the left half, different on the right: the SSIM window (radius 5) at columns
    # < 32 - 5 sees only equal pixels, so the map is exactly 1 there
    x = rand_img(3)
    y = x.clone()
    y[:, 32:] = rand_img(4)[:, 32:]
    left = box_mask(0, H, 0, 26)
    assert roi_ssim(x, y, left) == pytest.approx(1.0, abs=1e-12)
    # masked: both images are 0 outside the mask, the right half is masked out -> identical -> 1
    assert masked_ssim(x, y, left) == pytest.approx(1.0, abs=1e-12)
    assert masked_ssim(x, y, box_mask(0, H, 30, 40)) < 0.99
    # constant images: zero variances, SSIM = luminance term (2ab + C1) / (a^2 + b^2 + C1) everywhere
    a, b, c1 = 0.3, 0.7, 0.01**2
    expect = (2 * a * b + c1) / (a * a + b * b + c1)
    ca, cb = torch.full((H, W, 3), a, dtype=torch.float64), torch.full((H, W, 3), b, dtype=torch.float64)
    assert roi_ssim(ca, cb, box_mask(5, 9, 5, 9)) == pytest.approx(expect, abs=1e-12)


def test_lpips_conventions():
    x, y = rand_img(5).float(), rand_img(6).float()
    mask = box_mask(8, 40, 16, 48)
    # masked: differences only outside the mask vanish after masking -> exactly 0
    y_in = torch.where(mask[..., None], x, y)
    assert masked_lpips(y_in, x, mask) == 0.0
    assert masked_lpips_alex(y_in, x, mask) == 0.0
    # masked LPIPS is LPIPS of the mask-multiplied images
    m = mask[..., None].float()
    with torch.inference_mode():
        direct = lpips((x * m).permute(2, 0, 1), (y * m).permute(2, 0, 1)).item()
        full = lpips(x.permute(2, 0, 1), y.permute(2, 0, 1)).item()
        smap = lpips_map(x.permute(2, 0, 1), y.permute(2, 0, 1))[0, 0]
    assert masked_lpips(x, y, mask) == pytest.approx(direct, abs=1e-7)
    # roi: the spatial map averaged over the mask; the ROI and its complement add up to the whole
    # map, whose mean is the VGG value at sizes divisible by 16 (integer upsampling factors)
    inside, outside = roi_lpips(x, y, mask), roi_lpips(x, y, ~mask)
    k = int(mask.sum())
    assert inside == pytest.approx(smap[mask].double().mean().item(), rel=1e-6)
    assert (inside * k + outside * (H * W - k)) / (H * W) == pytest.approx(full, rel=1e-5)
    assert roi_lpips_alex(x, y, mask) == pytest.approx(roi_lpips(x, y, mask, net="alex"), abs=0)


def test_empty_roi_is_none_with_a_reason():
    x, y = rand_img(7), rand_img(8)
    empty = torch.zeros(H, W, dtype=torch.bool)
    assert roi_psnr(x, y, empty) is None
    assert roi_ssim(x, y, empty) is None
    assert roi_lpips(x.float(), y.float(), empty) is None
    assert roi_undefined_reason(empty) == EMPTY_ROI_REASON
    assert roi_undefined_reason(box_mask(0, 1, 0, 1)) is None
    # masked metrics stay defined (both images all zero), as in the paper's code
    assert masked_psnr(x, y, empty) == math.inf
    assert masked_ssim(x, y, empty) == pytest.approx(1.0, abs=1e-12)


def test_mask_shape_is_checked():
    with pytest.raises(ValueError):
        masked_psnr(rand_img(0), rand_img(1), torch.ones(H, W + 1, dtype=torch.bool))


def test_amcr_by_hand():
    masks = torch.zeros(2, 4, 5, dtype=torch.bool)
    masks[0, 0, :] = True  # 5 of 20 pixels: 25 %
    masks[1, :2, :] = True  # 10 of 20 pixels: 50 %
    assert amcr(masks) == pytest.approx(37.5)
    assert amcr(masks.numpy()) == pytest.approx(37.5)
    # views of different sizes: the mean of per-view percentages, not of pooled pixels
    assert amcr([np.ones((2, 2), bool), np.zeros((10, 10), bool)]) == pytest.approx(50.0)
    with pytest.raises(ValueError):
        amcr(torch.zeros(0, 4, 5, dtype=torch.bool))
    with pytest.raises(ValueError):
        amcr(torch.zeros(4, 5, dtype=torch.bool))
