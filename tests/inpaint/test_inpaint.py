"""The inpainting stage's parts on tiny hand-built cases with known answers (paper Sec. 3.5):
depth-guided initialisation (exact back-projection of a known plane), every term of Eq. 6 against a
hand computation, the crop the 3D stage optimises on, which Gaussians 3D inpainting may change, and
recursive conditioning along two overlapping views. The stage's CLI on bad input is in
``reliability/test_bad_input_inpaint.py``; virtual cameras and unseen masks in ``test_views.py``."""

from __future__ import annotations

import math

import numpy as np
import pytest
import torch

from scene_builder import textured_floor
from inpaint360gs.core.camera import Camera
from inpaint360gs.core.gaussians import SH_C0, Gaussians
from inpaint360gs.inpaint.conditioned import InpaintedView, inpaint_views, reprojection_error
from inpaint360gs.inpaint.init import depth_guided_init, naive_init
from inpaint360gs.inpaint.refine import RefineConfig, active_rows, crop_camera, crop_rect, hybrid_loss, refine
from inpaint360gs.metrics.lpips import lpips
from inpaint360gs.render.api import render
from inpaint360gs.views.unseen import footprint, normalised_depth

W, H = 32, 24
PARAMS = ("means", "log_scales", "quats", "opacity_logits", "sh0", "shN")


def colours(g: Gaussians) -> np.ndarray:
    """RGB of degree-0 Gaussians (the inverse of ``Gaussians.from_points``' colour)."""
    return (g.sh0[:, 0].double() * SH_C0 + 0.5).numpy()


def cat(*gs: Gaussians) -> Gaussians:
    return Gaussians(**{k: torch.cat([getattr(g, k) for g in gs], 0) for k in PARAMS})


# --- depth-guided initialisation: exact back-projection of a known plane ----------------------------

PLANE_N = np.array([0.0, 0.0, 1.0])  # the plane z = 0.1 in world coordinates
PLANE_C = 0.1


def oblique_camera(w: int = W, h: int = H, f: float = 30.0) -> Camera:
    return Camera.look_at((0.6, -2.0, 1.7), (0.1, 0.2, PLANE_C), (0, 0, 1), f, f * 1.1, w / 2 + 0.7, h / 2 - 0.4, w, h, name="oblique")


def plane_depth(cam: Camera) -> tuple[np.ndarray, np.ndarray]:
    """(camera z (H, W), world points (H, W, 3)) of the plane at every pixel centre, in float64."""
    R, t = cam.R.double().numpy(), cam.t.double().numpy()
    j, i = np.meshgrid(np.arange(cam.width) + 0.5, np.arange(cam.height) + 0.5)
    d_cam = np.stack([(j - cam.cx) / cam.fx, (i - cam.cy) / cam.fy, np.ones_like(j)], -1)  # z = 1 rays
    d_world = d_cam @ R
    c = -R.T @ t
    z = (PLANE_C - c @ PLANE_N) / (d_world @ PLANE_N)
    assert (z > 0).all()
    return z, c + z[..., None] * d_world


def colour_of(points: np.ndarray) -> np.ndarray:
    """A colour linear in the world position (so a voxel's mean colour is the colour of its mean point)."""
    return np.clip(np.stack([0.5 + 0.3 * points[..., 0], 0.4 + 0.25 * points[..., 1], 0.6 - 0.1 * points[..., 0] + 0.1 * points[..., 1]], -1), 0, 1)


def plane_view(mask: np.ndarray | None = None) -> tuple[InpaintedView, np.ndarray]:
    cam = oblique_camera()
    z, pts = plane_depth(cam)
    if mask is None:
        mask = np.zeros((H, W), bool)
        mask[5:20, 6:27] = True
    view = InpaintedView(cam, colour_of(pts).astype(np.float32), z.astype(np.float32), mask, np.ones((H, W), bool), np.zeros((H, W), bool))
    return view, pts


def test_depth_guided_points_lie_on_the_plane_with_the_images_colours():
    view, pts = plane_view()
    assert 0.8 < np.linalg.norm(colour_of(pts)[view.mask] - 0.5, axis=-1).mean() * 4  # the colour varies across the region
    # one voxel per pixel: the Gaussians are exactly the back-projected masked pixels (the statistical
    # outlier filter may drop the sparsest few: the far edge of a plane seen at a slant)
    g = depth_guided_init([view], voxel_pixels=1e-3, sh_degree=0)
    ref = pts[view.mask]
    assert 0.98 * len(ref) <= len(g) <= len(ref)
    means = g.means.double().numpy()
    from scipy.spatial import cKDTree

    dist, idx = cKDTree(ref).query(means)
    assert dist.max() < 2e-6 * np.linalg.norm(ref, axis=1).max()  # float32 depth and positions, nothing more
    assert len(np.unique(idx)) == len(g)  # one Gaussian per pixel
    assert np.abs(colours(g) - view.color[view.mask][idx]).max() < 1e-6
    # the default thinning (a voxel of ~1.5 pixels' footprint) keeps them on the plane, coloured as the image there
    g = depth_guided_init([view], sh_degree=3)
    means = g.means.double().numpy()
    assert 10 < len(g) < view.mask.sum()
    assert np.abs(means @ PLANE_N - PLANE_C).max() < 1e-6
    assert np.abs(colours(g) - colour_of(means)).max() < 1e-5
    assert g.sh_degree == 3 and not g.shN.any()
    # every point comes from a masked pixel: it projects into the mask
    from inpaint360gs.views.unseen import project

    u, v, _ = project(view.camera, means)
    assert view.mask[v.astype(int), u.astype(int)].all()


def test_an_isolated_depth_spike_is_filtered_out():
    view, _ = plane_view()
    view.depth[12, 15] *= 0.5  # one pixel's depth halved: a point far off the plane, alone
    clean = depth_guided_init([plane_view()[0]], voxel_pixels=1e-3, sh_degree=0)
    g = depth_guided_init([view], voxel_pixels=1e-3, sh_degree=0)
    assert len(g) == len(clean) - 1  # the spike's pixel, and nothing else
    assert np.abs(g.means.double().numpy() @ PLANE_N - PLANE_C).max() < 1e-6


def test_depth_guided_init_fuses_views_and_skips_pixels_without_depth():
    view, pts = plane_view()
    other = InpaintedView(view.camera, view.color, view.depth.copy(), view.mask.copy(), view.valid, view.from_condition)
    other.depth[view.mask] = 0.0  # no depth anywhere: contributes nothing
    g1 = depth_guided_init([view], voxel_pixels=1e-3, sh_degree=0)
    g2 = depth_guided_init([view, other], voxel_pixels=1e-3, sh_degree=0)
    assert torch.equal(g1.means, g2.means)
    from inpaint360gs.core.errors import InputError

    with pytest.raises(InputError, match="unseen masks are empty"):
        depth_guided_init([plane_view(np.zeros((H, W), bool))[0]])


def test_naive_init_is_uniform_in_the_box_and_seeded():
    view, _ = plane_view()
    lo, hi = np.array([-0.3, 0.2, 0.0]), np.array([0.1, 0.5, 0.4])
    g = naive_init([view], lo, hi, 400, seed=3, sh_degree=1)
    m = g.means.double().numpy()
    assert len(g) == 400 and g.sh_degree == 1
    assert (m >= lo - 1e-7).all() and (m <= hi + 1e-7).all()
    assert np.allclose(m.min(0), lo, atol=0.03) and np.allclose(m.max(0), hi, atol=0.03)  # the whole box, uniformly
    assert torch.equal(g.means, naive_init([view], lo, hi, 400, seed=3).means)
    assert not torch.equal(g.means, naive_init([view], lo, hi, 400, seed=4).means)
    mean_colour = view.color[view.mask].astype(np.float64).mean(0)
    assert np.abs(colours(g) - mean_colour).max() < 1e-6


# --- Eq. 6 term by term ----------------------------------------------------------------------------

LH, LW = 40, 48  # large enough for the LPIPS crop of a 16 x 16 mask


def loss_case(seed: int = 0):
    rng = np.random.default_rng(seed)
    target = torch.from_numpy(rng.random((LH, LW, 3))).float()
    pred = (target + 0.3 * torch.from_numpy(rng.standard_normal((LH, LW, 3))).float()).clamp(0, 1)
    mask = torch.zeros(LH, LW, dtype=torch.bool)
    mask[12:28, 16:32] = True
    valid = torch.ones(LH, LW, dtype=torch.bool)
    return pred, target, mask, valid


def cfg(**kw) -> RefineConfig:
    return RefineConfig(**kw).resolved()


def test_masked_l1_is_the_mean_over_the_mask_pixels():
    pred, target, mask, valid = loss_case()
    hand = sum(abs(float(pred[i, j, c]) - float(target[i, j, c])) for i, j in zip(*np.nonzero(mask.numpy())) for c in range(3)) / (3 * int(mask.sum()))
    _, logs = hybrid_loss(pred, target, mask, valid, cfg(lambda_lpips=0.0))
    assert logs["l1"] == pytest.approx(hand, rel=1e-6)
    # the authors' code: over every valid pixel
    valid[:5] = False
    v = valid.numpy()
    hand_code = np.abs(pred.double().numpy() - target.double().numpy())[v].mean()
    _, logs = hybrid_loss(pred, target, mask, valid, cfg(variant="code", lambda_lpips=0.0))
    assert logs["l1"] == pytest.approx(hand_code, rel=1e-6)


def test_dssim_sees_the_whole_valid_image_and_lpips_only_the_masked_crop():
    pred, target, mask, valid = loss_case()
    c = cfg()
    _, base = hybrid_loss(pred, target, mask, valid, c)
    outside = pred.clone()
    outside[:4, :6] = 1.0 - outside[:4, :6]  # outside the mask and outside the LPIPS crop
    _, o = hybrid_loss(outside, target, mask, valid, c)
    assert o["l1"] == base["l1"] and o["lpips"] == base["lpips"]
    assert abs(o["dssim"] - base["dssim"]) > 1e-3
    near = pred.clone()
    near[8:11, 16:32] = 1.0 - near[8:11, 16:32]  # inside the LPIPS crop (margin 8) but not the mask: multiplied away
    _, o = hybrid_loss(near, target, mask, valid, c)
    assert o["l1"] == base["l1"] and o["lpips"] == pytest.approx(base["lpips"], abs=1e-7)
    inside = pred.clone()
    inside[15:20, 20:25] = 1.0 - inside[15:20, 20:25]
    _, o = hybrid_loss(inside, target, mask, valid, c)
    assert o["l1"] != base["l1"] and abs(o["lpips"] - base["lpips"]) > 1e-6 and o["dssim"] != base["dssim"]
    # pixels marked invalid (holes left by occluders taken out) do not count in D-SSIM
    invalid = valid.clone()
    invalid[:12] = False
    _, a = hybrid_loss(pred, target, mask, invalid, c)
    _, b = hybrid_loss(outside, target, mask, invalid, c)
    assert a["dssim"] == pytest.approx(b["dssim"], abs=1e-7) and a["dssim"] != base["dssim"]
    # the LPIPS term by hand: both images times the mask, on the mask's box grown by the margin
    m = mask[..., None].float()
    crop = (slice(12 - 8, 28 + 8), slice(16 - 8, 32 + 8))
    hand = lpips((pred * m)[crop].permute(2, 0, 1), (target * m)[crop].permute(2, 0, 1), net="alex")
    assert base["lpips"] == pytest.approx(float(hand), rel=1e-6)


def test_the_lambdas_weigh_the_terms_linearly():
    pred, target, mask, valid = loss_case(1)
    loss, logs = hybrid_loss(pred, target, mask, valid, cfg(lambda_dssim=0.3, lambda_lpips=0.05))
    assert float(loss) == pytest.approx(0.7 * logs["l1"] + 0.3 * logs["dssim"] + 0.05 * logs["lpips"], rel=1e-6)
    no_lp, l0 = hybrid_loss(pred, target, mask, valid, cfg(lambda_dssim=0.3, lambda_lpips=0.0))
    assert "lpips" not in l0 and float(no_lp) == pytest.approx(0.7 * logs["l1"] + 0.3 * logs["dssim"], rel=1e-6)
    assert float(loss - no_lp) == pytest.approx(0.05 * logs["lpips"], rel=1e-5)
    no_ssim, _ = hybrid_loss(pred, target, mask, valid, cfg(lambda_dssim=0.0, lambda_lpips=0.05))
    assert float(no_ssim) == pytest.approx(logs["l1"] + 0.05 * logs["lpips"], rel=1e-6)
    # the defaults are the paper's (supp. B): lambda1 = 0.2, lambda2 = 0.005
    paper, lp = hybrid_loss(pred, target, mask, valid, cfg())
    assert float(paper) == pytest.approx(0.8 * lp["l1"] + 0.2 * lp["dssim"] + 0.005 * lp["lpips"], rel=1e-6)


def test_mask_supervision_ignores_everything_outside_the_mask():
    """Ablation e): masked L1 (and LPIPS) only."""
    pred, target, mask, valid = loss_case(2)
    c = cfg(supervision="mask")
    loss, logs = hybrid_loss(pred, target, mask, valid, c)
    assert "dssim" not in logs
    assert float(loss) == pytest.approx(logs["l1"] + 0.005 * logs["lpips"], rel=1e-6)
    outside = pred.clone()
    outside[~mask] = 1.0 - outside[~mask]
    loss2, _ = hybrid_loss(outside, target, mask, valid, c)
    assert float(loss2) == pytest.approx(float(loss), abs=1e-7)
    hybrid, _ = hybrid_loss(outside, target, mask, valid, cfg())
    assert float(hybrid) != pytest.approx(float(hybrid_loss(pred, target, mask, valid, cfg())[0]), abs=1e-4)


@pytest.mark.parametrize("where", ["centre", "corner"])
def test_a_small_mask_still_gets_an_lpips_term(where):
    """A few-pixel region (what survives the unseen mask's cleaning, or one near a border) gives an
    LPIPS crop smaller than AlexNet's receptive field needs; the term must still be computed."""
    pred, target, _, valid = loss_case(3)
    mask = torch.zeros(LH, LW, dtype=torch.bool)
    if where == "centre":
        mask[20:23, 24:26] = True
    else:
        mask[0:2, LW - 2 :] = True
    pred.requires_grad_(True)
    loss, logs = hybrid_loss(pred, target, mask, valid, cfg())
    assert math.isfinite(loss.item()) and logs["lpips"] > 0
    loss.backward()
    assert torch.isfinite(pred.grad).all()
    tiny = (slice(0, 12), slice(0, 10))  # a whole image smaller than the network's input
    loss, logs = hybrid_loss(pred.detach()[tiny], target[tiny], mask[tiny] | True, valid[tiny], cfg())
    assert math.isfinite(float(loss)) and "lpips" in logs


# --- the crop each view is optimised on --------------------------------------------------------------


def test_crop_rect_grows_the_mask_box_and_clips_to_the_image():
    m = np.zeros((H, W), bool)
    m[10:15, 20:30] = True  # rows 10..14, cols 20..29
    assert crop_rect(m, 3, 0.5) == (15, 7, 32, 18)  # x: 20 - max(3, 5), 30 + 5 -> clipped to 32; y: 10 - 3, 15 + 3
    assert crop_rect(m, 0, 0.0) == (20, 10, 30, 15)
    assert crop_rect(m, 100, 0.0) == (0, 0, W, H)


def few_gaussians(seed: int = 0, n: int = 40, spread: float = 0.6, scale: tuple[float, float] = (0.05, 0.2)) -> Gaussians:
    rng = np.random.default_rng(seed)
    pts = torch.from_numpy(rng.uniform(-spread, spread, (n, 3))).float()
    g = Gaussians.from_points(pts, torch.from_numpy(rng.random((n, 3))).float(), sh_degree=1, init_opacity=0.8,
                              scales=torch.from_numpy(rng.uniform(*scale, n)).float())  # fmt: skip
    g.shN.normal_(0, 0.2, generator=torch.Generator().manual_seed(seed))  # view-dependent colour too
    g.quats.copy_(torch.from_numpy(rng.standard_normal((n, 4))).float())
    g.log_scales.add_(torch.from_numpy(rng.uniform(-0.5, 0.5, (n, 3))).float())
    return g


@pytest.mark.parametrize("backend", ["torch", "numba"])
def test_rendering_a_cropped_camera_is_the_crop_of_the_full_render(backend):
    """Exact wherever the Gaussians that reach the crop have their centres within 1.3x its field of
    view: 3DGS evaluates the projection's Jacobian at the centre clamped to that range, which depends
    on the image frame (see the next test for what that costs at a crop's border)."""
    cam = Camera.look_at((0.5, -2.5, 1.0), (0, 0, 0), (0, 0, 1), 28.0, 28.0, W / 2, H / 2, W, H)
    g = few_gaussians(n=60, spread=0.15, scale=(0.01, 0.03))  # small, around the image centre
    full = render(g, cam, backend=backend)
    assert float(full.alpha.max()) > 0.5
    for rect in [(0, 0, W, H), (8, 4, 24, 20), (10, 6, 26, 24), (6, 0, 22, 18)]:
        x0, y0, x1, y1 = rect
        part = render(g, crop_camera(cam, rect), backend=backend)
        assert part.color.shape == (y1 - y0, x1 - x0, 3)
        for a, b in ((part.color, full.color), (part.depth, full.depth), (part.alpha, full.alpha)):
            assert torch.allclose(a, b[y0:y1, x0:x1], atol=2e-6), (rect, float((a - b[y0:y1, x0:x1]).abs().max()))


def test_the_crops_of_3d_inpainting_match_the_full_render_up_to_the_jacobian_clamp():
    """The crops :func:`refine` optimises on (the mask's box grown by half its size): on the masked
    pixels (the L1 and LPIPS terms) the crop render is the full render's crop; near the crop's border,
    big Gaussians centred outside it differ by the Jacobian clamp, a fraction of a percent."""
    floor = textured_floor()
    hole = (floor.means[:, :2].abs() < 0.35).all(1)
    for cam in floor_cameras([0, 110], w=96, h=72, f=78.0):
        full = render(floor, cam)
        mask = footprint(floor, hole, cam, 0.5)
        x0, y0, x1, y1 = rect = crop_rect(mask, 16, 0.5)
        assert (x1 - x0) * (y1 - y0) < 0.6 * mask.size  # a real crop
        part = render(floor, crop_camera(cam, rect))
        diff = (part.color - full.color[y0:y1, x0:x1]).abs().max(-1).values.numpy()
        assert diff[mask[y0:y1, x0:x1]].max() < 5e-4
        assert diff.max() < 5e-3


# --- 3D inpainting: which Gaussians change, and the loss goes down --------------------------------------


def floor_cameras(angles_deg, w: int = W, h: int = H, f: float = 26.0, radius: float = 2.2, height: float = 1.6) -> list[Camera]:
    cams = []
    for k, a in enumerate(np.radians(angles_deg)):
        eye = (radius * math.cos(a), radius * math.sin(a), height)
        cams.append(Camera.look_at(eye, (0, 0, 0), (0, 0, 1), f, f, w / 2, h / 2, w, h, name=f"v{k}"))
    return cams


@pytest.fixture(scope="module")
def hole_case():
    """The floor with a square of it removed, views of the whole floor as the inpainted targets, and
    grey new Gaussians where the square was (what the 3D stage must recolour)."""
    floor = textured_floor()
    hole = (floor.means[:, :2].abs() < 0.35).all(1)
    edited = floor.subset(~hole)
    cams = floor_cameras([0, 50, 110, 200], w=64, h=48, f=52.0)  # crops smaller than the image
    views = []
    with torch.no_grad():
        for cam in cams:
            o = render(floor, cam)
            mask = footprint(floor, hole, cam, 0.5)
            x0, y0, x1, y1 = crop_rect(mask, RefineConfig.crop_margin_px, 0.5)
            assert mask.sum() > 20 and (x1 - x0) * (y1 - y0) < 0.8 * mask.size
            views.append(InpaintedView(cam, o.color.clamp(0, 1).numpy(), normalised_depth(o).numpy(), mask, np.ones(mask.shape, bool), np.zeros(mask.shape, bool)))
    removed = floor.subset(hole)
    new = Gaussians.from_points(removed.means.clone(), torch.full((len(removed), 3), 0.5), sh_degree=0, init_opacity=0.5,
                                scales=torch.full((len(removed),), 0.07))  # fmt: skip
    return floor, hole, edited, new, views


def eq6(model: Gaussians, views, c: RefineConfig) -> float:
    with torch.no_grad():
        return float(np.mean([float(hybrid_loss(render(model, v.camera).color, torch.from_numpy(v.color), torch.from_numpy(v.mask),
                                                  torch.from_numpy(v.valid), c)[0]) for v in views]))  # fmt: skip


@pytest.mark.parametrize("supervision", ["hybrid", "mask"])
def test_refine_changes_only_the_region_and_lowers_the_loss(hole_case, supervision):
    floor, hole, edited, new, views = hole_case
    region = floor.means[hole].double().numpy()
    c = RefineConfig(iterations=40, supervision=supervision, seed=1)
    final, log = refine(edited, new, views, c, region=region, extent=2.0)
    assert len(final) == len(edited) + len(new)
    if supervision == "hybrid":
        active = active_rows(edited, np.concatenate([region, new.means.double().numpy()]), c.region_margin)
    else:  # ablation e): only what projects into a mask
        from inpaint360gs.inpaint.refine import _rows_in_masks

        active = _rows_in_masks(edited, views)
    assert 0 < int(active.sum()) < len(edited) // 2
    static = edited.subset(~active)
    n = len(static)
    for k in PARAMS:  # the static Gaussians come back first, bit for bit
        assert torch.equal(getattr(final, k)[:n], getattr(static, k)), k
    moved = final.subset(torch.arange(n, len(final)))
    assert not torch.equal(moved.sh0[-len(new):], new.sh0)  # the new Gaussians were recoloured
    before = eq6(cat(edited, Gaussians(**_pad_sh(new, edited))), views, c.resolved())
    after = eq6(final, views, c.resolved())
    assert after < 0.8 * before, (before, after)
    assert log and log[-1]["step"] == 40
    # deterministic: the same seed gives the same bytes
    again, _ = refine(edited, new, views, c, region=region, extent=2.0)
    assert all(torch.equal(getattr(final, k), getattr(again, k)) for k in PARAMS)


def _pad_sh(new: Gaussians, like: Gaussians) -> dict:
    d = {k: getattr(new, k) for k in PARAMS}
    d["shN"] = torch.zeros(len(new), like.shN.shape[1], 3)
    return d


# --- recursive conditioning (Sec. 3.5): view 2 takes what view 1 filled --------------------------------


class PerViewFill:
    """A 2D inpainter that fills each call's hole with its own flat colour: views inpainted on their
    own disagree, so any agreement comes from the conditioning."""

    PALETTE = np.array([[0.9, 0.2, 0.1], [0.1, 0.3, 0.9], [0.2, 0.8, 0.3]], np.float32)

    def __init__(self):
        self.calls = 0

    def __call__(self, image: np.ndarray, mask: np.ndarray) -> np.ndarray:
        out = image.copy()
        out[mask] = self.PALETTE[self.calls % len(self.PALETTE)]
        self.calls += 1
        return out


@pytest.fixture(scope="module")
def conditioned_case():
    from inpaint360gs.inpaint.inpainters import make_inpainter

    floor = textured_floor(step=0.05, half=2.5)
    hole = (floor.means[:, :2].abs() < 0.4).all(1)
    edited = floor.subset(~hole)
    cams = floor_cameras([0, 25], w=48, h=36, f=36.0)
    masks = [footprint(floor, hole, c, 0.5) for c in cams]
    depth = make_inpainter("plane").depth
    # blend=False: what a view takes from earlier ones, as it was (the blending has its own test)
    runs = {cond: inpaint_views(edited, cams, masks, PerViewFill(), depth, condition=cond, blend=False) for cond in (True, False)}
    return cams, masks, runs


def test_conditioned_view_takes_the_first_views_fill(conditioned_case):
    cams, masks, runs = conditioned_case
    first, second = runs[True]
    assert not first.from_condition.any()  # nothing before the first view
    cond = second.from_condition
    assert cond.sum() > 0.5 * second.mask.sum() and not (cond & ~second.mask).any()
    # those pixels carry the first view's colour (its flat fill), not the second view's own fill
    assert np.abs(second.color[cond] - PerViewFill.PALETTE[0]).max() < 0.02
    # and the plane's depth (what the depth inpainter recovers on its own, exactly), up to the splat size
    # of the first view's pixels: round Gaussians about a pixel wide, the front ones weigh most
    _, second_alone = runs[False]
    rel = (second.depth[cond] - second_alone.depth[cond]) / second_alone.depth[cond]
    assert np.abs(rel).max() < 0.05 and abs(rel.mean()) < 0.03, (rel.min(), rel.mean(), rel.max())
    # outside the masks nothing differs
    assert np.array_equal(first.color[~first.mask], runs[False][0].color[~first.mask])
    assert np.array_equal(second.color[~second.mask], second_alone.color[~second.mask])


def test_conditioning_lowers_the_reprojection_error(conditioned_case):
    _, _, runs = conditioned_case
    with_cond, without = reprojection_error(runs[True]), reprojection_error(runs[False])
    assert without > 0.3  # two different flat colours
    assert with_cond < 0.1 * without, (with_cond, without)


def test_new_gaussians_are_surfels_lying_in_the_surface():
    """Each new Gaussian is flat in the plane it continues: its thin axis along the plane's normal,
    a tenth of its radius in the plane."""
    from inpaint360gs.core.gaussians import quat_to_rotmat

    view, _ = plane_view()
    g = depth_guided_init([view], sh_degree=0)
    rot = quat_to_rotmat(g.quats.double())
    thin = rot[:, :, 2].numpy()  # the local z axis: the smallest scale
    s = g.log_scales.exp().double().numpy()
    assert np.allclose(s[:, 2], 0.1 * s[:, 0]) and np.allclose(s[:, 0], s[:, 1])
    interior = np.abs(np.abs(thin @ PLANE_N) - 1.0) < 1e-3
    assert interior.mean() > 0.98  # a plane's neighbourhoods are planar everywhere


def test_init_takes_each_surface_point_from_the_view_that_filled_it():
    """Pixels a view took over from earlier views (``from_condition``) add no Gaussians: the first
    view that inpainted a point initialises it (paper supp. B: the first inpainted view)."""
    view, _ = plane_view()
    taken = InpaintedView(view.camera, view.color, view.depth, view.mask, view.valid, view.mask.copy())
    g1 = depth_guided_init([view], voxel_pixels=1e-3, sh_degree=0)
    g2 = depth_guided_init([view, taken], voxel_pixels=1e-3, sh_degree=0)
    assert torch.equal(g1.means, g2.means)


def test_plane_depth_and_the_support_camera():
    """``plane_depth`` against the float64 ray-plane intersection; the support view looks straight
    down the plane's normal at the footprint's centre, the footprint filling half the short side."""
    from inpaint360gs.core.support import Footprint
    from inpaint360gs.views.unseen import backproject, project
    from inpaint360gs.views.virtual import plane_depth as virtual_plane_depth
    from inpaint360gs.views.virtual import support_camera

    cam = oblique_camera()
    z_ref, _ = plane_depth(cam)
    assert np.allclose(virtual_plane_depth(cam, PLANE_N, PLANE_C), z_ref, rtol=1e-6)  # the camera is float32
    square = np.array([[-0.2, -0.2], [0.2, -0.2], [0.2, 0.2], [-0.2, 0.2]]) + [0.3, -0.1]
    fp = Footprint(PLANE_N, PLANE_C, square, 0.5)
    top = support_camera(fp, cam, fill=0.5)
    assert np.allclose(top.R.double().numpy()[2], -PLANE_N, atol=1e-6)  # looking straight down
    u, v, _ = project(top, fp.to_world(square))
    assert np.allclose([u.mean(), v.mean()], [top.width / 2, top.height / 2], atol=1e-3)
    height = float(top.center.double().numpy() @ PLANE_N - PLANE_C)
    assert height * 0.5 * min(top.width, top.height) == pytest.approx(fp.diameter * max(cam.fx, cam.fy), rel=1e-5)  # the diameter at the larger focal length spans half the short side
    assert fp.diameter == pytest.approx(0.4 * math.sqrt(2))
    z = virtual_plane_depth(top, PLANE_N, PLANE_C)
    assert np.ptp(z) < 1e-9 * z.mean()  # an image plane parallel to the support: one depth
    rows, cols = np.array([3, 10]), np.array([4, 20])
    assert np.allclose(backproject(top, z[rows, cols], rows, cols) @ PLANE_N, PLANE_C)


def test_blending_takes_the_views_brightness_and_keeps_the_taken_texture():
    """Pixels taken from an earlier view whose colours are 0.1 darker than this view sees the surface
    (a view-dependent colour): after blending the offset is gone at the border and inside (the
    membrane interpolation of a constant is that constant), and the texture is the taken one."""
    from inpaint360gs.inpaint.conditioned import blend_into_view

    rng = np.random.default_rng(0)
    view = (0.4 + 0.2 * rng.random((40, 50, 3))).astype(np.float32)
    taken = np.zeros((40, 50), bool)
    taken[10:30, 12:40] = True
    img = view.copy()
    img[taken] -= 0.1
    out = blend_into_view(img, taken, taken)
    err = out[taken] - view[taken]
    assert abs(err.mean()) < 0.005 and np.abs(err).max() < 0.05  # the border pixels' own texture differences stay, smoothed
    corr = (out - img)[taken]
    assert corr.std() < 0.2 * view[taken].std()  # a smooth shift: the taken texture is kept
    assert np.array_equal(out[~taken], img[~taken])
    # a smooth mismatch (brighter on the left border than the right) is corrected smoothly, the texture kept
    ramp = np.linspace(0.1, -0.1, 50)[None, :, None].astype(np.float32)
    img = view.copy()
    img[taken] = (view + ramp)[taken]
    out = blend_into_view(img, taken, taken)
    assert np.abs(out[taken] - view[taken]).mean() < 0.01


def test_plane_transfer_carries_an_earlier_views_fill_by_the_plane_homography():
    """Two views of the plane z = 0.1 with a colour linear in position: the second view's masked
    pixels take the first view's colours through the plane (bilinear: exact for a linear colour), its
    depth is the plane's; pixels the first view did not fill, or off the plane, are left."""
    from inpaint360gs.inpaint.conditioned import plane_transfer

    first, _ = plane_view(np.ones((H, W), bool))
    cam2 = Camera.look_at((-0.4, -1.8, 1.9), (0.0, 0.1, PLANE_C), (0, 0, 1), 30.0, 33.0, W / 2, H / 2, W, H, name="second")
    z2, pts2 = plane_depth(cam2)
    mask = np.zeros((H, W), bool)
    mask[6:18, 8:24] = True
    z = z2.copy()
    z[6:9, 8:24] = np.inf  # rays that do not meet the support here
    color, depth = np.zeros((H, W, 3), np.float32), np.ones((H, W), np.float32)
    done = plane_transfer(cam2, z, mask, [(first, plane_depth(first.camera)[0])], color, depth)
    assert np.array_equal(done, mask & np.isfinite(z))
    assert np.abs(color[done] - colour_of(pts2)[done]).max() < 2e-3  # bilinear in the image of a colour linear on the plane
    assert np.allclose(depth[done], z2[done], rtol=1e-6) and (color[~done] == 0).all()
    # an earlier view that filled nothing there gives nothing
    empty = InpaintedView(first.camera, first.color, first.depth, np.zeros((H, W), bool), first.valid, first.from_condition)
    assert not plane_transfer(cam2, z, mask, [(empty, plane_depth(first.camera)[0])], color, depth).any()


def test_with_footprints_only_the_fill_and_the_support_around_it_move(hole_case):
    """The stage's active rows (footprint_rows): the floor within 0.25 of the footprint's size around
    it, not a wall standing beside the hole inside that margin (another object, a backdrop);
    everything else comes back bit for bit after 3D inpainting, the new Gaussians are refitted."""
    from inpaint360gs.core.support import Footprint
    from inpaint360gs.inpaint.stage import footprint_rows, in_columns

    floor, hole, edited, new, views = hole_case
    square = np.array([[-0.35, -0.35], [0.35, -0.35], [0.35, 0.35], [-0.35, 0.35]])
    n = np.array([0.0, 0.0, 1.0])
    fp = Footprint(n, 0.0, square, 0.5)
    zs, ys = np.meshgrid(np.arange(0.1, 0.45, 0.05), np.arange(-0.3, 0.31, 0.05))
    wall = Gaussians.from_points(torch.tensor(np.stack([np.full(zs.size, 0.45), ys.ravel(), zs.ravel()], 1), dtype=torch.float32),
                                 torch.full((zs.size, 3), 0.8), sh_degree=1, init_opacity=0.9, scales=torch.full((zs.size,), 0.03))  # fmt: skip
    scene = cat(edited, wall)
    active = footprint_rows(scene, [fp], 0.25)
    xy = scene.means[:, :2].double().numpy()
    near = (np.abs(xy) <= 0.35 + 0.25 * 0.7 + 1e-6).all(axis=1)  # the square grown by 0.25 x its size (0.7), mitred
    assert near[len(edited):].all()  # the wall stands inside the grown column ...
    assert np.array_equal(active.numpy(), near & (np.abs(scene.means[:, 2].numpy()) < 0.05))  # ... and stays: only the support moves
    assert in_columns(new.means.double().numpy(), [fp], 0.25).all()  # the new Gaussians lie in the column
    c = RefineConfig(iterations=20, seed=0)
    final, _ = refine(scene, new, views, c, region=floor.means[hole].double().numpy(), extent=2.0, active=active)
    static = scene.subset(~active)
    k = len(static)
    for p in PARAMS:
        assert torch.equal(getattr(final, p)[:k], getattr(static, p)), p
    assert not torch.equal(final.sh0[-len(new):], new.sh0)


def test_the_fill_keeps_new_gaussians_on_the_support_and_drops_those_standing_in_the_column():
    """fill_rows with a 1 x 1 footprint of an object 1 high: a point on the support inside the
    column, or a little below it, is kept; one standing a third of the height over the support
    inside the grown column (empty air after the removal) is dropped, as is one outside the column."""
    from inpaint360gs.core.support import Footprint
    from inpaint360gs.inpaint.stage import InpaintConfig, fill_rows

    fp = Footprint(np.array([0.0, 0.0, 1.0]), 0.0, np.array([[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]]), 1.0)
    pts = np.array([[0.0, 0.0, 0.0], [0.3, -0.2, 0.05], [0.2, 0.1, -0.3], [0.0, 0.0, 0.33], [0.4, 0.4, 1.5], [0.9, 0.0, 0.0]])
    assert fill_rows(pts, [fp], InpaintConfig()).tolist() == [True, True, True, False, False, False]


def test_a_faint_haze_over_the_hole_does_not_hide_the_support_an_opaque_sheet_does(hole_case):
    """revealed_geometry over the floor with a hole: the support's depth is given where the rays meet
    the footprint grown by its margin. Four layers of faint Gaussians (opacity 0.02) over it
    pull the alpha-normalised depth of the floor around the hole more than 3 % in front of it, but
    give less than half of the colour (share_in_front), so the support stays; one opaque sheet hides it."""
    from inpaint360gs.core.support import Footprint
    from inpaint360gs.inpaint.stage import InpaintConfig, revealed_geometry
    from inpaint360gs.views.unseen import share_in_front

    floor, hole, edited, new, views = hole_case
    fp = Footprint(np.array([0.0, 0.0, 1.0]), 0.0, np.array([[-0.35, -0.35], [0.35, -0.35], [0.35, 0.35], [-0.35, 0.35]]), 0.5)
    cfg = InpaintConfig()
    cam = views[0].camera
    plane = [(fp.normal, fp.offset)]
    g = np.arange(-0.5, 0.51, 0.05)
    x, y = np.meshgrid(g, g)

    def sheets(heights, opacity: float, scale: float) -> Gaussians:
        pts = np.concatenate([np.stack([x.ravel(), y.ravel(), np.full(x.size, z)], 1) for z in heights])
        s = Gaussians.from_points(torch.tensor(pts, dtype=torch.float32), torch.full((len(pts), 3), 0.9), sh_degree=1, init_opacity=opacity,
                                  scales=torch.full((len(pts),), scale))  # fmt: skip
        s.log_scales.data[:, 2] = math.log(1e-3)
        return s

    bare = revealed_geometry(cam, edited, [fp], cfg).support
    assert np.isfinite(bare).sum() > 50
    hazy = cat(edited, sheets([0.3, 0.4, 0.5, 0.6], 0.02, 0.05))
    with torch.no_grad():
        o = render(hazy, cam)
    d, alpha = normalised_depth(o).numpy(), o.alpha.numpy()
    pulled = np.isfinite(bare) & (alpha >= 0.5) & (d < 0.97 * bare)  # where the depth alone would call the support hidden
    assert pulled.sum() > 0.5 * np.isfinite(bare).sum()
    assert share_in_front(hazy, cam, plane)[np.isfinite(bare)].max() < 0.5
    assert np.array_equal(revealed_geometry(cam, hazy, [fp], cfg).support, bare)
    opaque = cat(edited, sheets([0.3], 0.99, 0.04))
    covered = share_in_front(opaque, cam, plane) >= 0.5
    assert covered.sum() > 20
    hidden = revealed_geometry(cam, opaque, [fp], cfg).support
    assert np.isinf(hidden[covered]).all() and np.array_equal(hidden[~covered], bare[~covered])


def test_a_thinned_surface_beside_the_hole_gives_the_fill_its_colour_not_a_darkening():
    """A uniform floor (0.7, 0.5, 0.3) with a square removed and a ring around it thinned to low
    opacity, as a removal leaves the surface around an object: the render there is the colour
    darkened by alpha (Eq. 1 over black); what the 2D inpainter receives as context is the floor's
    own colour beside the hole, so it copies no darkening into it; farther out the render is left."""
    g = np.arange(-2.5, 2.5 + 1e-9, 0.05)
    x, y = np.meshgrid(g, g)
    pts = np.stack([x.ravel(), y.ravel(), np.zeros(x.size)], 1)
    colour = np.array([0.7, 0.5, 0.3], np.float32)
    floor = Gaussians.from_points(torch.tensor(pts, dtype=torch.float32), torch.tensor(np.tile(colour, (len(pts), 1))), sh_degree=0,
                                  init_opacity=0.99, scales=torch.full((len(pts),), 0.0375))  # fmt: skip
    floor.log_scales[:, 2] = math.log(1e-3)
    hole = (floor.means[:, :2].abs() < 0.4).all(1)
    ring = (floor.means[:, :2].abs() < 0.7).all(1) & ~hole
    with torch.no_grad():
        floor.opacity_logits[ring] = math.log(0.25 / 0.75)
    edited = floor.subset(~hole)
    cam = floor_cameras([0], w=48, h=36, f=36.0)[0]
    mask = footprint(floor, hole, cam, 0.5)
    o = render(edited, cam)
    alpha = o.alpha.numpy()
    thin = ~mask & (alpha >= 0.5) & (alpha < 0.97)
    assert thin.sum() > 20 and (o.color.numpy()[thin].mean(0) < 0.95 * colour).all()  # the render is darker there
    seen = {}

    def fill(image, m):
        seen["image"] = image.copy()
        out = image.copy()
        out[m] = colour
        return out

    inpaint_views(edited, [cam], [mask], fill, lambda d, m: np.where(m, 1.0, d), blend=False)
    import cv2

    r = max(1, round(0.05 * max(mask.shape)))  # beside the hole: within 5 % of the image size
    near = cv2.dilate(mask.astype(np.uint8), cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))) > 0
    assert (thin & near).sum() > 5 and (thin & ~near).sum() > 5
    assert np.abs(seen["image"][thin & near] - colour).max() < 0.02
    # farther out the render is left as the 3DGS has it
    assert np.allclose(seen["image"][thin & ~near], o.color.numpy()[thin & ~near], atol=1e-6)


def test_the_support_view_is_kept_over_a_floor_a_little_off_its_plane_and_left_out_under_a_table_top():
    """The view straight above a footprint (a 1 x 1 square, object height 1, on the plane z = 0) is
    used when the floor it sees lies near the plane (here 0.1 above it: 3.5 % of the camera's
    distance, what a 3DGS floor fitted from low photos shows) and left out when a table top 1.5
    above the support hides it; for a flat object 2 % of the depth is the tolerance."""
    from inpaint360gs.core.support import Footprint
    from inpaint360gs.inpaint.stage import _support_views
    from inpaint360gs.views.virtual import support_camera

    fp = Footprint(np.array([0.0, 0.0, 1.0]), 0.0, np.array([[-0.5, -0.5], [0.5, -0.5], [0.5, 0.5], [-0.5, 0.5]]), 1.0)
    like = floor_cameras([0], w=48, h=36, f=36.0)[0]

    def sheet(z: float) -> Gaussians:
        g = np.arange(-3.0, 3.0 + 1e-9, 0.05)
        x, y = np.meshgrid(g, g)
        keep = ~((np.abs(x) < 0.5) & (np.abs(y) < 0.5))  # the footprint itself is empty after removal
        pts = np.stack([x[keep], y[keep], np.full(keep.sum(), z)], 1)
        s = Gaussians.from_points(torch.tensor(pts, dtype=torch.float32), torch.full((len(pts), 3), 0.5), sh_degree=0, init_opacity=0.99,
                                  scales=torch.full((len(pts),), 0.0375))  # fmt: skip
        s.log_scales.data[:, 2] = math.log(1e-3)
        return s

    cam_height = float(support_camera(fp, like).center[2])
    assert 0.1 / cam_height > 0.02  # the floor is off its plane by more than 2 % of the depth
    assert len(_support_views([fp], like, sheet(0.0), "torch")) == 1
    assert len(_support_views([fp], like, sheet(0.1), "torch")) == 1
    assert _support_views([fp], like, sheet(1.5), "torch") == []
    # a flat object (height 0.05): 2 % of the depth still counts, as it always did
    flat = Footprint(fp.normal, fp.offset, fp.outline, 0.05)
    assert len(_support_views([flat], like, sheet(0.05), "torch")) == 1
