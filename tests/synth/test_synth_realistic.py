"""The realistic scene family (dataset_tools/synth/realistic.py): its layouts against the generator's
truth (dark undersides, seams under the object), the dev/test suites, the unseen share, its photo
records and its poses from pycolmap."""

from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
import pytest

from dataset_tools.synth import SCENES, build_scene, generate_scene, load_scene
from dataset_tools.synth.catalogue import BENCHMARK_SCENES, LOW_UNSEEN_SHARE, suite_scenes
from dataset_tools.synth.photo import develop
from dataset_tools.synth.raycast import World
from dataset_tools.synth.realistic import LAYOUT_SEEDS, LAYOUT_SPARSE, LAYOUTS, LOOKED_AT, MAT_T, SEEDS, SPARSE, SPARSE_VIEWS
from dataset_tools.synth.render import render
from dataset_tools.synth.spec import SceneSpec
from dataset_tools.synth.textures import albedo
from dataset_tools.synth.visibility import MIN_UNSEEN_SHARE, estimate_unseen_shares, unseen_shares
from inpaint360gs.core.errors import InputError

REALISTIC = sorted(n for n, s in SCENES.items() if s.family == "realistic")


def test_culled_casting_finds_the_same_hits():
    """The realistic scenes cull object primitives by bounding sphere (raycast.World.cast): same hits
    as testing every primitive, for camera rays and for short occlusion rays alike."""
    w = World(SCENES["dozer-dev1"])
    rng = np.random.default_rng(0)
    o = np.array([0.7, -0.3, 0.4]) + rng.normal(0.0, 0.05, (20000, 3))
    d = rng.normal(0.0, 0.1, (20000, 3)) - o  # towards the object, scattered
    t0, i0 = w.cast(o, d, cull=False)
    t1, i1 = w.cast(o, d, cull=True)
    assert (i0 != -1).sum() > 10000 and (w.obj_ids[i0] != 0).sum() > 2000
    np.testing.assert_array_equal(i0, i1)
    np.testing.assert_allclose(t0, t1, rtol=1e-12)
    o2 = np.c_[rng.uniform(-0.3, 0.3, (20000, 2)), np.full(20000, MAT_T + 1e-5)]
    d2 = rng.normal(0.0, 1.0, (20000, 3))
    d2[:, 2] = np.abs(d2[:, 2])
    d2 /= np.linalg.norm(d2, axis=1, keepdims=True)
    for background in (True, False):
        a = w.cast(o2, d2, tmax=0.2, background=background, cull=False)
        b = w.cast(o2, d2, tmax=0.2, background=background, cull=True)
        np.testing.assert_array_equal(a[1], b[1])
        np.testing.assert_allclose(a[0], b[0], rtol=1e-12)


def test_dozer_has_a_dark_underside_a_few_millimetres_above_the_support():
    spec = SCENES["dozer-dev1"]
    w = World(spec)
    obj = spec.objects[0]
    # rays straight up from the mat under the chassis: its centre and 3 cm to the side
    up = np.array([[0.0, 0.0, 1.0]])
    for local, lo, hi in (((0.0, 0.0), 0.005, 0.007), ((0.0, 0.03), 0.005, 0.007)):
        a = np.radians(obj.yaw)
        x = obj.position[0] + np.cos(a) * local[0] - np.sin(a) * local[1]
        y = obj.position[1] + np.sin(a) * local[0] + np.cos(a) * local[1]
        t, idx = w.cast(np.array([[x, y, MAT_T]]), up)
        assert lo < t[0] < hi and w.obj_ids[idx[0]] == obj.id  # the chassis, 6 mm above the mat
        prim = w.prims[idx[0]].prim
        hit = np.array([[0.0, 0.0, -prim.params[2]]])  # its underside, local frame
        assert albedo(prim.material, hit, np.zeros(1), 0).max() < 0.15  # dark


def test_two_mats_meet_in_a_straight_seam_under_the_object_in_the_object_free_views():
    for name in ("dozer-dev1", "dozer-dev2"):
        sc = build_scene(name, width=64, height=48)
        mats = [k for k, p in enumerate(sc.world_free.prims) if p.prim.material.kind == "weave"]
        assert len(mats) == 2
        crossing = 0
        for v in sc.test_views:
            jj, ii = np.meshgrid(np.arange(64) + 0.5, np.arange(48) + 0.5)
            _, idx = sc.world_free.cast(v.center, v.rays(jj.ravel(), ii.ravel()))
            lab = idx.reshape(48, 64)
            a, b = lab == mats[0], lab == mats[1]
            # pixels of mat A with a mat-B neighbour: the seam, a straight line in the image
            nb = np.zeros_like(b)
            nb[1:] |= b[:-1]
            nb[:-1] |= b[1:]
            nb[:, 1:] |= b[:, :-1]
            nb[:, :-1] |= b[:, 1:]
            seam = np.argwhere(a & nb).astype(float)
            if len(seam) < 6:
                continue
            c = seam - seam.mean(0)
            _, s, vt = np.linalg.svd(c, full_matrices=False)
            residual = np.abs(c @ vt[1])
            assert residual.max() < 1.5, (name, v.name, residual.max())
            # it runs under the object: seam pixels inside the object's silhouette in the same view
            inst = render(sc.world_full, v, supersample=1).instance
            crossing += int(np.any(inst[seam[:, 0].astype(int), seam[:, 1].astype(int)] == 1))
        assert crossing >= len(sc.test_views) // 2, (name, crossing)


# ----------------------------------------------------------------------------------------------
# the family: layouts, suites, defaults


def _layout(spec: SceneSpec):
    """What a layout seed decides: the background (supports and their materials) and the objects' poses and materials."""
    return (spec.background, tuple((o.position, o.yaw, o.prims) for o in spec.objects))


def test_suites_split_the_catalogue():
    dev, test = set(suite_scenes("dev")), set(suite_scenes("test"))
    assert not dev & test and dev | test == set(SCENES)
    assert set(BENCHMARK_SCENES) <= dev and all(SCENES[n].family == "realistic" for n in test)
    for layout in LAYOUTS:
        for suite in ("dev", "test"):
            names = [n for n in suite_scenes(suite) if n.startswith(layout + "-")]
            if layout in LAYOUT_SEEDS:  # a layout with its own seeds (the plain-backdrop one: one scene per suite, no sparse variant)
                assert sum(not n.endswith("-sparse") for n in names) >= 1
                continue
            assert sum(not n.endswith("-sparse") for n in names) >= 2 and sum(n.endswith("-sparse") for n in names) >= 1
    with pytest.raises(InputError, match="unknown suite"):
        suite_scenes("train")
    # the sealed test suite: at least 12 scenes, none of the test stream's layouts that were looked at
    assert len(test) >= 12 and not {n for n in test if int(n.split("-")[1].removeprefix("test")) in LOOKED_AT["test"]}
    assert {"dozer-test1", "teapot-test2", "duck-test1-sparse", "plush-dev1"} <= dev and "plush-test3" in test
    assert not any(n.startswith("plush-") and n.endswith("-sparse") for n in SCENES) and LAYOUT_SPARSE["plush"] != SPARSE


def test_plush_is_a_large_object_on_a_plain_sheet():
    """The plain-backdrop layout: the toy fills much of the frame (larger orbit fill than the other
    layouts) and stands on a sheet whose albedo barely varies (what gives SfM few points there)."""
    spec, dozer = SCENES["plush-dev1"], SCENES["dozer-dev1"]
    assert spec.orbit.fill > dozer.orbit.fill and spec.objects[0].target
    sheet = [p for p in spec.background if p.shape == "box" and p.params[2] < 0.01]
    assert len(sheet) == 1
    rng = np.random.default_rng(0)
    pts = np.c_[rng.uniform(-0.3, 0.3, (4000, 2)), np.full(4000, MAT_T)]
    sheet_std = albedo(sheet[0].material, pts, np.full(4000, 1e-3), 0).std(axis=0).max()
    mats = [p for p in dozer.background if p.material.kind == "weave"]
    mat_std = min(albedo(m.material, pts[:, :] * [0.5, 0.5, 1.0], np.full(4000, 1e-3), 0).std(axis=0).max() for m in mats)
    assert sheet_std < 0.05 and sheet_std < 0.2 * mat_std, (sheet_std, mat_std)


def test_layouts_vary_with_the_seed_and_test_layouts_are_not_dev_layouts():
    for layout in LAYOUTS:
        names = [n for n in REALISTIC if n.startswith(layout + "-") and not n.endswith("-sparse")]
        layouts = [_layout(SCENES[n]) for n in names]
        assert len(names) == sum(len(k) for k in LAYOUT_SEEDS.get(layout, SEEDS).values()) >= 2
        for i in range(len(layouts)):
            for j in range(i + 1, len(layouts)):
                assert layouts[i][0] != layouts[j][0], (names[i], names[j])
                assert {o.yaw for o in SCENES[names[i]].objects}.isdisjoint(o.yaw for o in SCENES[names[j]].objects)
    for n in REALISTIC:
        s = SCENES[n]
        stream, k = n.split("-")[1].rstrip("0123456789"), int("".join(c for c in n.split("-")[1] if c.isdigit()))
        assert s.poses == "colmap" and s.light.ao > 0 and s.photo.active
        assert s.suite == ("dev" if stream == "dev" or k in LOOKED_AT.get(stream, ()) else "test"), n
        if n.endswith("-sparse"):  # the same layout as its dense sibling, ~25 photos
            dense = SCENES[n.removesuffix("-sparse")]
            assert _layout(s) == _layout(dense) and s.n_views == SPARSE_VIEWS and dense.n_views == 56


@pytest.mark.slow
def test_every_realistic_scene_has_a_meaningful_unseen_region_and_the_low_list_is_right():
    for n in REALISTIC:
        shares = estimate_unseen_shares(build_scene(n))
        assert np.mean(list(shares.values())) >= MIN_UNSEEN_SHARE, n
    low = [n for n in BENCHMARK_SCENES if np.mean(list(estimate_unseen_shares(build_scene(n)).values())) < MIN_UNSEEN_SHARE]
    assert tuple(low) == LOW_UNSEEN_SHARE


# ----------------------------------------------------------------------------------------------
# a generated realistic scene (true poses: fast)


@pytest.fixture(scope="module")
def duck(tmp_path_factory) -> Path:
    return generate_scene("duck-dev1", tmp_path_factory.mktemp("real"), reduced=True, width=48, height=36, poses="generator")


def test_generated_scene_records_its_photo_effects(duck):
    meta = json.loads((duck / "scene.json").read_text())
    assert meta["provenance"]["family"] == "realistic" and meta["provenance"]["suite"] == "dev"
    images = sorted(p.name for p in (duck / "images").iterdir())
    record = json.loads((duck / "gt" / "photometric.json").read_text())["images"]
    assert sorted(record) == images and record["IMG_0000.png"]["jpeg_quality"] == 90
    assert len({r["gain"] for r in record.values()}) == len(images)  # every photo its own exposure
    sc = load_scene(duck)
    for name in ("test_0000.png", "test_0003.png"):
        clean = cv2.imread(str(duck / "gt" / "clean" / name))[..., ::-1]
        photo = cv2.imread(str(duck / "images" / name))[..., ::-1]
        r = render(sc.world_free, next(v for v in sc.test_views if v.name == name))
        np.testing.assert_array_equal(clean, r.rgb8())  # gt/clean: the capture without photo effects
        expected, _ = develop(r.rgb, sc.spec.photo, sc.seed, name)
        np.testing.assert_array_equal(photo, expected)
        assert np.abs(photo.astype(int) - clean).mean() > 1.0


def test_unseen_share_function_and_its_estimate(duck):
    shares = unseen_shares(duck)
    assert sorted(shares) == [f"test_{k:04d}" for k in range(8)]
    # at the scene's own size the estimate applies the masks' rule to the same pixel centres
    assert estimate_unseen_shares(load_scene(duck), 48, 36) == shares
    with pytest.raises(InputError, match="unseen_mask"):
        unseen_shares(duck / "gt")


@pytest.mark.slow
def test_default_poses_come_from_pycolmap(tmp_path):
    """The family's default: every image registered by joint SfM, gt/ kept, the similarity recorded."""
    d = generate_scene("duck-dev2", tmp_path, reduced=True, width=256, height=192)
    meta = json.loads((d / "scene.json").read_text())
    assert meta["provenance"]["poses"] == "colmap" and "created_utc" not in meta["provenance"]["build"]
    report = json.loads((d / "build_report.json").read_text())
    assert report["registration"]["registered"] == report["registration"]["total"] == 40 and "timings" not in report
    acc = json.loads((d / "gt" / "colmap_frame.json").read_text())["pose_accuracy"]
    assert acc["center_err_max_pct"] < 3.0 and acc["rot_err_max_deg"] < 1.0
    assert (d / "gt" / "photometric.json").is_file() and len(list((d / "gt" / "clean").iterdir())) == 8
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temporaries left
