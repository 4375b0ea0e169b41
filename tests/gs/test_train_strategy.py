"""Densification (clone / split / prune / opacity reset), optimiser surgery, schedules, on hand-built cases."""

from __future__ import annotations

import math
from types import SimpleNamespace

import pytest
import torch

from inpaint360gs.gs.config import DensifyConfig, TrainConfig
from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.gs.optim import PARAM_NAMES, learning_rates, make_optimizers, make_params, means_lr
from inpaint360gs.core.gaussians import quat_to_rotmat
from inpaint360gs.gs.strategy import DensifyStrategy

EXTENT = 10.0  # percent_dense 0.01 -> clone if max scale <= 0.1, split above


def hand_built(scales, opacities, quats=None):
    n = len(scales)
    g = Gaussians(
        means=torch.arange(n * 3, dtype=torch.float32).reshape(n, 3),
        log_scales=torch.log(torch.tensor(scales, dtype=torch.float32)),
        quats=torch.tensor(quats, dtype=torch.float32) if quats is not None else torch.tensor([[1.0, 0, 0, 0]] * n),
        opacity_logits=torch.logit(torch.tensor(opacities, dtype=torch.float32)),
        sh0=torch.arange(n * 3, dtype=torch.float32).reshape(n, 1, 3) / 10,
        shN=torch.ones(n, 15, 3) * torch.arange(n, dtype=torch.float32)[:, None, None],
    )
    params = make_params(g, PARAM_NAMES)
    opts = make_optimizers(params, learning_rates(TrainConfig(), EXTENT), 1e-15)
    for p in params.values():  # one step so that every Adam has moments to carry along
        p.grad = torch.ones_like(p)
    for o in opts.values():
        o.step()
        o.zero_grad()
    with torch.no_grad():  # back to the hand-set values; the moments stay
        for k, p in params.items():
            p.copy_(getattr(g, k))
    return params, opts


def state_with_grads(strategy, n, grads, count=1.0):
    st = strategy.initialize_state(n)
    st["grad2d"] = torch.tensor(grads, dtype=torch.float32) * count
    st["count"] = torch.full((n,), count)
    return st


def test_accumulate_converts_pixel_gradients_to_ndc_and_skips_culled():
    s = DensifyStrategy(DensifyConfig(), EXTENT)
    st = s.initialize_state(3)
    grad = torch.tensor([[1e-5, 2e-5], [3e-5, 0.0], [5.0, 5.0]])
    radii = torch.tensor([4, 7, 0])
    s.accumulate(st, grad, radii, width=200, height=100)
    s.accumulate(st, grad, torch.tensor([9, 0, 0]), width=200, height=100)
    # d(pixel)/d(ndc) = W/2, H/2
    g0 = math.hypot(1e-5 * 100, 2e-5 * 50)
    assert st["grad2d"][0].item() == pytest.approx(2 * g0, rel=1e-6)
    assert st["grad2d"][1].item() == pytest.approx(3e-5 * 100, rel=1e-6)
    assert st["grad2d"][2].item() == 0.0
    assert st["count"].tolist() == [2.0, 1.0, 0.0]
    assert st["max_radii"].tolist() == [9.0, 7.0, 0.0]


def test_clone_small_high_gradient_gaussians():
    params, opts = hand_built(scales=[[0.05] * 3, [0.05] * 3], opacities=[0.5, 0.5])
    s = DensifyStrategy(DensifyConfig(), EXTENT)
    st = state_with_grads(s, 2, [5e-4, 1e-4], count=3.0)  # mean 5e-4 >= 2e-4: clone; 1e-4: keep
    old = {k: v.detach().clone() for k, v in params.items()}
    old_m = opts["means"].state[params["means"]]["exp_avg"].clone()
    stats = s.densify_and_prune(params, opts, st, prune_big=True)
    assert (stats.cloned, stats.split, stats.pruned) == (1, 0, 0)
    for k, v in params.items():
        assert v.shape[0] == 3
        assert torch.equal(v.detach()[:2], old[k]) and torch.equal(v.detach()[2], old[k][0]), k  # exact copy of #0
    m = opts["means"].state[params["means"]]
    assert opts["means"].param_groups[0]["params"][0] is params["means"]
    assert torch.equal(m["exp_avg"][:2], old_m) and torch.equal(m["exp_avg"][2], torch.zeros(3))
    assert all(v.shape[0] == 3 and not v.any() for v in st.values())  # statistics restart


def test_gaussian_cap_keeps_the_largest_gradients():
    # four small Gaussians, all candidates for cloning (+1 each): cap 6 leaves room for 2 of them
    params, opts = hand_built(scales=[[0.05] * 3] * 4, opacities=[0.5] * 4)
    s = DensifyStrategy(DensifyConfig(max_gaussians=6), EXTENT)
    st = state_with_grads(s, 4, [3e-4, 9e-4, 5e-4, 7e-4])
    old = params["means"].detach().clone()
    stats = s.densify_and_prune(params, opts, st, prune_big=False)
    assert (stats.cloned, stats.split) == (2, 0)
    assert torch.equal(params["means"].detach()[4:], old[[1, 3]])  # gradients 9e-4 and 7e-4 won
    # at the cap nothing densifies; without a cap (the original) all four would
    st = state_with_grads(s, 6, [1e-3] * 6)
    assert s.densify_and_prune(params, opts, st, prune_big=False).cloned == 0
    params, opts = hand_built(scales=[[0.05] * 3] * 4, opacities=[0.5] * 4)
    s = DensifyStrategy(DensifyConfig(), EXTENT)
    assert s.densify_and_prune(params, opts, state_with_grads(s, 4, [3e-4, 9e-4, 5e-4, 7e-4]), prune_big=False).cloned == 4


def test_split_large_high_gradient_gaussians():
    q = torch.nn.functional.normalize(torch.tensor([[0.9, 0.1, -0.3, 0.2]]), dim=-1)
    params, opts = hand_built(scales=[[0.5, 0.2, 0.3], [0.5, 0.5, 0.5]], opacities=[0.5, 0.5], quats=[q[0].tolist(), [1, 0, 0, 0]])
    s = DensifyStrategy(DensifyConfig(), EXTENT)
    st = state_with_grads(s, 2, [3e-4, 0.0])
    parent = {k: v.detach()[0].clone() for k, v in params.items()}
    stats = s.densify_and_prune(params, opts, st, prune_big=False, generator=torch.Generator().manual_seed(7))
    assert (stats.cloned, stats.split, stats.pruned) == (0, 1, 0)
    n = params["means"].shape[0]
    assert n == 3  # parent replaced by 2 children, #1 kept first
    assert torch.equal(params["means"].detach()[0], torch.tensor([3.0, 4.0, 5.0]))
    # children: scales / (0.8 * 2), same rotation/opacity/colour, means = parent + R (s * z)
    z = torch.randn((2, 3), generator=torch.Generator().manual_seed(7))
    R = quat_to_rotmat(parent["quats"][None])[0]
    expect = parent["means"] + (z * parent["log_scales"].exp()) @ R.T
    assert torch.allclose(params["means"].detach()[1:], expect, atol=1e-6)
    assert torch.allclose(params["log_scales"].detach()[1:].exp(), parent["log_scales"].exp().expand(2, 3) / 1.6, rtol=1e-6)
    for k in ("quats", "opacity_logits", "sh0", "shN"):
        assert torch.equal(params[k].detach()[1], parent[k]) and torch.equal(params[k].detach()[2], parent[k])
    assert not opts["sh0"].state[params["sh0"]]["exp_avg"][1:].any()


def test_abs_gradient_mode_thresholds_the_absolute_sums_at_their_own_threshold():
    """gradient="abs" (AbsGS) reads ``means2d.absgrad``, not ``means2d.grad``, and compares with
    ``abs_grad_threshold``: a Gaussian whose pixels pull both ways (sum 0) densifies; the mean mode
    leaves it. "auto" is "abs" on a sparse start only."""
    width, height = 64, 48
    grad = torch.zeros(2, 2)  # both pulled both ways: the sums cancel
    # per pixel unit; in NDC units (x W/2 = 32): 1.5e-3 and 0.3e-3, around the 4e-4 threshold
    absgrad = torch.tensor([[1.5e-3 / 32, 0.0], [0.3e-3 / 32, 0.0]])
    cases = (("mean", False, 0), ("abs", False, 1), ("auto", False, 0), ("auto", True, 1), ("mean", True, 0))
    for mode, sparse, cloned in cases:
        s = DensifyStrategy(DensifyConfig(gradient=mode, densify_from=0, densify_every=1), EXTENT, sparse_start=sparse)
        assert s.gradient == ("abs" if cloned else "mean")
        params, opts = hand_built(scales=[[0.05] * 3] * 2, opacities=[0.5, 0.5])
        st = s.initialize_state(2)
        out = SimpleNamespace(means2d=SimpleNamespace(grad=grad, absgrad=absgrad), radii=torch.tensor([3, 3]))
        stats = s.step_post_backward(params, opts, st, 1, out, SimpleNamespace(width=width, height=height))
        assert stats.cloned == cloned, (mode, sparse)  # 1.5e-3 >= 4e-4 > 0.3e-3: only the first
    assert DensifyConfig().gradient == "auto" and DensifyConfig().abs_grad_threshold == 4e-4


def test_prune_low_opacity_and_big_gaussians():
    s = DensifyStrategy(DensifyConfig(), EXTENT)
    # 0 transparent, 1 big in the world (1.5 > 0.1 x 10), 2 big on screen (radius 30 > 20), 3 fine
    params, opts = hand_built(scales=[[0.05] * 3, [1.5, 0.01, 0.01], [0.05] * 3, [0.05] * 3], opacities=[0.004, 0.5, 0.5, 0.5])
    st = state_with_grads(s, 4, [0, 0, 0, 0])
    st["max_radii"] = torch.tensor([1.0, 1.0, 30.0, 19.0])
    stats = s.densify_and_prune(params, opts, st, prune_big=False)
    assert stats.pruned == 1 and params["means"].shape[0] == 3  # before the first reset: opacity only
    assert torch.equal(params["means"].detach()[0], torch.tensor([3.0, 4.0, 5.0]))
    st = state_with_grads(s, 3, [0, 0, 0])
    st["max_radii"] = torch.tensor([1.0, 30.0, 19.0])
    stats = s.densify_and_prune(params, opts, st, prune_big=True)
    assert stats.pruned == 2 and torch.equal(params["means"].detach(), torch.tensor([[9.0, 10.0, 11.0]]))
    assert opts["means"].state[params["means"]]["exp_avg"].shape == (1, 3)


def test_opacity_reset_clamps_and_zeroes_moments():
    params, opts = hand_built(scales=[[0.05] * 3] * 2, opacities=[0.9, 0.005])
    s = DensifyStrategy(DensifyConfig(), EXTENT)
    s.reset_opacity(params, opts)
    assert torch.allclose(torch.sigmoid(params["opacity_logits"].detach()), torch.tensor([0.01, 0.005]), atol=1e-7)
    st = opts["opacity_logits"].state[params["opacity_logits"]]
    assert not st["exp_avg"].any() and not st["exp_avg_sq"].any()


def test_schedule_of_step_post_backward():
    cfg = DensifyConfig(densify_from=10, densify_until=50, densify_every=5, opacity_reset_every=20)
    s = DensifyStrategy(cfg, EXTENT)
    params, opts = hand_built(scales=[[0.05] * 3], opacities=[0.5])
    st = s.initialize_state(1)
    events = {}
    for step in range(60):
        n0 = params["means"].shape[0]
        out = SimpleNamespace(means2d=SimpleNamespace(grad=torch.ones(n0, 2)), radii=torch.tensor([3] * n0))
        stats = s.step_post_backward(params, opts, st, step, out, SimpleNamespace(width=64, height=48))
        if stats.cloned or stats.reset_opacity:
            events[step] = (stats.cloned, stats.reset_opacity)
    # densify at 15, 20, ..., 45 (> from, multiple of every, < until); reset at 20 and 40
    assert sorted(events) == [15, 20, 25, 30, 35, 40, 45]
    assert events[20][1] and events[40][1] and not events[15][1]
    assert params["means"].shape[0] == 2**7


def test_means_learning_rate_decay():
    cfg = TrainConfig(means_lr_max_steps=1000)
    assert means_lr(0, cfg, 2.0) == pytest.approx(1.6e-4 * 2)
    assert means_lr(1000, cfg, 2.0) == pytest.approx(1.6e-6 * 2)
    assert means_lr(500, cfg, 2.0) == pytest.approx(math.sqrt(1.6e-4 * 1.6e-6) * 2)
    assert means_lr(5000, cfg, 2.0) == pytest.approx(1.6e-6 * 2)
    lrs = learning_rates(TrainConfig(), 3.0)
    assert lrs == pytest.approx({"means": 4.8e-4, "log_scales": 5e-3, "quats": 1e-3, "opacity_logits": 0.05, "sh0": 2.5e-3, "shN": 1.25e-4})


def test_schedule_scaling_is_explicit():
    d = TrainConfig(iterations=7000)
    e = d.effective()
    assert (e.densify.densify_from, e.densify.densify_until, e.densify.opacity_reset_every) == (500, 15000, 3000)
    s = TrainConfig(iterations=7000, schedule_scale=7000 / 30000).effective()
    assert (s.densify.densify_from, s.densify.densify_until, s.densify.densify_every, s.densify.opacity_reset_every) == (117, 3500, 100, 700)
    assert (s.sh_degree_interval, s.means_lr_max_steps, s.schedule_scale) == (233, 7000, 1.0)
    assert TrainConfig.from_dict(d.to_dict()) == d
