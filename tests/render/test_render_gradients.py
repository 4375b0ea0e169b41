"""Gradients of every backend against the float64 torch reference on awkward random scenes."""

from __future__ import annotations

import math

import pytest
import torch

from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.render import Camera, available_backends, render

D = torch.float64
FAST = [b for b in ("numba",) if b in available_backends()]
PARAMS = ("means", "log_scales", "quats", "opacity_logits", "sh0", "shN", "features")


def awkward_scene(seed: int, n: int = 240, width: int = 64, height: int = 48) -> tuple[Gaussians, Camera]:
    """Random Gaussians in front of a camera plus ones behind it, off-screen, straddling the near plane and nearly flat."""
    gen = torch.Generator().manual_seed(seed)

    def rand(*s):
        return torch.rand(*s, generator=gen, dtype=D)

    def randn(*s):
        return torch.randn(*s, generator=gen, dtype=D)

    cam = Camera.look_at([0.2, -0.1, -0.5], [0.0, 0.0, 3.0], [0.0, -1.0, 0.0], 55.0, 55.0, width / 2 - 1.3, height / 2 + 0.7, width, height)
    cam = cam.to(dtype=D)
    p = torch.stack([(rand(n) - 0.5) * 3.0, (rand(n) - 0.5) * 2.4, 1.5 + 3.0 * rand(n)], -1)  # camera space
    p[:15, 2] = -1.0 - rand(15)  # behind the camera
    p[15:25, 0] = 8.0 + rand(10)  # far off-screen to the right
    p[25:30, 2] = 0.005  # in front of the camera but before the near plane (0.01)
    means = (p - cam.t) @ cam.R  # to world: R^T (p - t)
    log_scales = math.log(0.04) + 0.5 * randn(n, 3)
    log_scales[30:45, 2] = math.log(1e-6)  # nearly degenerate: flat discs, some seen edge-on
    quats = randn(n, 4)
    opacity_logits = 1.5 * randn(n)
    sh0 = randn(n, 1, 3) * 0.8
    shN = randn(n, 15, 3) * 0.15
    features = randn(n, 6)
    return Gaussians(means, log_scales, quats, opacity_logits, sh0, shN, features), cam


def loss_and_grads(g: Gaussians, cam: Camera, backend: str, dtype: torch.dtype, seed: int = 7):
    """Fixed random weighting of colour, depth, alpha and features (so every gradient path is used)."""
    params = g.map(lambda t: t.detach().to(dtype).clone().requires_grad_(True))
    out = render(params, cam.to(dtype=dtype), backend=backend, with_features=True, background=torch.tensor([0.1, 0.5, 0.9]))
    gen = torch.Generator().manual_seed(seed)
    H, W = out.alpha.shape
    weights = [torch.randn(*s, generator=gen, dtype=D).to(dtype) for s in ((H, W, 3), (H, W), (H, W), (H, W, 6))]
    loss = sum((o * w).sum() for o, w in zip((out.color, out.depth, out.alpha, out.features), weights))
    loss.backward()
    grads = {k: getattr(params, k).grad.double() for k in PARAMS}
    grads["means2d"] = out.means2d.grad.double()
    return out, grads


def rel(a: torch.Tensor, b: torch.Tensor) -> float:
    a, b = a.detach(), b.detach()
    return float((a.double() - b.double()).norm() / b.double().norm().clamp_min(1e-30))


@pytest.fixture(scope="module", params=[0, 1])
def reference(request):
    g, cam = awkward_scene(request.param)
    out, grads = loss_and_grads(g, cam, "torch", D)
    radii = out.radii
    assert (radii[:30] == 0).all() and (radii > 0).sum() > 150  # the awkward ones are culled, most others visible
    return g, cam, out, grads


@pytest.mark.parametrize("backend", ["torch", *FAST])
def test_float32_gradients_match_float64_reference(reference, backend):
    g, cam, ref_out, ref_grads = reference
    out, grads = loss_and_grads(g, cam, backend, torch.float32)
    for name in ("color", "depth", "alpha", "features"):
        assert rel(getattr(out, name), getattr(ref_out, name)) < 1e-5, name
    assert torch.equal(out.radii, ref_out.radii)
    for k, ref in ref_grads.items():
        assert ref.norm() > 0, k
        assert torch.isfinite(grads[k]).all(), k
        assert rel(grads[k], ref) < 1e-4, (k, rel(grads[k], ref))


@pytest.mark.parametrize("name", PARAMS)
def test_reference_gradient_is_the_true_derivative(reference, name):
    """Directional central difference of the float64 loss equals the autograd gradient (checks the reference itself).

    The step is tiny because the loss has jumps (alpha thresholds, integer radii) that a larger step may cross.
    """
    g, cam, _, grads = reference
    direction = torch.randn(getattr(g, name).shape, generator=torch.Generator().manual_seed(3), dtype=D)
    eps = 1e-7

    def loss_at(t):
        shifted = g.map(lambda x: x.clone())
        setattr(shifted, name, getattr(shifted, name) + t * direction)
        with torch.no_grad():
            out = render(shifted, cam, backend="torch", with_features=True, background=torch.tensor([0.1, 0.5, 0.9]))
        gen = torch.Generator().manual_seed(7)
        H, W = out.alpha.shape
        weights = [torch.randn(*s, generator=gen, dtype=D) for s in ((H, W, 3), (H, W), (H, W), (H, W, 6))]
        return float(sum((o * w).sum() for o, w in zip((out.color, out.depth, out.alpha, out.features), weights)))

    fd = (loss_at(eps) - loss_at(-eps)) / (2 * eps)
    analytic = float((grads[name] * direction).sum())
    assert fd == pytest.approx(analytic, rel=1e-5, abs=1e-6)


@pytest.mark.skipif(not FAST, reason="numba not installed")
def test_numba_gradients_are_deterministic_across_runs_and_threads():
    import numba

    g, cam = awkward_scene(5, n=150)
    _, a = loss_and_grads(g, cam, "numba", torch.float32)
    _, b = loss_and_grads(g, cam, "numba", torch.float32)
    before = torch.get_num_threads()
    try:
        torch.set_num_threads(1)  # the backend follows torch's thread count
        _, c = loss_and_grads(g, cam, "numba", torch.float32)
        assert numba.get_num_threads() == 1
    finally:
        torch.set_num_threads(before)
    for k in a:
        assert torch.equal(a[k], b[k]) and torch.equal(a[k], c[k]), k
