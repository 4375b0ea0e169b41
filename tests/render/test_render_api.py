"""render(): backend choice, input validation (InputError), means2d gradient, numba cache folder, gsplat on CUDA."""

from __future__ import annotations

import math
from pathlib import Path

import pytest
import torch

from inpaint360gs.core.errors import InputError
from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.render import Camera, available_backends, render
from inpaint360gs.render.backends import RasterizerBackend, backend_names, get_backend, resolve_backend


def _scene(n=30, dtype=torch.float32, features=True, seed=0):
    gen = torch.Generator().manual_seed(seed)
    means = torch.randn(n, 3, generator=gen) * 0.4 + torch.tensor([0.0, 0.0, 3.0])
    g = Gaussians(
        means=means,
        log_scales=torch.full((n, 3), math.log(0.08)),
        quats=torch.randn(n, 4, generator=gen),
        opacity_logits=torch.randn(n, generator=gen),
        sh0=torch.randn(n, 1, 3, generator=gen),
        shN=torch.randn(n, 15, 3, generator=gen) * 0.1,
        features=torch.randn(n, 4, generator=gen) if features else None,
    ).to(dtype=dtype)
    cam = Camera(torch.eye(3), torch.zeros(3), 40.0, 40.0, 24.0, 16.0, 48, 32)
    return g, cam


def test_available_backends_and_auto_choice():
    avail = available_backends()
    assert "torch" in avail
    assert resolve_backend("auto", torch.device("cpu"), torch.float64).name == "torch"  # float64 = the reference
    expect = "numba" if "numba" in avail else "torch"
    assert resolve_backend("auto", torch.device("cpu"), torch.float32).name == expect


def test_backend_registry_is_one_list_of_interface_implementations():
    names = backend_names()
    assert set(names) >= {"torch", "numba", "gsplat"}
    for n in names:  # every registered module implements the interface under its own name
        b = get_backend(n)
        assert isinstance(b, RasterizerBackend) and b.name == n
    with pytest.raises(InputError, match="unknown rasterizer backend"):
        get_backend("opengl")
    if not torch.cuda.is_available():
        with pytest.raises(InputError, match="not available|runs on"):
            resolve_backend("gsplat", torch.device("cpu"), torch.float32)


@pytest.mark.parametrize(
    "change, message",
    [
        (lambda g, c: (_replace(g, means=g.means[:, :2]), c, {}), "means"),
        (lambda g, c: (_replace(g, quats=g.quats[:-1]), c, {}), "quats"),
        (lambda g, c: (_replace(g, shN=g.shN[:, :, :2]), c, {}), "shN"),
        (lambda g, c: (_replace(g, features=None), c, {"with_features": True}), "features"),
        (lambda g, c: (g, c, {"sh_degree": 4}), "sh_degree"),
        (lambda g, c: (g, c, {"backend": "vulkan"}), "unknown rasterizer backend"),
        (lambda g, c: (g, c, {"background": torch.zeros(4)}), "background"),
        (lambda g, c: (g, Camera(c.R, c.t, 40.0, 40.0, 1.0, 1.0, 0, 32), {}), "camera"),
    ],
)
def test_bad_input_raises_input_error(change, message):
    g, cam = _scene()
    g2, cam2, kwargs = change(g, cam)
    with pytest.raises(InputError, match=message):
        render(g2, cam2, **kwargs)


def _replace(g: Gaussians, **kw) -> Gaussians:
    d = g.tensors()
    d.update(kw)
    return Gaussians(**{k: v for k, v in d.items()})


def test_gsplat_backend_on_cpu_is_refused():
    g, cam = _scene()
    with pytest.raises(InputError, match="gsplat"):
        render(g, cam, backend="gsplat")


@pytest.mark.parametrize("backend", [b for b in ("torch", "numba") if b in available_backends()])
def test_means2d_gradient_is_retained_and_outputs_have_the_documented_shapes(backend):
    g, cam = _scene()
    g = g.map(lambda t: t.requires_grad_(True))
    out = render(g, cam, backend=backend, with_features=True)
    assert out.color.shape == (32, 48, 3) and out.depth.shape == (32, 48) and out.alpha.shape == (32, 48)
    assert out.features.shape == (32, 48, 4)
    assert out.means2d.shape == (30, 2) and out.radii.shape == (30,) and out.depths.shape == (30,)
    (out.color.sum() + out.depth.sum()).backward()
    assert out.means2d.grad is not None and out.means2d.grad.abs().sum() > 0
    assert render(g, cam, backend=backend).features is None


def test_numba_cache_dir_fallback(tmp_path: Path, monkeypatch):
    pytest.importorskip("numba")
    import inpaint360gs.render.numba_cache as nb

    pkg = tmp_path / "pkg"
    pkg.mkdir()
    assert nb.cache_dir_for(pkg, {}) is None  # writable: numba's default, beside the sources
    monkeypatch.setattr(nb.os, "access", lambda path, mode: False)  # a read-only site-packages (even as root)
    assert nb.cache_dir_for(pkg, {"XDG_CACHE_HOME": str(tmp_path / "c")}) == str(tmp_path / "c" / "inpaint360gs" / "numba")
    assert nb.cache_dir_for(pkg, {"NUMBA_CACHE_DIR": "/x"}) is None  # the user's choice wins


@pytest.mark.cuda
@pytest.mark.skipif(not torch.cuda.is_available() or "gsplat" not in available_backends(), reason="needs CUDA and gsplat")
def test_gsplat_matches_torch_reference_on_cuda():
    g, cam = _scene(n=200, features=True, seed=3)
    ref = render(g.to(dtype=torch.float64), cam, backend="torch", with_features=True)
    out = render(g.to(device="cuda"), cam, backend="gsplat", with_features=True)
    for name in ("color", "depth", "alpha", "features"):
        a, b = getattr(out, name).double().cpu(), getattr(ref, name)
        assert float((a - b).norm() / b.norm()) < 1e-3, name
