"""Forward rasterization: the torch backend (float64) against a brute-force per-pixel loop, and closed-form cases."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from inpaint360gs.core.gaussians import SH_C0, Gaussians
from inpaint360gs.render import Camera, available_backends, render
from inpaint360gs.render.backends import Splats
from inpaint360gs.render.torch_backend import rasterize_to_pixels_torch

D = torch.float64
BACKENDS = [b for b in ("torch", "numba") if b in available_backends()]


def brute_force(means2d, conics, opac, channels, radii, depths, width, height):
    """Per-pixel front-to-back loop written straight from the CUDA rules (float64 numpy, slow, obviously right)."""
    m, q, o, ch = (t.detach().double().numpy() for t in (means2d, conics, opac, channels))
    r = radii.numpy()
    order = np.argsort(depths.detach().numpy(), kind="stable")
    out = np.zeros((height, width, ch.shape[1]))
    alpha = np.zeros((height, width))
    for i in range(height):
        for j in range(width):
            tx, ty = j // 16, i // 16
            T, acc = 1.0, np.zeros(ch.shape[1])
            for g in order:
                if r[g] <= 0:
                    continue
                # binning: the 3-sigma square [u-r, u+r] must touch this pixel's 16x16 tile
                if not (m[g, 0] - r[g] < 16 * (tx + 1) and m[g, 0] + r[g] >= 16 * tx):
                    continue
                if not (m[g, 1] - r[g] < 16 * (ty + 1) and m[g, 1] + r[g] >= 16 * ty):
                    continue
                dx, dy = m[g, 0] - (j + 0.5), m[g, 1] - (i + 0.5)
                power = -0.5 * (q[g, 0] * dx * dx + q[g, 2] * dy * dy) - q[g, 1] * dx * dy
                if power > 0:
                    continue
                a = min(0.99, o[g] * math.exp(power))
                if a < 1.0 / 255.0:
                    continue
                test_t = T * (1 - a)
                if test_t < 1e-4:
                    break
                acc += ch[g] * a * T
                T = test_t
            out[i, j] = acc
            alpha[i, j] = 1 - T
    return out, alpha


def random_2d(n, width, height, seed, dtype=D):
    gen = torch.Generator().manual_seed(seed)
    means2d = torch.rand(n, 2, generator=gen, dtype=dtype) * torch.tensor([width + 20, height + 20], dtype=dtype) - 10
    sig = torch.exp(torch.randn(n, 2, generator=gen, dtype=dtype) * 0.6 + 0.7)
    rho = (torch.rand(n, generator=gen, dtype=dtype) - 0.5) * 1.6
    a, c, b = sig[:, 0] ** 2 + 0.3, sig[:, 1] ** 2 + 0.3, rho * sig[:, 0] * sig[:, 1]
    det = a * c - b * b
    conics = torch.stack([c / det, -b / det, a / det], -1)
    mid = 0.5 * (a + c)
    radii = torch.ceil(3 * torch.sqrt(mid + torch.sqrt(torch.clamp_min(mid * mid - det, 0.1)))).int()
    opac = torch.rand(n, generator=gen, dtype=dtype) * 0.95 + 0.05
    opac[:3] = 1.0  # exercise the 0.99 clamp
    channels = torch.rand(n, 5, generator=gen, dtype=dtype)
    depths = torch.rand(n, generator=gen, dtype=dtype) * 5 + 1
    radii[-2:] = 0  # culled entries are ignored
    return means2d, conics, opac, channels, radii, depths


def splats_of(means2d, conics, opac, channels, radii, depths, W, H):
    return Splats(means2d, conics, opac, radii, depths, W, H), channels


@pytest.mark.parametrize("seed", [0, 1])
def test_torch_backend_float64_matches_brute_force(seed):
    W, H = 40, 36  # not a multiple of the tile size
    args = random_2d(60, W, H, seed)
    img, alpha = rasterize_to_pixels_torch(*splats_of(*args, W, H))
    ref_img, ref_alpha = brute_force(*args, W, H)
    assert alpha.max() > 0.9  # the scene really has opaque regions that stop early
    np.testing.assert_allclose(img.numpy(), ref_img, atol=1e-12)
    np.testing.assert_allclose(alpha.numpy(), ref_alpha, atol=1e-12)


@pytest.mark.parametrize("seed", [2])
def test_torch_backend_small_batches_match(seed):
    """Tiles are batched by list length; a tiny batch budget must not change the image."""
    W, H = 40, 36
    args = random_2d(60, W, H, seed)
    img, alpha = rasterize_to_pixels_torch(*splats_of(*args, W, H))
    img2, alpha2 = rasterize_to_pixels_torch(*splats_of(*args, W, H), chunk_elems=1)
    assert torch.equal(img, img2) and torch.equal(alpha, alpha2)


def test_numba_forward_matches_brute_force():
    if "numba" not in available_backends():
        pytest.skip("numba not installed")
    from inpaint360gs.render.numba_backend import rasterize_to_pixels_numba

    W, H = 40, 36
    args = random_2d(60, W, H, 3, dtype=torch.float32)
    img, alpha = rasterize_to_pixels_numba(*splats_of(*args, W, H))
    ref_img, ref_alpha = brute_force(*args, W, H)
    np.testing.assert_allclose(img.numpy(), ref_img, atol=2e-5)
    np.testing.assert_allclose(alpha.numpy(), ref_alpha, atol=2e-5)


def _camera(dtype=D, width=48, height=40) -> Camera:
    return Camera(torch.eye(3, dtype=dtype), torch.zeros(3, dtype=dtype), 60.0, 60.0, width / 2, height / 2, width, height)


def _gaussians(means, scale, opacity, rgb, dtype=D, features=None) -> Gaussians:
    means = torch.as_tensor(means, dtype=dtype).reshape(-1, 3)
    n = means.shape[0]
    rgb = torch.as_tensor(rgb, dtype=dtype).reshape(n, 3)
    return Gaussians(
        means=means,
        log_scales=torch.full((n, 3), math.log(scale), dtype=dtype),
        quats=torch.tensor([[1.0, 0, 0, 0]], dtype=dtype).repeat(n, 1),
        opacity_logits=torch.logit(torch.as_tensor(opacity, dtype=dtype).reshape(n)),
        sh0=((rgb - 0.5) / SH_C0).reshape(n, 1, 3),
        shN=torch.zeros(n, 15, 3, dtype=dtype),
        features=features,
    )


def _centre_pixel_gaussian_means(cam: Camera, z: float, i: int, j: int):
    """World point whose projection is exactly the centre of pixel (i, j)."""
    return [(j + 0.5 - cam.cx) * z / cam.fx, (i + 0.5 - cam.cy) * z / cam.fy, z]


@pytest.mark.parametrize("backend", BACKENDS)
def test_depth_of_single_gaussian_is_z_times_alpha(backend):
    dt = D if backend == "torch" else torch.float32
    cam = _camera(dt)
    z = 3.0
    g = _gaussians(_centre_pixel_gaussian_means(cam, z, 20, 24), 0.08, 0.5, [0.2, 0.4, 0.6], dt)
    out = render(g, cam, backend=backend)
    tol = 1e-12 if dt == D else 2e-6
    assert out.alpha[20, 24].item() == pytest.approx(0.5, abs=tol)  # G = 1 at the centre
    assert torch.allclose(out.depth, z * out.alpha, atol=tol * 10)
    assert torch.allclose(out.color, torch.tensor([0.2, 0.4, 0.6], dtype=dt) * out.alpha[..., None], atol=tol * 10)
    assert out.radii.tolist() == [out.radii.item()] and out.radii.item() > 0
    assert out.depths.item() == pytest.approx(z)


@pytest.mark.parametrize("backend", BACKENDS)
def test_early_stop_and_alpha_clamp(backend):
    """Three stacked opaque Gaussians at one pixel centre: alpha 0.98 each; T = 1, 0.02, 4e-4, then 8e-6 < 1e-4 stops."""
    dt = D if backend == "torch" else torch.float32
    cam = _camera(dt)
    cols = [[1.0, 0, 0], [0, 1.0, 0], [0, 0, 1.0]]
    means = [_centre_pixel_gaussian_means(cam, z, 10, 10) for z in (2.0, 2.5, 3.0)]
    out = render(_gaussians(means, 0.05, [0.98] * 3, cols, dt), cam, backend=backend)
    tol = 1e-12 if dt == D else 2e-6
    expect = torch.tensor([0.98, 0.98 * 0.02, 0.0], dtype=dt)  # the third is not added
    assert torch.allclose(out.color[10, 10], expect, atol=tol)
    assert out.alpha[10, 10].item() == pytest.approx(1 - 0.02 * 0.02, abs=tol)
    assert out.depth[10, 10].item() == pytest.approx(2.0 * 0.98 + 2.5 * 0.98 * 0.02, abs=tol * 10)
    # opacity 1 is clamped to alpha 0.99
    one = render(_gaussians(means[:1], 0.05, [1.0 - 1e-12 if dt == D else 1.0], cols[:1], dt), cam, backend=backend)
    assert one.alpha[10, 10].item() == pytest.approx(0.99, abs=tol)


@pytest.mark.parametrize("backend", BACKENDS)
def test_features_render_like_colour_and_background(backend):
    dt = D if backend == "torch" else torch.float32
    cam = _camera(dt)
    gen = torch.Generator().manual_seed(4)
    n = 40
    means = torch.rand(n, 3, generator=gen, dtype=dt) * torch.tensor([2.0, 2.0, 2.0], dtype=dt) + torch.tensor([-1.0, -1.0, 2.0], dtype=dt)
    rgb = torch.rand(n, 3, generator=gen, dtype=dt)
    g = _gaussians(means, 0.1, torch.rand(n, generator=gen, dtype=dt) * 0.9 + 0.05, rgb, dt, features=rgb.clone())
    bg = torch.tensor([0.3, 0.1, 0.9], dtype=dt)
    out = render(g, cam, with_features=True, backend=backend, sh_degree=0)
    out_bg = render(g, cam, with_features=True, backend=backend, sh_degree=0, background=bg)
    tol = 1e-12 if dt == D else 1e-5
    assert torch.allclose(out.features, out.color, atol=tol)
    assert torch.allclose(out_bg.color, out.color + (1 - out.alpha)[..., None] * bg, atol=tol)
    assert torch.allclose(out_bg.features, out.features, atol=tol)  # no background on feature channels
    assert out.alpha.min() < 0.5 < out.alpha.max()


@pytest.mark.parametrize("backend", BACKENDS)
def test_everything_culled_renders_background(backend):
    dt = D if backend == "torch" else torch.float32
    cam = _camera(dt)
    g = _gaussians([[0, 0, -2.0], [50.0, 0, 2.0]], 0.1, [0.9, 0.9], [[1, 0, 0], [0, 1, 0]], dt)
    for p in g.tensors().values():
        p.requires_grad_(True)
    bg = torch.tensor([0.25, 0.5, 0.75], dtype=dt)
    out = render(g, cam, background=bg, backend=backend)
    assert out.radii.tolist() == [0, 0]
    assert torch.equal(out.alpha, torch.zeros_like(out.alpha)) and torch.equal(out.depth, torch.zeros_like(out.depth))
    assert torch.allclose(out.color, bg.expand_as(out.color))
    (out.color.sum() + out.depth.sum()).backward()
    for t in g.tensors().values():
        assert torch.equal(t.grad, torch.zeros_like(t.grad))
