"""Real-photo effects of the synthetic generator, each against its closed form, and that the classic
scenes, which have them all off, are what they were, within the rounding that differs between CPUs (their tables depend on them)."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from dataset_tools.synth import SCENES, generate_scene
from dataset_tools.synth.cameras import View, intrinsics, look_at
from dataset_tools.synth.occlusion import occlusion
from dataset_tools.synth.photo import develop, draw, jpeg_round_trip
from dataset_tools.synth.raycast import World
from dataset_tools.synth.render import render
from dataset_tools.synth.spec import Light, ObjectSpec, Photo, Prim, SceneSpec
from dataset_tools.synth.textures import Material, albedo

FLAT = Material("noise", ((0.5, 0.5, 0.5), (0.5, 0.5, 0.5)), detail=0.0)


def _world(obj_prims, *, ao=1.0, radius=0.05, samples=64, hidden=frozenset()) -> World:
    """A flat grey floor (z = 0) and one object made of ``obj_prims``."""
    spec = SceneSpec("t", "t", (Prim("rect", (5.0, 5.0), FLAT),), (ObjectSpec(1, "o", "box", tuple(obj_prims), target=True),),
                     light=Light(ao=ao, ao_radius=radius, ao_samples=samples), family="realistic")
    return World(spec, hidden)


def _floor_occlusion(world: World, xy: np.ndarray) -> np.ndarray:
    p = np.c_[xy, np.zeros(len(xy))]
    return occlusion(world, p, np.tile([0.0, 0.0, 1.0], (len(p), 1)), np.zeros(len(p), dtype=np.int64))


# ----------------------------------------------------------------------------------------------
# the classic scenes are untouched


# The classic scenes as the generator made them before the realistic family existed, kept as a
# small reference (tests/synth/data/classic_reference.npz, written by `python -m
# tests.synth.test_synth_effects`): each image and depth map averaged over 4x4 blocks, every
# instance and unseen mask whole, the cameras. Compared within tolerances, not by bytes: the ray caster's float
# rounding differs between CPUs (vector instruction sets), which moves a few pixels by a grey level
# and a few edge pixels between objects, while any change of the scenes themselves (an effect left
# on, a moved object, another colour) moves far more.
CLASSIC_REFERENCE = Path(__file__).parent / "data" / "classic_reference.npz"
CLASSIC_NAMES = ("cone", "toys")


def _block_mean(a: np.ndarray, k: int = 4) -> np.ndarray:
    h, w = a.shape[0] // k * k, a.shape[1] // k * k
    a = a[:h, :w].astype(np.float64)
    return a.reshape(h // k, k, w // k, k, *a.shape[2:]).mean(axis=(1, 3))


def classic_summary(d: Path) -> dict[str, np.ndarray]:
    """What the reference keeps of a generated classic scene (see above)."""
    out: dict[str, np.ndarray] = {}
    for p in sorted((d / "images").iterdir()):
        out[f"images/{p.name}"] = _block_mean(cv2.imread(str(p), cv2.IMREAD_UNCHANGED)).astype(np.float32)
    for p in sorted((d / "gt" / "depth").iterdir()):
        out[f"depth/{p.name}"] = _block_mean(np.load(p)).astype(np.float32)
    for sub in ("unseen_mask", "gt/instance"):
        for p in sorted((d / sub).iterdir()):
            out[f"{sub}/{p.name}"] = cv2.imread(str(p), cv2.IMREAD_UNCHANGED)
    cams = json.loads((d / "gt" / "cameras.json").read_text())
    out["cameras"] = np.array([cams["fx"], cams["fy"], cams["cx"], cams["cy"]], np.float64)
    out["camera_poses"] = np.array([[*sum(c["R"], []), *c["t"]] for c in cams["images"]])
    return out


def _generate_classic(name: str, where: Path) -> Path:
    return generate_scene(name, where, reduced=True, width=64, height=48, seed=0)


@pytest.mark.slow
@pytest.mark.parametrize("name", CLASSIC_NAMES)
def test_classic_scene_files_are_what_they_were_before_the_family(tmp_path, name):
    d = _generate_classic(name, tmp_path)
    ref = np.load(CLASSIC_REFERENCE)
    got = classic_summary(d)
    keys = sorted(k for k in ref.files if k.startswith(f"{name}:"))
    assert sorted(f"{name}:{k}" for k in got) == keys  # the same files
    for key in keys:
        a, b = got[key.split(":", 1)[1]], ref[key]
        assert a.shape == b.shape, key
        kind = key.split(":", 1)[1].split("/")[0]
        if kind in ("images", "depth"):  # 4x4 block means: 99 % of blocks agree; an edge pixel may flip
            off = np.abs(a - b) > (0.5 if kind == "images" else 1e-4 * np.abs(b).max())
            assert off.mean() <= 0.01, key
        elif kind in ("cameras", "camera_poses"):
            np.testing.assert_allclose(a, b, rtol=1e-6, atol=1e-9, err_msg=key)
        else:  # masks: the same labels, a few edge pixels may change hands
            assert set(np.unique(a)) == set(np.unique(b)), key
            assert (a != b).mean() <= 0.01, key
    assert not (d / "gt" / "photometric.json").exists() and not (d / "gt" / "clean").exists()
    assert set(json.loads((d / "scene.json").read_text())["provenance"]) == {"generator", "version", "seed", "width", "height", "reduced"}


def test_classic_scenes_have_every_effect_off():
    classic = [n for n, s in SCENES.items() if s.family == "classic"]
    assert len(classic) == 10
    for n in classic:
        s = SCENES[n]
        assert s.family == "classic" and s.suite == "dev" and s.poses == "generator"
        assert s.light.ao == 0.0 and not s.photo.active and s.orbit.frame == ()
        assert not any(p.material.kind in ("weave", "grain") for p in s.background)


# ----------------------------------------------------------------------------------------------
# ambient occlusion


@pytest.mark.parametrize("h", [0.005, 0.01, 0.02, 0.04])
def test_occlusion_under_a_wide_overhang_is_the_closed_form(h):
    """Under a plane at height h: the cosine-weighted mean of max(0, 1 - h / (R cos theta)) = (1 - h/R)^2."""
    w = _world([Prim("box", (1.0, 1.0, 0.001), FLAT, (0.0, 0.0, h + 0.001))], radius=0.05)
    occ = _floor_occlusion(w, np.random.default_rng(0).uniform(-0.1, 0.1, (500, 2)))
    np.testing.assert_allclose(occ, (1.0 - h / 0.05) ** 2, atol=0.005)


def test_occlusion_at_the_foot_of_a_wall_is_one_half_and_zero_beyond_the_radius():
    w = _world([Prim("box", (1.0, 1.0, 1.0), FLAT, (1.0 + 1e-4, 0.0, 0.999))], radius=0.05)
    ys = np.random.default_rng(1).uniform(-0.3, 0.3, 2000)
    foot = _floor_occlusion(w, np.c_[np.zeros(2000), ys])
    assert abs(foot.mean() - 0.5) < 0.02  # half the hemisphere is wall at distance -> 0
    mid = _floor_occlusion(w, np.c_[np.full(2000, -0.02), ys])
    assert 0.05 < mid.mean() < foot.mean() - 0.2  # falls off with the distance...
    assert np.all(_floor_occlusion(w, np.c_[np.full(200, -0.0501), ys[:200]]) == 0.0)  # ...to 0 at R


def test_ao_darkens_the_support_next_to_the_object_and_not_in_the_object_free_capture():
    box = [Prim("box", (0.05, 0.05, 0.05), FLAT, (0.0, 0.0, 0.048))]
    R, t = look_at(np.array([0.45, 0.0, 0.35]), np.zeros(3))
    view = View.at("v.png", R, t, intrinsics(96, 72), 96, 72)
    on = render(_world(box, ao=0.8, radius=0.1, samples=8), view)
    off = render(_world(box, ao=0.0), view)
    free = render(_world(box, ao=0.8, radius=0.1, samples=8, hidden={1}), view)
    floor = (on.instance == 0) & (np.abs(on.points[..., 2]) < 1e-9)
    floor = cv2.erode(floor.astype(np.uint8), np.ones((3, 3), np.uint8)).astype(bool)  # no pixel straddling the outline
    d = np.maximum(np.abs(on.points[..., :2]).max(-1) - 0.05, 0.0)  # distance to the box's footprint (square)
    near, far = floor & (d < 0.02), floor & (d > 0.15)
    assert near.sum() > 20 and far.sum() > 200
    # AO off: the flat floor has one colour everywhere (no contact shading in the classic model)
    assert np.ptp(off.rgb[floor], axis=0).max() < 1e-12
    # AO on: next to the object it is darker by a measurable amount; far from it unchanged
    assert on.rgb[near].mean() < 0.9 * on.rgb[far].mean()  # 0.85 measured: occlusion ~0.2 within 2 cm
    np.testing.assert_array_equal(on.rgb[far], off.rgb[far])
    # the object-free capture has the floor without the removed object's darkening
    free_floor = (free.instance == 0) & (np.abs(free.points[..., 2]) < 1e-9)
    np.testing.assert_allclose(free.rgb[free_floor], np.broadcast_to(off.rgb[far][0], (free_floor.sum(), 3)), rtol=0, atol=1e-12)


# ----------------------------------------------------------------------------------------------
# photo effects


def _radiance(seed=0, shape=(48, 64)) -> np.ndarray:
    return np.random.default_rng(seed).uniform(0.1, 0.6, (*shape, 3))


def test_effects_off_is_plain_quantisation():
    rgb = _radiance()
    img, dev = develop(rgb, Photo(), 0, "IMG_0000.png")
    np.testing.assert_array_equal(img, np.round(rgb * 255.0).astype(np.uint8))
    assert dev.gain == 1.0 and dev.white_balance == (1.0, 1.0, 1.0) and not Photo().active


def test_exposure_and_white_balance_scale_each_photo_by_its_drawn_gains():
    rgb = _radiance()
    photo = Photo(exposure=0.3, white_balance=0.05)
    a, da = develop(rgb, photo, 3, "IMG_0001.png")
    b, db = develop(rgb, photo, 3, "IMG_0002.png")
    for img, d in ((a, da), (b, db)):
        gains = d.gain * np.asarray(d.white_balance)
        np.testing.assert_array_equal(img, np.round(np.clip(rgb * gains, 0, 1) * 255.0).astype(np.uint8))
        assert d.white_balance[1] == 1.0
    # two photos of the same radiance differ by the ratio of their gains (up to 8-bit rounding)
    ratio = (da.gain * np.asarray(da.white_balance)) / (db.gain * np.asarray(db.white_balance))
    ratio = np.broadcast_to(ratio, a.shape)
    ok = (a < 255) & (b < 255)  # not clipped: each is within half a level of radiance x gains x 255
    assert ok.mean() > 0.9 and np.all(np.abs(a - ratio * b)[ok] <= 0.5 + 0.5 * ratio[ok] + 1e-9)
    assert abs(np.log2(da.gain / db.gain)) > 1e-3
    # over many photos the gains spread as set: std of log2(gain) = exposure, of log(wb) = white_balance
    ds = [draw(photo, 3, f"IMG_{k:04d}.png") for k in range(600)]
    assert abs(np.std([np.log2(d.gain) for d in ds]) - 0.3) < 0.03
    assert abs(np.std([np.log(d.white_balance[0]) for d in ds]) - 0.05) < 0.005
    assert draw(photo, 3, "IMG_0001.png") == da and draw(photo, 4, "IMG_0001.png") != da  # seeded per name


@pytest.mark.parametrize("noise, shot, level", [(0.02, 0.0, 0.5), (0.0, 0.001, 0.25), (0.0, 0.001, 0.64), (0.01, 0.0004, 0.4)])
def test_noise_standard_deviation_matches_the_setting(noise, shot, level):
    rgb = np.full((160, 160, 3), level)
    img, _ = develop(rgb, Photo(noise=noise, shot_noise=shot), 0, "IMG_0000.png")
    err = img / 255.0 - level
    expected = np.sqrt(noise**2 + shot * level + (1.0 / 255.0) ** 2 / 12.0)  # + 8-bit rounding
    assert abs(err.std() / expected - 1.0) < 0.03
    assert abs(err.mean()) < 0.002


def test_jpeg_writes_lossy_images():
    x = cv2.resize(_radiance(1, (12, 16)), (64, 48), interpolation=cv2.INTER_CUBIC).clip(0, 1)
    plain = np.round(x * 255.0).astype(np.uint8)
    q90, _ = develop(x, Photo(jpeg_quality=90), 0, "IMG_0000.png")
    np.testing.assert_array_equal(q90, jpeg_round_trip(plain, 90))
    err = {q: np.abs(develop(x, Photo(jpeg_quality=q), 0, "a.png")[0].astype(int) - plain).mean() for q in (30, 90)}
    assert 0 < err[90] < err[30]
    # the decoded image is what libjpeg gives back for it: encoding it again at the same quality changes little
    assert np.abs(jpeg_round_trip(q90, 90).astype(int) - q90).mean() < err[90]


# ----------------------------------------------------------------------------------------------
# supports: woven mats, two mats meeting under the object, wood grain


def test_weave_hem_and_stripes():
    colors = ((0.8, 0.8, 0.8), (0.6, 0.5, 0.4), (0.1, 0.1, 0.5), (0.9, 0.1, 0.1))
    m = Material("weave", colors, scale=0.008, detail=0.0, extent=(0.2, 0.15), border=0.012, bands=((0.05, 0.01),))
    rng = np.random.default_rng(0)
    p = np.c_[rng.uniform(-0.2, 0.2, 20000), rng.uniform(-0.15, 0.15, 20000), np.zeros(20000)]
    a = albedo(m, p, np.zeros(len(p)), 0)
    edge = np.minimum(0.2 - np.abs(p[:, 0]), 0.15 - np.abs(p[:, 1]))
    hem = edge < 0.011
    assert np.all(a[hem, 0] > 0.7) and np.all(a[hem, 2] < 0.2)  # the red hem all round
    inside = edge > 0.013
    assert np.all(a[inside, 0] < 0.7 * a[inside, 1] + 0.5)
    band = inside & (np.abs(p[:, 1] - 0.05) < 0.009)
    other = inside & (np.abs(p[:, 1] - 0.05) > 0.011)
    assert a[band, 2].mean() > a[band, 0].mean() and a[other, 2].mean() < a[other, 0].mean()  # blue stripe
    # the weave: warp on top in a checker of thread cells (plain weave), blurred away far off
    u, v = np.floor(p[:, 0] / 0.008), np.floor(p[:, 1] / 0.008)
    warp_top = (u + v) % 2 == 0
    centre = other & (np.abs(p[:, 0] / 0.008 - u - 0.5) < 0.2) & (np.abs(p[:, 1] / 0.008 - v - 0.5) < 0.2)
    assert a[centre & warp_top, 0].mean() > a[centre & ~warp_top, 0].mean() + 0.1
    calm = inside & (edge > 0.05) & (np.abs(p[:, 1] - 0.05) > 0.05)  # away from hem and stripe
    far = albedo(m, p[calm], np.full(calm.sum(), 0.05), 0)
    assert far.std(axis=0).max() < 0.1 * a[calm].std(axis=0).max()


if __name__ == "__main__":  # rewrite the classic scenes' reference (only when they are meant to change)
    import tempfile

    arrays = {}
    with tempfile.TemporaryDirectory() as tmp:
        for n in CLASSIC_NAMES:
            arrays.update({f"{n}:{k}": v for k, v in classic_summary(_generate_classic(n, Path(tmp))).items()})
    np.savez_compressed(CLASSIC_REFERENCE, **arrays)
    print(f"wrote {CLASSIC_REFERENCE} ({len(arrays)} arrays)")
