"""Feature images with each view's projection kept (render/feature_cache.py): bit for bit what
``render(..., with_features=True)`` composites, for new features on the same Gaussians, on each
backend; the removal's fill masks and selection with the cache are those without it."""

from __future__ import annotations

import inpaint360gs  # noqa: F401  (first: sets OMP_WAIT_POLICY before torch starts its thread pool)
import numpy as np
import pytest
import torch

from inpaint360gs.core.camera import Camera
from inpaint360gs.render import available_backends, render
from inpaint360gs.render.feature_cache import FeatureRenders

BACKENDS = [b for b in ("numba", "torch") if b in available_backends()]


def _model(n=500, seed=0):
    from inpaint360gs.core.gaussians import Gaussians

    gen = torch.Generator().manual_seed(seed)
    means = torch.randn(n, 3, generator=gen) * torch.tensor([0.9, 0.6, 0.5]) + torch.tensor([0.0, 0.0, 3.0])
    return Gaussians(means=means, log_scales=torch.log(torch.rand(n, 3, generator=gen) * 0.12 + 0.02), quats=torch.randn(n, 4, generator=gen),
                     opacity_logits=torch.randn(n, generator=gen) * 2 + 1, sh0=torch.randn(n, 1, 3, generator=gen), shN=torch.randn(n, 3, 3, generator=gen) * 0.1)  # fmt: skip


def _features(kind: str, g, n_features: int, rng) -> torch.Tensor:
    """0/1 features on a random 30 %; on the 15 % of Gaussians nearest the cameras (each tile's list
    is cut after its first few: the cache composites only up to a tile's last nonzero feature); or
    signed real values on a random half."""
    n = len(g.means)
    if kind == "random":
        return torch.from_numpy(rng.random((n, n_features)) < 0.3).float()
    if kind == "front":
        near = g.means[:, 2] < torch.quantile(g.means[:, 2], 0.15)
        return near[:, None].float().expand(n, n_features).clone()
    return torch.from_numpy(rng.normal(size=(n, n_features)) * (rng.random((n, 1)) < 0.5)).float()


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("n_features,kind", [(2, "random"), (1, "front"), (1, "signed"), (5, "front"), (5, "signed")])
def test_cached_features_are_the_rendered_features_bit_for_bit(backend, n_features, kind):
    g = _model()
    cams = {f"v{k}": Camera(torch.eye(3), torch.tensor([0.1 * k, 0.0, 0.0]), 50.0, 50.0, 35.3, 22.3, 70, 45) for k in range(3)}
    cache = FeatureRenders(g, backend)
    rng = np.random.default_rng(1)
    for _ in range(2):  # the second round reuses every view's projection
        for key, cam in cams.items():
            feats = _features(kind, g, n_features, rng)
            ref = g.map(lambda t: t)
            ref.features = feats
            want = render(ref, cam, with_features=True, backend=backend).features
            assert torch.equal(cache.features(key, cam, feats), want)
    assert all(cache.holds(k) for k in cams) == (backend == "numba")


def test_the_removal_with_the_cache_is_the_removal_without_it(make_blobs_scene):
    from object_fields import click_on, labelled_field

    from inpaint360gs.io.scene import load_scene
    from inpaint360gs.remove.objects import fill_masks
    from inpaint360gs.remove.stage import plan_removal, support_plane

    root, model, labels = make_blobs_scene("feature-cache", n_views=8)
    scene = load_scene(root)
    field = labelled_field(model, labels, [0, 3, 7])
    cache = FeatureRenders(field.gaussians)
    removed = torch.from_numpy(np.random.default_rng(0).random(len(model)) < 0.3)
    a = fill_masks(field.gaussians, removed, scene.train_views)
    b = fill_masks(field.gaussians, removed, scene.train_views, renders=cache)
    assert a.keys() == b.keys() and all(np.array_equal(a[k], b[k]) for k in a)
    c = click_on(scene.train_views[0], (0.45, 0.0, 0.25))
    ref = plan_removal(field, scene, clicks=[c])
    got = plan_removal(field, scene, clicks=[c], renders=cache, support=support_plane(field, scene))
    assert np.array_equal(ref.removal.removed_mask.numpy(), got.removal.removed_mask.numpy()) and ref.check == got.check
    assert ref.masks.keys() == got.masks.keys() and all(np.array_equal(ref.masks[k], got.masks[k]) for k in ref.masks)


def test_features_near_some_pixels_are_the_rendered_ones_there():
    g = _model(seed=2)
    cam = Camera(torch.eye(3), torch.zeros(3), 50.0, 50.0, 35.3, 22.3, 70, 45)
    feats = torch.from_numpy(np.random.default_rng(3).random((len(g.means), 1)) < 0.5).float()
    ref = g.map(lambda t: t)
    ref.features = feats
    want = render(ref, cam, with_features=True, backend="numba" if "numba" in BACKENDS else "torch").features[..., 0]
    x, y = np.array([3, 40, 69]), np.array([44, 20, 0])
    got = FeatureRenders(g).features("v", cam, feats, near=(x, y), margin=2)[..., 0]
    for dx in range(-2, 3):
        for dy in range(-2, 3):
            xx, yy = np.clip(x + dx, 0, 69), np.clip(y + dy, 0, 44)
            assert torch.equal(got[yy, xx], want[yy, xx])


def test_the_silhouette_test_with_the_cache_is_the_one_without_it(make_blobs_scene):
    from object_fields import labelled_field

    from inpaint360gs.io.scene import load_scene
    from inpaint360gs.remove.objects import silhouette_share

    root, model, labels = make_blobs_scene("silhouette-cache", n_views=8)
    scene = load_scene(root)
    field = labelled_field(model, labels, [0, 3, 7])
    g = field.gaussians
    rng = np.random.default_rng(4)
    plain = silhouette_share(g, scene.train_views)
    cached = silhouette_share(g, scene.train_views, renders=FeatureRenders(g))
    for _ in range(3):
        body = rng.random(len(model)) < 0.4
        idx = np.flatnonzero(rng.random(len(model)) < 0.1)
        assert np.array_equal(plain(idx, body), cached(idx, body))


def test_the_kernels_of_a_thread_run_on_at_most_the_threads_it_asks_for():
    """numba_threads_at_most caps the calling thread's kernels only (another thread keeps its count),
    the cap ends with the block, and the features are the same bits on one thread as on all."""
    import threading

    import numba

    from inpaint360gs.render.numba_arrays import numba_threads_at_most, set_numba_threads

    set_numba_threads()
    full = numba.get_num_threads()
    g = _model(seed=5)
    cam = Camera(torch.eye(3), torch.zeros(3), 50.0, 50.0, 35.3, 22.3, 70, 45)
    feats = _features("random", g, 1, np.random.default_rng(6))
    want = FeatureRenders(g).features("v", cam, feats)
    seen = {}
    with numba_threads_at_most(1):
        set_numba_threads()
        seen["inside"] = numba.get_num_threads()
        other = threading.Thread(target=lambda: (set_numba_threads(), seen.__setitem__("other", numba.get_num_threads())))
        other.start()
        other.join()
        got = FeatureRenders(g).features("v", cam, feats)
    set_numba_threads()
    assert seen == {"inside": 1, "other": full} and numba.get_num_threads() == full
    assert torch.equal(got, want)
