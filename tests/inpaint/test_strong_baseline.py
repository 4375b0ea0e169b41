"""The strong baseline's switches (Gaussian Grouping style; docs/guide.md, "Tables of the paper"):
Gaussian Grouping's loss (L1 outside the mask, LPIPS inside), 3DGS density control during 3D
inpainting confined to the Gaussians that train, and the stage on the training views with footprint
masks and depth-guided initialisation: new Gaussians on the support where the removed object
stood, from the training views' filled depth, where the weak per-view baseline adds none."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

import scene_builder as sb
from scene_builder import textured_floor
from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.inpaint.conditioned import InpaintedView
from inpaint360gs.inpaint.refine import RefineConfig, active_rows, hybrid_loss, refine
from inpaint360gs.metrics.lpips import lpips
from inpaint360gs.render.api import render
from inpaint360gs.views.unseen import footprint, normalised_depth

PARAMS = ("means", "log_scales", "quats", "opacity_logits", "sh0", "shN")


def cat(*gs: Gaussians) -> Gaussians:
    return Gaussians(**{k: torch.cat([getattr(g, k) for g in gs], 0) for k in PARAMS})


# --- the loss: L1 outside the mask, LPIPS inside ------------------------------------------------------


def loss_case(seed: int = 0, h: int = 40, w: int = 48):
    rng = np.random.default_rng(seed)
    target = torch.from_numpy(rng.random((h, w, 3))).float()
    pred = (target + 0.3 * torch.from_numpy(rng.standard_normal((h, w, 3))).float()).clamp(0, 1)
    mask = torch.zeros(h, w, dtype=torch.bool)
    mask[12:28, 16:32] = True
    return pred, target, mask, torch.ones(h, w, dtype=torch.bool)


def test_the_grouping_loss_is_l1_outside_the_mask_plus_lpips_of_the_masked_crop():
    pred, target, mask, valid = loss_case()
    valid[:3] = False  # pixels without a target (holes left by occluders taken out) do not count
    c = RefineConfig(supervision="lpips").resolved()
    assert c.lambda_lpips == 1.0  # Gaussian Grouping weighs the perceptual term like the L1 term
    loss, logs = hybrid_loss(pred, target, mask, valid, c)
    out = (valid & ~mask).numpy()
    hand_l1 = np.abs(pred.double().numpy() - target.double().numpy())[out].mean()
    m = mask[..., None].float()
    crop = (slice(12 - 8, 28 + 8), slice(16 - 8, 32 + 8))
    hand_lp = float(lpips((pred * m)[crop].permute(2, 0, 1), (target * m)[crop].permute(2, 0, 1), net="alex"))
    assert logs["l1"] == pytest.approx(hand_l1, rel=1e-6) and logs["lpips"] == pytest.approx(hand_lp, rel=1e-6)
    assert "dssim" not in logs and float(loss) == pytest.approx(hand_l1 + hand_lp, rel=1e-6)
    # inside the mask only LPIPS sees a change; outside the crop only L1; an invalid pixel neither
    inside, far, invalid = pred.clone(), pred.clone(), pred.clone()
    inside[12:28, 16:32] = 0.5  # the masked texture flattened
    far[36:, :6] = 1.0 - far[36:, :6]
    invalid[:3] = 1.0 - invalid[:3]
    _, a = hybrid_loss(inside, target, mask, valid, c)
    _, b = hybrid_loss(far, target, mask, valid, c)
    _, d = hybrid_loss(invalid, target, mask, valid, c)
    assert a["l1"] == logs["l1"] and a["lpips"] > logs["lpips"] + 0.05
    assert b["l1"] > logs["l1"] + 1e-3 and b["lpips"] == logs["lpips"]
    assert d == logs
    # lambda2 given: the LPIPS term scales linearly
    half, _ = hybrid_loss(pred, target, mask, valid, RefineConfig(supervision="lpips", lambda_lpips=0.5).resolved())
    assert float(half) == pytest.approx(hand_l1 + 0.5 * hand_lp, rel=1e-6)


def test_the_density_control_runs_on_a_short_schedule_without_opacity_resets():
    d = RefineConfig(densify=True, densify_until=0.75, densify_grad=3e-4).densify_config()
    assert (d.densify_from, d.densify_until, d.densify_every, d.grad_threshold) == (100, 1500, 100, 3e-4)
    assert d.opacity_reset_every > 2000  # never within the run
    assert RefineConfig(iterations=400, densify_until=0.5).densify_config().densify_until == 200


# --- density control during 3D inpainting -------------------------------------------------------------


@pytest.fixture(scope="module")
def hole_case():
    """The floor with a square removed, four views of the whole floor as targets, and few large
    grey Gaussians where the square was: too coarse for the checker, so density control has work."""
    floor = textured_floor()
    hole = (floor.means[:, :2].abs() < 0.35).all(1)
    edited = floor.subset(~hole)
    views = []
    with torch.no_grad():
        for cam in sb.orbit_cameras(4, radius=2.2, height=1.6, width=64, h=48, f=52.0, prefix="v"):
            o = render(floor, cam)
            mask = footprint(floor, hole, cam, 0.5)
            views.append(InpaintedView(cam, o.color.clamp(0, 1).numpy(), normalised_depth(o).numpy(), mask, np.ones(mask.shape, bool), np.zeros(mask.shape, bool)))
    g = np.linspace(-0.25, 0.25, 3)
    x, y = np.meshgrid(g, g)
    pts = torch.tensor(np.stack([x.ravel(), y.ravel(), np.zeros(x.size)], 1), dtype=torch.float32)
    new = Gaussians.from_points(pts, torch.full((len(pts), 3), 0.5), sh_degree=1, init_opacity=0.9, scales=torch.full((len(pts),), 0.15))
    return floor.means[hole].double().numpy(), edited, new, views


def test_density_control_grows_only_the_gaussians_that_train(hole_case):
    region, edited, new, views = hole_case
    base = RefineConfig(iterations=300, supervision="lpips", seed=0, densify_until=1.0)
    plain, _ = refine(edited, new, views, base, region=region, extent=2.0)
    grown, log = refine(edited, new, views, RefineConfig(**{**base.__dict__, "densify": True}), region=region, extent=2.0)
    active = active_rows(edited, np.concatenate([region, new.means.double().numpy()]), base.region_margin)
    static = edited.subset(~active)
    k, trained = len(static), int(active.sum()) + len(new)
    assert len(plain) == k + trained  # without density control the count stays
    for p in PARAMS:  # the static Gaussians come back first, bit for bit
        assert torch.equal(getattr(grown, p)[:k], getattr(static, p)), p
    last = log[-1]
    assert last["cloned"] + last["split"] > 0 and last["gaussians"] == len(grown) - k
    assert len(grown) - k == trained + last["cloned"] + last["split"] - last["pruned"]
    # what grew lies where the trained Gaussians are: in the region's box grown by the margin
    lo, hi = region.min(0), region.max(0)
    pad = base.region_margin * float(np.linalg.norm(hi - lo)) + 0.3  # + the split children's spread
    m = grown.means[k:].double().numpy()
    assert ((m >= lo - pad) & (m <= hi + pad)).all()
    # a gradient threshold nothing reaches: the same run as without density control, bit for bit
    same, log0 = refine(edited, new, views, RefineConfig(**{**base.__dict__, "densify": True, "densify_grad": 1e9}), region=region, extent=2.0)
    assert log0[-1]["cloned"] + log0[-1]["split"] + log0[-1]["pruned"] == 0
    assert all(torch.equal(getattr(same, p), getattr(plain, p)) for p in PARAMS)


# --- the stage: training views, footprint masks, depth-guided initialisation --------------------------

W, H, F = 64, 48, 56.0
BALL_R = 0.25


@pytest.fixture(scope="module")
def ball_scene(tmp_path_factory):
    """A textured floor (id 0) with a ball (id 1) standing on it; the floor under the ball is
    missing, as a 3DGS never sees it. Returns (distilled field, scene, removed mask, footprint)."""
    from inpaint360gs.core.support import Footprint, plane_coordinates
    from inpaint360gs.distill.field import IdentityField
    from inpaint360gs.io.scene import load_scene

    rng = np.random.default_rng(0)
    g = np.arange(-2.0, 2.0 + 1e-9, 0.06)
    x, y = np.meshgrid(g, g)
    floor = np.stack([x.ravel(), y.ravel(), np.zeros(x.size)], 1)
    floor = floor[np.hypot(floor[:, 0], floor[:, 1]) > 0.8 * BALL_R]
    checker = (np.floor(floor[:, 0] / 0.3) + np.floor(floor[:, 1] / 0.3)) % 2
    d = rng.normal(size=(400, 3))
    d *= BALL_R * rng.uniform(0.3, 1.0, (400, 1)) ** (1 / 3) / np.linalg.norm(d, axis=1, keepdims=True)
    ball = np.array([0.0, 0.0, BALL_R]) + d
    pts = np.concatenate([floor, ball])
    rgb = np.concatenate([0.3 + 0.4 * checker[:, None] * np.array([[1.0, 0.8, 0.4]]) + 0.1, np.tile([[0.9, 0.15, 0.1]], (len(ball), 1))]).clip(0, 1)
    ids = np.concatenate([np.zeros(len(floor), int), np.ones(len(ball), int)])
    scales = np.where(ids == 0, 0.045, 0.04)
    model = Gaussians.from_points(torch.tensor(pts, dtype=torch.float32), torch.tensor(rgb, dtype=torch.float32), sh_degree=1,
                                  init_opacity=0.98, scales=torch.tensor(scales, dtype=torch.float32))  # fmt: skip
    model.log_scales[torch.from_numpy(ids == 0), 2] = math.log(1e-3)
    model.features = torch.nn.functional.one_hot(torch.from_numpy(ids), 2).float()
    cams = sb.orbit_cameras(12, radius=2.5, height=1.6, width=W, h=H, f=F) + sb.orbit_cameras(3, radius=2.5, height=1.6, width=W, h=H, f=F, prefix="test_", phase=0.25)
    root = tmp_path_factory.mktemp("ball") / "scene"
    sb.write_model(root / "sparse" / "0", cams, floor[::9], np.full((len(floor[::9]), 3), 0.5))
    for c in cams:
        sb.write_png(root / "images" / c.name, np.zeros((H, W, 3), np.uint8))  # the stage reads no pixel
    classifier = torch.nn.Linear(2, 2)
    with torch.no_grad():
        classifier.weight.copy_(10.0 * torch.eye(2))
        classifier.bias.zero_()
    n = np.array([0.0, 0.0, 1.0])
    fp = Footprint(n, 0.0, plane_coordinates(ball, n), 2 * BALL_R)
    return IdentityField(model, classifier, [0, 1]), load_scene(root), torch.from_numpy(ids == 1), fp


def run_stage(ball_scene, **refine_kw):
    from inpaint360gs.inpaint.stage import InpaintConfig, inpaint_scene

    field_, scene, removed, fp = ball_scene
    init = refine_kw.pop("init")
    r = RefineConfig(seed=0, **refine_kw)
    cfg = InpaintConfig(views="training", masks="footprint", condition=False, init=init, refine=r)
    final, record, views = inpaint_scene(field_, removed, [1], scene, cfg, footprints=[fp])
    return final, record, views


@pytest.fixture(scope="module")
def strong(ball_scene):
    return run_stage(ball_scene, init="depth", supervision="lpips", densify=True, densify_until=1.0, iterations=300)


def test_the_initialisation_fills_the_hole_from_the_training_views_filled_depth(ball_scene):
    """One step: the new Gaussians are (almost) as initialised: on the support plane, inside the
    footprint's column, covering the floor the ball hid; fused from the training views."""
    field_, scene, removed, fp = ball_scene
    final, record, views = run_stage(ball_scene, init="depth", supervision="lpips", densify=True, iterations=1)
    assert record["views"] == "training" and [v.camera.name for v in views] == [v.name for v in scene.train_views] and not any(v.from_condition.any() for v in views)
    n_new = record["new_gaussians"]
    assert n_new > 10 and len(final) == int((~removed).sum()) + n_new
    new = final.means[-n_new:].double().numpy()
    assert np.abs(new[:, 2]).max() < 0.01  # on the floor: the support plane's depth, not a made-up one
    assert (fp.distance(new) <= 1e-6).all()  # in the footprint's column (reveal_margin 0)
    hidden = np.stack(np.meshgrid(np.linspace(-0.15, 0.15, 7), np.linspace(-0.15, 0.15, 7)), -1).reshape(-1, 2)
    gap = np.min(np.hypot(hidden[:, None, 0] - new[None, :, 0], hidden[:, None, 1] - new[None, :, 1]), axis=1)
    foot = 2.9 / F  # a pixel's footprint on the floor at the cameras' distance
    assert gap.max() < 1.5 * foot  # every part of the floor the ball hid gets new Gaussians, a voxel (1.5 px) apart
    # fused: one point per voxel of about a pixel, far fewer than the training views' filled pixels
    assert n_new < 0.5 * sum(int(v.mask.sum()) for v in views)


def test_the_strong_baseline_adds_a_surface_where_the_weak_one_only_recolours(ball_scene, strong):
    _, scene, _, fp = ball_scene
    final, record, _ = strong
    weak, weak_record, _ = run_stage(ball_scene, init="none", iterations=300)
    assert weak_record["new_gaussians"] == 0 and record["new_gaussians"] > 0
    from inpaint360gs.inpaint.stage import support_depth
    from inpaint360gs.views.virtual import plane_depth

    # the weak baseline trains only what the scene had around the hole: no Gaussian ends up in it
    inner = lambda g: int((torch.hypot(g.means[:, 0], g.means[:, 1]) < 0.6 * BALL_R).sum())  # noqa: E731
    assert inner(weak) == 0 and inner(final) > 10
    hole_alpha, hole_err, floor_err = [], [], []
    with torch.no_grad():
        for v in scene.test_views:
            z = plane_depth(v.camera, fp.normal, fp.offset)
            hole = np.isfinite(support_depth(v.camera, [fp], -0.3))  # rays meeting the floor well inside the footprint
            ring = np.isfinite(support_depth(v.camera, [fp], 1.5)) & ~np.isfinite(support_depth(v.camera, [fp], 0.5))  # the floor around it
            o = render(final, v.camera)
            err = (normalised_depth(o).numpy() - z) / z
            hole_alpha.append(o.alpha.numpy()[hole])
            hole_err.append(err[hole])
            floor_err.append(err[ring])
    hole_alpha, hole_err, floor_err = map(np.concatenate, (hole_alpha, hole_err, floor_err))
    assert len(hole_alpha) > 20
    # a surface on the floor: its depth as far from the plane as the splatted floor's own (which reads
    # a little in front of it: the nearer splats win the blending), within the evaluation's 5 %
    assert hole_alpha.mean() > 0.9
    assert abs(np.median(hole_err) - np.median(floor_err)) < 0.03 and np.abs(np.median(hole_err)) < 0.05


def test_densification_happens_and_stays_in_the_trained_region(ball_scene, strong):
    """Every Gaussian the stage did not take over bit for bit from the scene after removal lies in
    the footprint's column grown by the trained margin, near the support; density control cloned or
    split some; the loss logged is Gaussian Grouping's (L1 and LPIPS, no D-SSIM)."""
    from inpaint360gs.inpaint.stage import InpaintConfig

    field_, _, removed, fp = ball_scene
    final, record, _ = strong
    last = record["refine_log"][-1]
    assert last["cloned"] + last["split"] > 0 and "lpips" in last and "dssim" not in last
    kept = field_.gaussians.subset(~removed)
    rows = lambda g: [tuple(r) for r in torch.cat([g.means, g.log_scales, g.sh0[:, 0]], 1).numpy().tolist()]  # noqa: E731
    before, after = rows(kept), rows(final)
    changed = final.means[torch.from_numpy(np.array([r not in set(before) for r in after]))].double().numpy()
    assert len(changed) >= record["new_gaussians"] + last["split"]
    # what trains (and so densifies) is the support within the margin of the footprint and the new
    # Gaussians in it: the scene beyond is taken over bit for bit, and what changed stays near the hole
    # (split children are drawn from their parent's Gaussian, and the steps move them a little)
    reach = InpaintConfig().footprint_margin * fp.size
    far = fp.distance(kept.means.double().numpy()) > reach
    assert far.sum() > 1000 and {r for r, f in zip(before, far) if f} <= set(after)
    assert (fp.distance(changed) <= fp.diameter).all() and np.abs(fp.heights(changed)).max() < fp.height
