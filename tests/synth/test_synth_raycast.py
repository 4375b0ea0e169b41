"""Ray caster of the synthetic benchmark: closed-form hits, independent implicit-surface checks, textures, cameras."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from dataset_tools.synth import shapes
from dataset_tools.synth.cameras import View, intrinsics, look_at
from dataset_tools.synth.noise import fbm, lattice_hash, value_noise
from dataset_tools.synth.raycast import World
from dataset_tools.synth.render import render
from dataset_tools.synth.spec import ObjectSpec, Prim, SceneSpec, euler_matrix
from dataset_tools.synth.textures import Material, albedo, box_square
from inpaint360gs.core.camera import Camera

FLAT = Material("noise", ((0.5, 0.5, 0.5), (0.5, 0.5, 0.5)), scale=0.1, detail=0.0)

# Independent implicit descriptions (negative inside) of every shape, for a brute-force reference.
PARAMS = {
    "ellipsoid": (0.6, 0.4, 0.3),
    "box": (0.5, 0.3, 0.2),
    "cylinder": (0.3, 0.5),
    "cone": (0.4, 0.1, 0.35),
    "capsule": (0.2, 0.4),
    "torus": (0.5, 0.15),
}


def inside(shape: str, x: np.ndarray) -> np.ndarray:
    p = PARAMS[shape]
    X, Y, Z = x[..., 0], x[..., 1], x[..., 2]
    if shape == "ellipsoid":
        return (X / p[0]) ** 2 + (Y / p[1]) ** 2 + (Z / p[2]) ** 2 < 1
    if shape == "box":
        return (np.abs(X) < p[0]) & (np.abs(Y) < p[1]) & (np.abs(Z) < p[2])
    if shape == "cylinder":
        return (X**2 + Y**2 < p[0] ** 2) & (np.abs(Z) < p[1])
    if shape == "cone":
        r = p[0] + (p[1] - p[0]) * (Z + p[2]) / (2 * p[2])
        return (X**2 + Y**2 < r**2) & (np.abs(Z) < p[2])
    if shape == "capsule":
        zc = np.clip(Z, -p[1], p[1])
        return X**2 + Y**2 + (Z - zc) ** 2 < p[0] ** 2
    if shape == "torus":
        return (np.hypot(X, Y) - p[0]) ** 2 + Z**2 < p[1] ** 2
    raise ValueError(shape)


@pytest.mark.parametrize("shape", sorted(PARAMS))
def test_first_hit_matches_brute_force_march(shape):
    """The returned t is the first entry into the solid: outside just before, inside just after, never inside earlier."""
    rng = np.random.default_rng(1)
    n = 400
    o = rng.normal(size=(n, 3))
    o = o / np.linalg.norm(o, axis=1, keepdims=True) * 2.0
    target = rng.uniform(-0.4, 0.4, size=(n, 3))
    d = (target - o) * rng.uniform(0.5, 2.0, size=(n, 1))  # arbitrary lengths: t is in units of |d|
    t = shapes.intersect(shape, o, d, PARAMS[shape])
    hit = np.isfinite(t)
    assert hit.sum() > n // 4
    ts = np.linspace(0.0, 1.0, 4001)[None, :, None]
    # dense march up to the hit (or the whole relevant range for misses)
    far = np.where(hit, t, 3.0)[:, None, None]
    pts = o[:, None, :] + ts * far * d[:, None, :]
    ins = inside(shape, pts)
    assert not ins[:, :-2].any(), "a point before the reported first hit is inside the solid"
    eps = 1e-7
    before = o + (t - eps)[:, None] * d
    after = o + (t + eps)[:, None] * d
    assert not inside(shape, before[hit]).any()
    assert inside(shape, after[hit]).all()


@pytest.mark.parametrize("shape", sorted(PARAMS))
def test_normals_point_outward(shape):
    rng = np.random.default_rng(2)
    o = rng.normal(size=(300, 3))
    o = o / np.linalg.norm(o, axis=1, keepdims=True) * 2.0
    d = rng.uniform(-0.3, 0.3, size=(300, 3)) - o
    t = shapes.intersect(shape, o, d, PARAMS[shape])
    hit = np.isfinite(t)
    x = o[hit] + t[hit, None] * d[hit]
    n = shapes.normal(shape, x, PARAMS[shape])
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-12)
    assert not inside(shape, x + 1e-6 * n).any()
    assert inside(shape, x - 1e-6 * n).mean() > 0.98  # edges/rims may be ambiguous


def test_closed_forms():
    # sphere radius 0.5 at the origin, ray from z = -3 along +z: t = 2.5 (entry), from inside: exit at 0.5
    np.testing.assert_allclose(shapes.intersect("ellipsoid", np.array([[0, 0, -3.0]]), np.array([[0, 0, 1.0]]), (0.5,) * 3), [2.5])
    np.testing.assert_allclose(shapes.intersect("ellipsoid", np.array([[0, 0, 0.0]]), np.array([[0, 0, 2.0]]), (0.5,) * 3), [0.25])
    # torus R = 1, r = 0.25 in z = 0, ray along +x from x = -5 through the centre: hits at x = -1.25
    np.testing.assert_allclose(shapes.intersect("torus", np.array([[-5.0, 0, 0]]), np.array([[1.0, 0, 0]]), (1.0, 0.25)), [3.75], rtol=1e-12)
    # ... and straight down the hole misses
    assert np.isinf(shapes.intersect("torus", np.array([[0.0, 0, 3]]), np.array([[0, 0, -1.0]]), (1.0, 0.25)))[0]
    # box seen from inside (a room): exit through the wall
    np.testing.assert_allclose(shapes.intersect("box", np.array([[0.0, 0, 0]]), np.array([[0, 1.0, 0]]), (4, 3, 2)), [3.0])
    # cone frustum r0 = 0.4 at z = -0.35 .. r1 = 0.1 at z = +0.35; horizontal ray at z = 0 hits r = 0.25
    np.testing.assert_allclose(shapes.intersect("cone", np.array([[-2.0, 0, 0]]), np.array([[1.0, 0, 0]]), PARAMS["cone"]), [1.75])
    # ray parallel to a cylinder's axis hits its cap
    np.testing.assert_allclose(shapes.intersect("cylinder", np.array([[0.1, 0, 5]]), np.array([[0, 0, -1.0]]), (0.3, 0.5)), [4.5])
    # rect and disc in z = 0
    np.testing.assert_allclose(shapes.intersect("rect", np.array([[0.2, 0.1, 2]]), np.array([[0, 0, -1.0]]), (1, 1)), [2.0])
    assert np.isinf(shapes.intersect("disc", np.array([[2.0, 0, 2]]), np.array([[0, 0, -1.0]]), (1.0,)))[0]


def _sphere_scene(radius=0.5, centre=(0.0, 0.0, 0.0)):
    enclosure = (Prim("ellipsoid", (20.0, 20.0, 20.0), FLAT),)
    ball = ObjectSpec(1, "ball", "sphere", (Prim("ellipsoid", (radius,) * 3, FLAT, centre),), target=True)
    return SceneSpec("unit", "test", enclosure, (ball,))


def _view(eye, target, w=33, h=25, name="v.png"):
    R, t = look_at(np.asarray(eye, float), np.asarray(target, float), up=(0.0, 0.0, 1.0))
    return View.at(name, R, t, intrinsics(w, h), w, h)


def test_render_sphere_depth_closed_form():
    """Camera at distance D looking at a sphere of radius r: centre pixel z-depth D - r, id 1; background id 0."""
    spec = _sphere_scene(0.5)
    view = _view((3.0, 0.0, 0.0), (0.0, 0.0, 0.0))  # odd size: pixel (12, 16) centre is the principal point
    r = render(World(spec), view, supersample=3)
    assert r.depth[12, 16] == pytest.approx(2.5, rel=1e-12)
    assert r.instance[12, 16] == 1 and r.instance[0, 0] == 0
    # a pixel off-centre: depth along the optical axis from the analytic ray-sphere root
    i, j = 12, 19
    d = view.rays(np.array([j + 0.5]), np.array([i + 0.5]))[0]
    C = view.center
    a, b, c = d @ d, 2 * C @ d, C @ C - 0.25
    assert r.depth[i, j] == pytest.approx((-b - np.sqrt(b * b - 4 * a * c)) / (2 * a), rel=1e-12)
    # hidden object: the ray reaches the enclosure (radius 20): depth 20 + 3 at the centre
    r2 = render(World(spec, hidden={1}), view, supersample=1)
    assert r2.depth[12, 16] == pytest.approx(23.0, rel=1e-12)
    assert (r2.instance == 0).all()
    # hit points project back to their pixel centres and have camera z = depth
    uv, z = view.project(r.points.reshape(-1, 3))
    jj, ii = np.meshgrid(np.arange(33), np.arange(25))
    np.testing.assert_allclose(uv[:, 0], jj.ravel() + 0.5, atol=1e-9)
    np.testing.assert_allclose(uv[:, 1], ii.ravel() + 0.5, atol=1e-9)
    np.testing.assert_allclose(z, r.depth.ravel(), rtol=1e-12)


def test_view_matches_project_camera_convention():
    """A View is an inpaint360gs Camera: same pose, and u = fx x/z + cx with pixel centres at +0.5."""
    v = _view((1.0, -2.0, 1.5), (0.1, 0.2, 0.3), w=64, h=48)
    cam = v.camera
    assert cam.R.dtype == torch.float64 and cam.name == "v.png"
    np.testing.assert_allclose(cam.center.numpy(), v.center, atol=1e-12)
    ref = Camera.look_at((1.0, -2.0, 1.5), (0.1, 0.2, 0.3), (0.0, 0.0, 1.0), cam.fx, cam.fy, cam.cx, cam.cy, 64, 48)
    np.testing.assert_allclose(ref.R.numpy(), v.R, atol=1e-6)  # the core look_at, in float32
    np.testing.assert_allclose(View(ref).t, v.t, atol=1e-6)  # any dtype reads back as float64
    x = np.array([[0.1, 0.2, 0.3], [0.5, -0.2, 0.1]])
    xc = x @ cam.R.numpy().T + cam.t.numpy()
    uv, z = v.project(x)
    np.testing.assert_allclose(uv[:, 0], cam.fx * xc[:, 0] / xc[:, 2] + cam.cx)
    np.testing.assert_allclose(uv[:, 1], cam.fy * xc[:, 1] / xc[:, 2] + cam.cy)
    np.testing.assert_allclose(uv[0], [32.0, 24.0], atol=1e-9)  # the look-at target projects to the image centre
    # up is up: a point above the target appears higher in the image (smaller v)
    assert v.project(np.array([[0.1, 0.2, 0.8]]))[0][0, 1] < 24.0


def test_euler_matrix_is_rotation():
    R = euler_matrix((10.0, -35.0, 120.0))
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-15)
    assert np.linalg.det(R) == pytest.approx(1.0)


def test_noise_properties():
    rng = np.random.default_rng(0)
    p = rng.uniform(-50, 50, size=(20000, 3))
    v = value_noise(p, 3)
    assert v.min() >= 0.0 and v.max() <= 1.0 and 0.4 < v.mean() < 0.6
    # value noise interpolates the lattice hash at integer points
    q = np.array([[3.0, -7.0, 11.0]])
    assert value_noise(q, 5)[0] == pytest.approx(lattice_hash(3, -7, 11, 5), abs=1e-15)
    # deterministic, seed-dependent, and fully faded to the mean for footprints >> every period
    a = fbm(p, np.zeros(len(p)), 1)
    np.testing.assert_array_equal(a, fbm(p, np.zeros(len(p)), 1))
    assert not np.allclose(a, fbm(p, np.zeros(len(p)), 2))
    np.testing.assert_allclose(fbm(p, np.full(len(p), 10.0), 1), 0.5, atol=1e-15)
    # continuity: nearby points have nearby values
    assert np.abs(fbm(p + 1e-6, np.zeros(len(p)), 1) - a).max() < 1e-3


def test_box_filtered_square_wave_is_exact_average():
    rng = np.random.default_rng(0)
    x = rng.uniform(-3, 3, 50)
    w = rng.uniform(0.01, 2.5, 50)
    for duty in (0.3, 0.5, 0.94):
        ref = []
        for xi, wi in zip(x, w):
            s = np.linspace(xi - wi / 2, xi + wi / 2, 200001)
            ref.append(np.mean((s - np.floor(s)) < duty))
        np.testing.assert_allclose(box_square(x, duty, w), ref, atol=2e-4)


@pytest.mark.parametrize("kind", ["noise", "patches", "checker", "stripes", "wood", "planks", "tiles", "sky", "weave", "grain"])
def test_textures_in_range_and_band_limited(kind):
    m = Material(kind, ((0.9, 0.2, 0.1), (0.1, 0.3, 0.9), (0.8, 0.8, 0.2), (0.2, 0.6, 0.2), (0.3, 0.3, 0.3)), scale=0.1)
    rng = np.random.default_rng(0)
    p = rng.uniform(-1, 1, size=(4000, 3)) + np.array([0, 0, 2.0])  # sky needs a direction off the origin
    sharp = albedo(m, p, np.zeros(len(p)), 0)
    assert sharp.min() >= 0 and sharp.max() <= 1
    assert sharp.std(axis=0).max() > 0.02  # textured, not flat
    # a footprint far above the pattern scale removes most of the variation (filtered to the mean)
    blurred = albedo(m, p, np.full(len(p), 100.0), 0)
    if kind != "sky":  # the sky keeps its large-scale gradient/tree line by design
        assert blurred.std(axis=0).max() < 0.35 * sharp.std(axis=0).max()
    np.testing.assert_array_equal(sharp, albedo(m, p, np.zeros(len(p)), 0))


def test_dots_cover_planes_through_the_origin():
    """Spots show on axis planes at 0 (floors, walls) with roughly the expected coverage, and fade when far."""
    base = Material("noise", ((0.3, 0.5, 0.2), (0.3, 0.5, 0.2)), scale=0.3, detail=0.0)
    dotted = Material("noise", base.colors, scale=0.3, detail=0.0, dots=0.5, dot_size=0.4, dot_colors=((1.0, 1.0, 1.0),))
    rng = np.random.default_rng(0)
    for axis in range(3):
        p = rng.uniform(-3, 3, size=(40000, 3))
        p[:, axis] = 0.0
        a = albedo(base, p, np.zeros(len(p)), 0)
        b = albedo(dotted, p, np.zeros(len(p)), 0)
        covered = np.abs(b - a).max(axis=1) > 1e-9
        # sphere radii 0.08..0.25 cells, present in half the cells, cut by a plane at a random height
        assert 0.01 < covered.mean() < 0.2
        far = albedo(dotted, p, np.full(len(p), 1.0), 0)
        np.testing.assert_allclose(far, albedo(base, p, np.full(len(p), 1.0), 0))
