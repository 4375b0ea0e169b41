"""Per-pixel contributions (render/contributions.py): W @ channels equals the rasterized channels, for the
numba and torch backends; the weights sum to alpha; pruning loses exactly the dropped weight; the
differentiable product has the rasterizer's feature gradient."""

from __future__ import annotations

import math

import inpaint360gs  # noqa: F401  (first: sets OMP_WAIT_POLICY before torch starts its thread pool)
import pytest
import torch

from inpaint360gs.core.errors import InputError
from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.render import Camera, available_backends, render
from inpaint360gs.render.contributions import contributions, sparse_render

BACKENDS = [b for b in ("numba", "torch") if b in available_backends()]


def _model(n=400, f=16, seed=0, dtype=torch.float32, width=70, height=45):
    """Random Gaussians in front of a camera whose image is not a multiple of the 16-pixel tile."""
    gen = torch.Generator().manual_seed(seed)
    means = torch.randn(n, 3, generator=gen, dtype=torch.float64) * torch.tensor([0.9, 0.6, 0.5], dtype=torch.float64) + torch.tensor([0.0, 0.0, 3.0], dtype=torch.float64)
    g = Gaussians(
        means=means,
        log_scales=torch.log(torch.rand(n, 3, generator=gen, dtype=torch.float64) * 0.12 + 0.02),
        quats=torch.randn(n, 4, generator=gen, dtype=torch.float64),
        opacity_logits=torch.randn(n, generator=gen, dtype=torch.float64) * 2 + 1,
        sh0=torch.randn(n, 1, 3, generator=gen, dtype=torch.float64),
        shN=torch.zeros(n, 0, 3, dtype=torch.float64),
        features=torch.randn(n, f, generator=gen, dtype=torch.float64),
    ).to(dtype=dtype)
    cam = Camera(torch.eye(3), torch.zeros(3), 50.0, 50.0, width / 2 + 0.3, height / 2 - 0.2, width, height)
    return g, cam


@pytest.mark.parametrize("backend", BACKENDS)
def test_contributions_reproduce_rasterized_features_depth_and_alpha(backend):
    dtype = torch.float32 if backend == "numba" else torch.float64
    g, cam = _model(dtype=dtype)
    c = contributions(g, cam, backend=backend)
    out = render(g, cam, with_features=True, backend=backend)
    assert c.nnz > 1000 and c.indptr.shape == (cam.width * cam.height + 1,)
    scale = g.features.abs().max().item()
    tol = 1e-5 if dtype == torch.float32 else 1e-12
    assert (c.render(g.features).double() - out.features.double()).abs().max().item() <= tol * scale * 10
    assert (c.render(out.depths[:, None]).double()[..., 0] - out.depth.double()).abs().max().item() <= tol * 10 * out.depths.abs().max().item()
    assert (c.alpha().double() - out.alpha.double()).abs().max().item() <= tol * 10
    # each row lists distinct Gaussians with weights in (0, 0.99]
    assert bool((c.vals > 0).all()) and float(c.vals.max()) <= 0.99 + 1e-6
    rows = c.rows()
    assert len(set(zip(rows.tolist(), c.cols.tolist()))) == c.nnz
    # the sparse-matrix view is the same operator
    dense = c.matrix().to_dense()
    assert torch.allclose(dense @ g.features.to(dense.dtype), c.render(g.features).reshape(-1, g.features.shape[1]), atol=1e-5)


@pytest.mark.skipif(len(BACKENDS) < 2, reason="needs numba")
def test_numba_and_torch_contributions_agree():
    g, cam = _model(seed=3)
    a = contributions(g, cam, backend="numba")
    b = contributions(g.to(dtype=torch.float64), cam, backend="torch")
    # the same (pixel, Gaussian) pairs up to entries at the 1/255 and T thresholds, where float32 and float64 may differ
    pa = set(zip(a.rows().tolist(), a.cols.tolist()))
    pb = set(zip(b.rows().tolist(), b.cols.tolist()))
    assert len(pa ^ pb) <= 0.002 * len(pa)
    assert (a.alpha().double() - b.alpha()).abs().max().item() < 2e-3


@pytest.mark.parametrize("backend", BACKENDS)
def test_pruning_drops_exactly_the_small_weights(backend):
    g, cam = _model(seed=1)
    if backend == "torch":
        g = g.to(dtype=torch.float64)
    full = contributions(g, cam, backend=backend)
    pruned = contributions(g, cam, backend=backend, min_weight=0.01)
    assert full.dropped is None and pruned.nnz < full.nnz
    assert float(pruned.vals.min()) >= 0.01
    kept = (full.vals >= 0.01).sum().item()
    assert pruned.nnz == kept
    # what is lost per pixel is the dropped weight, and rendering loses at most dropped * max |f|
    lost = full.alpha() - pruned.alpha()
    assert torch.allclose(lost.float(), pruned.dropped.float(), atol=1e-5)
    err = (full.render(g.features) - pruned.render(g.features)).abs().amax(-1)
    assert bool((err <= pruned.dropped * g.features.abs().max() + 1e-5).all())


def test_sparse_render_gradient_equals_rasterizer_feature_gradient():
    backend = BACKENDS[0]
    g, cam = _model(seed=2, n=250)
    c = contributions(g, cam, backend=backend)
    feats = g.features.clone().requires_grad_(True)
    target = torch.randn(cam.height, cam.width, feats.shape[1], generator=torch.Generator().manual_seed(5))

    mine = sparse_render(c, feats)
    ((mine - target) ** 2).sum().backward()
    g_mine = feats.grad.clone()

    feats.grad = None
    g2 = Gaussians(**{**g.tensors(), "features": feats})
    out = render(g2, cam, with_features=True, backend=backend)
    ((out.features - target) ** 2).sum().backward()
    assert torch.allclose(g_mine, feats.grad, rtol=1e-4, atol=1e-4 * g_mine.abs().max().item())


def test_empty_view_and_bad_threshold():
    g, _ = _model(n=20)
    behind = Camera(torch.eye(3), torch.tensor([0.0, 0.0, -10.0]), 50.0, 50.0, 20.0, 15.0, 40, 30)  # everything behind it
    c = contributions(g, behind)
    assert c.nnz == 0 and bool((c.alpha() == 0).all())
    assert c.render(g.features).shape == (30, 40, g.features.shape[1])
    with pytest.raises(InputError, match="min_weight"):
        contributions(g, behind, min_weight=math.nan)
