"""AbsGS's densification statistic (``means2d.absgrad``): the sum over a Gaussian's pixels of the
absolute value of each pixel's gradient of its 2D centre, on every CPU backend."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from inpaint360gs.render.backends import Splats
from inpaint360gs.render.numba_backend import rasterize_to_pixels_numba
from inpaint360gs.render.tiles import ALPHA_MIN
from inpaint360gs.render.torch_backend import rasterize_to_pixels_torch

BACKENDS = {"torch": (rasterize_to_pixels_torch, torch.float64), "numba": (rasterize_to_pixels_numba, torch.float32)}


def _grads(backend: str, means2d, conics, opacities, channels, radii, depths, width, height, loss):
    raster, dtype = BACKENDS[backend]
    m = means2d.to(dtype).clone().requires_grad_()
    img, alpha = raster(Splats(m, conics.to(dtype), opacities.to(dtype), radii, depths.to(dtype), width, height, absgrad=True), channels.to(dtype))
    loss(img.double(), alpha.double()).backward()
    return m.grad.double(), m.absgrad.double()


@pytest.mark.parametrize("backend", sorted(BACKENDS))
def test_one_centred_gaussian_pulls_both_ways_its_mean_gradient_cancels_its_absolute_one_does_not(backend):
    """Closed form: one isotropic Gaussian centred on a pixel centre, loss = sum of the image. The
    per-pixel gradients of its x centre are -o g(p) a dx and cancel in pairs; their absolute sum is
    sum o g(p) a |dx| over the pixels it covers (alpha >= 1/255)."""
    W, H, sigma, o = 40, 32, 3.0, 0.5
    mx, my = 20.5, 16.5  # a pixel centre: the pixels lie symmetrically about it
    a = 1.0 / sigma**2
    means2d = torch.tensor([[mx, my]], dtype=torch.float64)
    conics = torch.tensor([[a, 0.0, a]], dtype=torch.float64)
    grad, absgrad = _grads(
        backend, means2d, conics, torch.tensor([o]), torch.ones(1, 1), torch.tensor([12], dtype=torch.int32),
        torch.tensor([2.0]), W, H, lambda img, alpha: img.sum(),
    )  # fmt: skip
    xs, ys = np.meshgrid(np.arange(W) + 0.5, np.arange(H) + 0.5)
    dx, dy = mx - xs, my - ys
    g = np.exp(-0.5 * a * (dx**2 + dy**2))
    covered = o * g >= ALPHA_MIN
    expect = [float((o * g * a * np.abs(dx))[covered].sum()), float((o * g * a * np.abs(dy))[covered].sum())]
    assert absgrad[0].tolist() == pytest.approx(expect, rel=2e-3)
    assert grad.abs().max().item() < 1e-3 * min(expect)


def test_numba_absolute_gradients_match_the_float64_reference():
    """Random overlapping Gaussians and an L2 loss on colour and alpha: the numba kernels' absolute
    sums agree with the torch backend's (float64, per-pixel autograd) to float32 rounding."""
    gen = torch.Generator().manual_seed(3)
    N, W, H = 60, 45, 34
    means2d = torch.rand(N, 2, generator=gen, dtype=torch.float64) * torch.tensor([W, H], dtype=torch.float64)
    s = 1.0 / (1.0 + 6.0 * torch.rand(N, 2, generator=gen, dtype=torch.float64)) ** 2
    conics = torch.stack([s[:, 0], 0.3 * torch.sqrt(s[:, 0] * s[:, 1]), s[:, 1]], -1)
    opac = 0.2 + 0.7 * torch.rand(N, generator=gen, dtype=torch.float64)
    colours = torch.rand(N, 3, generator=gen, dtype=torch.float64)
    depths = 1.0 + torch.rand(N, generator=gen, dtype=torch.float64)
    radii = torch.full((N,), 16, dtype=torch.int32)
    target = torch.rand(H, W, 3, generator=gen, dtype=torch.float64)
    loss = lambda img, alpha: ((img - target) ** 2).sum() + 0.3 * alpha.sum()  # noqa: E731
    ref_grad, ref_abs = _grads("torch", means2d, conics, opac, colours, radii, depths, W, H, loss)
    grad, absgrad = _grads("numba", means2d, conics, opac, colours, radii, depths, W, H, loss)
    assert torch.allclose(grad, ref_grad, rtol=1e-4, atol=1e-4)
    assert torch.allclose(absgrad, ref_abs, rtol=1e-4, atol=1e-4)
    assert bool((absgrad >= grad.abs() - 1e-4).all())  # |sum| <= sum |.|
    assert bool((ref_abs > 2 * ref_grad.abs() + 1e-3).any())  # and here it is far from it
