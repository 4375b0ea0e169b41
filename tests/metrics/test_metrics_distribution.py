"""Fréchet distance and KID against closed forms and hand computations; the FID Inception network
loaded strictly from a generated state dict (the real file cannot be downloaded here)."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import torch

from inpaint360gs.core.errors import InputError
from inpaint360gs.metrics import (
    FIDInceptionV3,
    feature_statistics,
    frechet_distance,
    frechet_distance_features,
    inception_features,
    kernel_inception_distance,
    load_fid_inception,
)
from inpaint360gs.metrics.inception import _avg_pool_no_pad


def random_rotation(d: int, seed: int) -> np.ndarray:
    q, r = np.linalg.qr(np.random.default_rng(seed).normal(size=(d, d)))
    return q * np.sign(np.diag(r))


def test_frechet_distance_closed_forms():
    rng = np.random.default_rng(0)
    d = 6
    mu1, mu2 = rng.normal(size=d), rng.normal(size=d)
    a, b = rng.uniform(0.1, 3, size=d), rng.uniform(0.1, 3, size=d)
    # diagonal covariances: tr(S1 + S2 - 2 (S1 S2)^1/2) = sum (sqrt a - sqrt b)^2
    expect = np.sum((mu1 - mu2) ** 2) + np.sum((np.sqrt(a) - np.sqrt(b)) ** 2)
    assert frechet_distance(mu1, np.diag(a), mu2, np.diag(b)) == pytest.approx(expect, rel=1e-10)
    # commuting covariances (same eigenvectors): the same value
    q = random_rotation(d, 1)
    assert frechet_distance(mu1, q @ np.diag(a) @ q.T, mu2, q @ np.diag(b) @ q.T) == pytest.approx(expect, rel=1e-9)
    # one dimension: (m1 - m2)^2 + (s1 - s2)^2 for standard deviations s1, s2
    assert frechet_distance([1.0], [[4.0]], [3.0], [[9.0]]) == pytest.approx(4.0 + 1.0)
    assert frechet_distance(mu1, np.diag(a), mu1, np.diag(a)) == pytest.approx(0.0, abs=1e-12)


def test_sqrtm_fallbacks_like_pytorch_fid(monkeypatch):
    from inpaint360gs.metrics import distribution

    a, b, eps = np.array([1.0, 2.0, 0.5]), np.array([3.0, 0.25, 1.0]), 1e-3
    real_sqrtm, calls = distribution._sqrtm, []

    def not_finite_first(m):
        calls.append(m)
        return np.full_like(m, np.inf) if len(calls) == 1 else real_sqrtm(m)

    monkeypatch.setattr(distribution, "_sqrtm", not_finite_first)
    # a non-finite root: retried with eps I added to both covariances
    expect = np.sum(a + b - 2 * np.sqrt((a + eps) * (b + eps)))
    assert frechet_distance(np.zeros(3), np.diag(a), np.zeros(3), np.diag(b), eps=eps) == pytest.approx(expect, rel=1e-12)
    assert np.allclose(calls[1], np.diag((a + eps) * (b + eps)))
    # small imaginary parts are dropped, large ones on the diagonal are an error
    monkeypatch.setattr(distribution, "_sqrtm", lambda m: real_sqrtm(m) + 1e-4j)
    assert frechet_distance(np.zeros(3), np.diag(a), np.zeros(3), np.diag(b)) == pytest.approx(np.sum((np.sqrt(a) - np.sqrt(b)) ** 2))
    monkeypatch.setattr(distribution, "_sqrtm", lambda m: real_sqrtm(m) + 0.1j)
    with pytest.raises(ValueError, match="imaginary component"):
        frechet_distance(np.zeros(3), np.diag(a), np.zeros(3), np.diag(b))


def test_frechet_distance_of_feature_sets():
    rng = np.random.default_rng(2)
    f = rng.normal(size=(40, 5))
    shift = np.array([1.0, -2.0, 0.5, 0.0, 3.0])
    # equal covariances: only the mean difference remains
    assert frechet_distance_features(f, f + shift) == pytest.approx(float(shift @ shift), rel=1e-9)
    mu, sigma = feature_statistics(f)
    assert np.allclose(sigma, np.cov(f.T)) and np.allclose(mu, f.mean(0))
    # scaling by 2: covariance x4, (S1 S2)^1/2 = 2 S1 -> tr(S1 + 4 S1 - 4 S1) = tr(S1)
    assert frechet_distance_features(f, 2 * f) == pytest.approx(float(mu @ mu + np.trace(sigma)), rel=1e-9)
    # fewer samples than dimensions (a scene's 8-30 views, 512-d features): singular covariances
    g = rng.normal(size=(8, 64))
    assert frechet_distance_features(g, g) == pytest.approx(0.0, abs=1e-6 * np.trace(np.cov(g.T)))
    assert math.isfinite(frechet_distance_features(g, rng.normal(size=(8, 64))))
    with pytest.raises(ValueError):
        feature_statistics(f[:1])


@pytest.mark.parametrize(("n1", "n2", "d"), [(40, 30, 6), (8, 10, 64)])
def test_lowrank_frechet_distance_equals_the_sqrtm_one(n1, n2, d):
    # full-rank covariances (n > d) and singular ones (n < d, as for a scene's views)
    rng = np.random.default_rng(n1 + d)
    f1 = np.abs(rng.normal(size=(n1, d)))
    f2 = np.abs(rng.normal(size=(n2, d))) * 1.5 + 0.2
    exact = frechet_distance_features(f1, f2)
    assert exact == pytest.approx(frechet_distance_features(f1, f2, method="sqrtm"), rel=1e-6)
    assert exact == pytest.approx(frechet_distance(*feature_statistics(f1), *feature_statistics(f2)), rel=1e-6)


def test_kid_by_hand():
    # 1-d features, k(x, y) = (x y + 1)^3:
    # within x = k(0, 1) = 1; within y = k(1, 2) = 27; cross mean = (1 + 1 + 8 + 27) / 4 = 9.25
    x, y = np.array([[0.0], [1.0]]), np.array([[1.0], [2.0]])
    assert kernel_inception_distance(x, y) == pytest.approx(1 + 27 - 2 * 9.25)
    assert kernel_inception_distance(y, x) == pytest.approx(9.5)
    # 2-d features: x.y is divided by d = 2; x = {(0,0), (2,0)}, y = {(2,2), (0,2)}
    x2, y2 = np.array([[0.0, 0.0], [2.0, 0.0]]), np.array([[2.0, 2.0], [0.0, 2.0]])
    kxx = (0 / 2 + 1) ** 3
    kyy = (4 / 2 + 1) ** 3
    kxy = np.mean([(0 / 2 + 1) ** 3, (0 / 2 + 1) ** 3, (4 / 2 + 1) ** 3, (0 / 2 + 1) ** 3])
    assert kernel_inception_distance(torch.tensor(x2), torch.tensor(y2)) == pytest.approx(kxx + kyy - 2 * kxy)
    # unbiased: the expectation over draws from one distribution is 0 (mean of many small sets)
    rng = np.random.default_rng(3)
    vals = [kernel_inception_distance(rng.normal(size=(6, 4)), rng.normal(size=(6, 4))) for _ in range(4000)]
    assert abs(np.mean(vals)) < 4 * np.std(vals) / math.sqrt(len(vals))
    with pytest.raises(ValueError):
        kernel_inception_distance(x[:1], y)


def test_inception_parameter_count_and_pooling_patch():
    # torchvision's Inception-v3 has 27,161,264 parameters; without the auxiliary head (3,326,696)
    # and with the TF graph's 1008 classes (+8 x 2049) that is 23,850,960
    assert sum(p.numel() for p in FIDInceptionV3().parameters()) == 23_850_960
    # TF's average pool ignores the zero padding: a constant map stays constant at the borders
    x = torch.full((1, 2, 5, 5), 3.0)
    assert torch.equal(_avg_pool_no_pad(x), x)


def he_state_dict(model: torch.nn.Module, seed: int) -> dict[str, torch.Tensor]:
    """A state dict of the model's shapes: He-initialised convolutions, identity batch norms."""
    gen = torch.Generator().manual_seed(seed)
    out = {}
    for k, v in model.state_dict().items():
        if k.endswith("num_batches_tracked"):
            continue  # old-format files (like pytorch-fid's) have none; BatchNorm loads them without
        if k.endswith("conv.weight"):
            out[k] = torch.randn(v.shape, generator=gen) * math.sqrt(2.0 / v[0].numel())
        elif k.endswith("running_var") or k.endswith("bn.weight"):
            out[k] = torch.ones(v.shape)
        else:
            out[k] = torch.randn(v.shape, generator=gen) * 0.01
    return out


@pytest.fixture(scope="session")
def generated_inception(tmp_path_factory) -> Path:
    """A weights file in the pytorch-fid layout with generated values (shared by the tests)."""
    path = tmp_path_factory.mktemp("inception") / "generated_inception.pth"
    torch.save(he_state_dict(FIDInceptionV3(), seed=0), path)
    return path


def test_inception_loads_strictly_and_gives_pool3_features(generated_inception):
    model = load_fid_inception(generated_inception)
    assert not model.training and all(not p.requires_grad for p in model.parameters())
    imgs = torch.rand(2, 3, 40, 56, generator=torch.Generator().manual_seed(1))
    f = inception_features(imgs, model, batch_size=1)
    assert f.shape == (2, 2048) and f.dtype == torch.float64 and torch.isfinite(f).all()
    assert (f >= 0).all() and not torch.allclose(f[0], f[1])  # means of ReLU outputs, image-dependent
    # the input is resized to 299x299 first: an image already at 299 gives the same features
    big = torch.nn.functional.interpolate(imgs[:1], size=(299, 299), mode="bilinear", align_corners=False)
    assert torch.allclose(inception_features(big, model), f[:1], atol=1e-5)


def test_inception_rejects_other_state_dicts(tmp_path, generated_inception):
    sd = torch.load(generated_inception, weights_only=True)
    sd["extra.weight"] = torch.zeros(1)
    bad = tmp_path / "extra.pth"
    torch.save(sd, bad)
    with pytest.raises(InputError, match="not the pytorch-fid Inception state dict"):
        load_fid_inception(bad)
    junk = tmp_path / "junk.pth"
    junk.write_bytes(b"not a torch file")
    with pytest.raises(InputError, match="cannot read Inception weights"):
        load_fid_inception(junk)
    with pytest.raises(InputError, match="not found"):
        load_fid_inception(tmp_path / "missing.pth")
