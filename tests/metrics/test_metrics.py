"""Image metrics and the training loss against closed forms and float64 references."""

from __future__ import annotations

import math

import pytest
import torch
import torch.nn.functional as F

from inpaint360gs.gs.loss import SSIM_C1, SSIM_C2, photometric_loss, ssim_map
from inpaint360gs.metrics import psnr, ssim


def rand_img(seed: int, h: int = 40, w: int = 52) -> torch.Tensor:
    return torch.rand(h, w, 3, generator=torch.Generator().manual_seed(seed))


def reference_ssim_map(x: torch.Tensor, y: torch.Tensor, pad: str) -> torch.Tensor:
    """Float64 SSIM map with a full 11x11 Gaussian window (Wang et al. 2004), same size as the
    image: ``pad="zeros"`` like 3DGS, ``"reflect"`` like torchmetrics."""
    x = x.double().permute(2, 0, 1)[:, None]
    y = y.double().permute(2, 0, 1)[:, None]
    r = torch.arange(11, dtype=torch.float64) - 5
    g = torch.exp(-(r**2) / (2 * 1.5**2))
    g = g / g.sum()
    win = (g[:, None] * g[None, :])[None, None]
    f = lambda t: F.conv2d(F.pad(t, (5, 5, 5, 5), mode="constant" if pad == "zeros" else pad), win)  # noqa: E731
    mx, my = f(x), f(y)
    vx, vy, cxy = f(x * x) - mx**2, f(y * y) - my**2, f(x * y) - mx * my
    return ((2 * mx * my + SSIM_C1) * (2 * cxy + SSIM_C2)) / ((mx**2 + my**2 + SSIM_C1) * (vx + vy + SSIM_C2))


def test_psnr_of_a_known_mse():
    ref = rand_img(0).double() * 0.8 + 0.1
    assert psnr(ref + 0.05, ref) == pytest.approx(-10 * math.log10(0.05**2), abs=1e-5)
    img = (ref + 0.03 * torch.randn(ref.shape, generator=torch.Generator().manual_seed(1))).clamp(0, 1)
    mse = ((img.double() - ref.double()) ** 2).mean().item()
    assert psnr(img, ref) == pytest.approx(10 * math.log10(1 / mse), abs=1e-5)
    # renders that overshoot [0, 1] are clamped first
    assert psnr(torch.full((8, 8, 3), 1.7), torch.full((8, 8, 3), 0.9)) == pytest.approx(-10 * math.log10(0.01), abs=1e-5)


def test_ssim_closed_forms():
    x = rand_img(2)
    assert ssim(x, x) == pytest.approx(1.0, abs=1e-12)
    a, b = 0.3, 0.7  # constant images: zero variances, SSIM = luminance term
    expect = (2 * a * b + SSIM_C1) / (a * a + b * b + SSIM_C1)
    assert ssim(torch.full((32, 32, 3), a), torch.full((32, 32, 3), b)) == pytest.approx(expect, abs=1e-7)


def test_ssim_matches_float64_reference():
    x, y = rand_img(3), (rand_img(3) * 0.7 + rand_img(4) * 0.3)
    assert ssim(x, y) == pytest.approx(reference_ssim_map(x, y, pad="reflect").mean().item(), abs=1e-6)


def test_training_ssim_is_the_3dgs_one_and_differentiable():
    x, y = rand_img(5).requires_grad_(True), rand_img(6) * 0.5 + rand_img(5).detach() * 0.5
    m = ssim_map(x.double(), y.double())
    ref = reference_ssim_map(x.detach(), y, pad="zeros")[:, 0].permute(1, 2, 0)
    assert torch.allclose(m, ref, atol=1e-12)  # separable window == 2D window, zero padding like 3DGS
    # away from the border every convention agrees
    other = reference_ssim_map(x.detach(), y, pad="reflect")[:, 0].permute(1, 2, 0)
    assert torch.allclose(m[5:-5, 5:-5], other[5:-5, 5:-5], atol=1e-12)
    loss, l1, s = photometric_loss(x, y, 0.2)
    assert loss.item() == pytest.approx(0.8 * (x - y).abs().mean().item() + 0.2 * (1 - ssim_map(x, y).mean().item()), rel=1e-6)
    loss.backward()
    assert x.grad is not None and torch.isfinite(x.grad).all() and x.grad.abs().sum() > 0


def test_shape_errors():
    with pytest.raises(ValueError):
        psnr(torch.zeros(4, 4, 3), torch.zeros(4, 5, 3))
