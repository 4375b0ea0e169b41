"""Ground-truth consistency of a generated synthetic scene (small reduced ``toys``: 3 objects, 2 removed)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pycolmap
import pytest
from PIL import Image

from inpaint360gs.core.layout import assign_splits

from dataset_tools.synth import (
    SCENES,
    build_scene,
    generate_scene,
    load_scene,
    render_view,
    scene_spec,
    seen_by_object_inclusive_views,
)
from dataset_tools.synth.cameras import View, orbit_geometry
from dataset_tools.synth.raycast import World
from dataset_tools.synth.render import render
from dataset_tools.synth.scene import REDUCED_VIEWS
from dataset_tools.synth.visibility import seen_by_views
from inpaint360gs.core.errors import InputError

W, H = 96, 72


@pytest.fixture(scope="module")
def toys(tmp_path_factory) -> Path:
    return generate_scene("toys", tmp_path_factory.mktemp("synth"), reduced=True, width=W, height=H, seed=3)


def _cams(scene: Path) -> tuple[dict, list[View]]:
    cj = json.loads((scene / "gt" / "cameras.json").read_text())
    K = (cj["fx"], cj["fy"], cj["cx"], cj["cy"])
    views = [View.at(c["name"], c["R"], c["t"], K, cj["width"], cj["height"], c["object_free"]) for c in cj["images"]]
    return cj, views


def _depth(scene: Path, v: View) -> np.ndarray:
    return np.load(scene / "gt" / "depth" / f"{v.stem}.npy").astype(np.float64)


def _backproject(v: View, depth: np.ndarray) -> np.ndarray:
    c = v.camera
    jj, ii = np.meshgrid(np.arange(c.width) + 0.5, np.arange(c.height) + 0.5)
    xc = np.stack([(jj - c.cx) / c.fx * depth, (ii - c.cy) / c.fy * depth, depth], -1).reshape(-1, 3)
    return (xc - v.t) @ v.R  # R^T (x_cam - t)


def test_layout_and_metadata(toys):
    meta = json.loads((toys / "scene.json").read_text())
    assert meta["name"] == "toys" and meta["up"] == [0.0, 0.0, 1.0]
    assert meta["removal_targets"] == [1, 2]
    assert [o["id"] for o in meta["objects"]] == [1, 2, 3]
    # one click per target, in a training view, inside the target and away from its outline
    assert [c["object"] for c in meta["clicks"]] == [1, 2]
    splits = assign_splits([p.name for p in (toys / "images").iterdir()])
    for c in meta["clicks"]:
        assert splits[c["view"]] == "train"
        inst = np.array(Image.open(toys / "gt" / "instance" / c["view"]))
        x, y = c["x"], c["y"]
        assert (inst[max(y - 1, 0) : y + 2, max(x - 1, 0) : x + 2] == c["object"]).all()
    assert meta["provenance"] == {"generator": "inpaint360gs-dataset synth", "version": meta["provenance"]["version"],
                                  "seed": 3, "width": W, "height": H, "reduced": True}
    names = sorted(p.name for p in (toys / "images").iterdir())
    n_inc, n_test = REDUCED_VIEWS
    assert names == [f"IMG_{k:04d}.png" for k in range(n_inc)] + [f"test_{k:04d}.png" for k in range(n_test)]
    for n in names:
        stem = n[:-4]
        assert Image.open(toys / "images" / n).size == (W, H)
        assert Image.open(toys / "images" / n).mode == "RGB"
        inst = np.array(Image.open(toys / "gt" / "instance" / n))
        assert inst.dtype == np.uint8 and inst.shape == (H, W)
        d = np.load(toys / "gt" / "depth" / f"{stem}.npy")
        assert d.dtype == np.float32 and d.shape == (H, W) and np.isfinite(d).all() and (d > 0).all()
    masks = sorted(p.name for p in (toys / "unseen_mask").iterdir())
    assert masks == [f"test_{k:04d}.png" for k in range(n_test)]
    objs = json.loads((toys / "gt" / "objects.json").read_text())
    assert [(o["id"], o["removal_target"]) for o in objs] == [(1, True), (2, True), (3, False)]
    assert not list(toys.parent.glob(".*"))  # no temporary folder left behind


def test_orbit_covers_360_with_varying_height(toys):
    _, views = _cams(toys)
    inc = [v for v in views if not v.object_free]
    target, radius = orbit_geometry(scene_spec("toys"), W, H)
    rel = np.array([v.center - target for v in inc])
    az = np.unwrap(np.arctan2(rel[:, 1], rel[:, 0]))
    assert np.all(np.diff(az) > 0) and az[-1] - az[0] > 2 * np.pi * (1 - 2 / len(inc))  # sorted order = orbit order
    el = np.degrees(np.arcsin(rel[:, 2] / np.linalg.norm(rel, axis=1)))
    assert el.min() >= 15.0 - 1e-9 and el.max() <= 45.0 + 1e-9 and el.max() - el.min() > 20.0
    # every capture looks at the objects: the target projects near the image centre
    for v in views:
        uv, z = v.project(target[None])
        assert z[0] > 0 and abs(uv[0, 0] - W / 2) < 0.15 * W and abs(uv[0, 1] - H / 2) < 0.15 * H


def test_sparse_model_reads_back_with_true_poses(toys):
    rec = pycolmap.Reconstruction(str(toys / "sparse" / "0"))
    cj, views = _cams(toys)
    assert rec.num_cameras() == 1
    cam = rec.cameras[1]
    assert cam.model == pycolmap.CameraModelId.PINHOLE and (cam.width, cam.height) == (W, H)
    np.testing.assert_allclose(cam.params, [cj["fx"], cj["fy"], cj["cx"], cj["cy"]])
    by_name = {v.name: v for v in views}
    assert sorted(im.name for im in rec.images.values()) == sorted(by_name)
    assert rec.num_reg_images() == len(views)
    for im in rec.images.values():
        v = by_name[im.name]
        np.testing.assert_allclose(im.cam_from_world().matrix(), np.c_[v.R, v.t], atol=1e-12)
    assert 1000 <= rec.num_points3D() <= 3000
    inclusive_ids = {i for i, im in rec.images.items() if not im.name.startswith("test_")}
    for im in rec.images.values():
        if im.name.startswith("test_"):
            assert im.num_points2D() == 0
    xyz = []
    for k, (pid, p) in enumerate(sorted(rec.points3D.items())):
        ids = [e.image_id for e in p.track.elements]
        assert len(set(ids)) >= 2 and set(ids) <= inclusive_ids
        xyz.append(p.xyz)
        if k % 4:
            continue  # reprojection on every 4th point keeps the test fast
        for e in p.track.elements:
            im = rec.images[e.image_id]
            obs = im.points2D[e.point2D_idx]
            assert obs.point3D_id == pid
            proj = cam.img_from_cam(np.array([im.cam_from_world() * p.xyz]))[0]
            np.testing.assert_allclose(proj, obs.xy, atol=1e-6)
    assert rec.compute_mean_reprojection_error() < 1e-6
    # no point lies on a surface that only the object-free test views see
    assert seen_by_object_inclusive_views(toys, np.array(xyz)).all()


def test_sparse_points_lie_on_surfaces_with_rendered_colours(toys):
    rec = pycolmap.Reconstruction(str(toys / "sparse" / "0"))
    _, views = _cams(toys)
    by_name = {v.name: v for v in views}
    n_checked = 0
    for p in list(rec.points3D.values())[:300]:
        # a point's observation in some view is (near) a pixel centre whose gt depth equals the point's camera z
        for e in p.track.elements:
            im = rec.images[e.image_id]
            v = by_name[im.name]
            xy = im.points2D[e.point2D_idx].xy
            if np.allclose(xy - np.floor(xy), 0.5, atol=1e-9):
                z = v.project(p.xyz[None])[1][0]
                assert _depth(toys, v)[int(xy[1]), int(xy[0])] == pytest.approx(z, rel=1e-6)
                col = np.array(Image.open(toys / "images" / im.name))[int(xy[1]), int(xy[0])]
                np.testing.assert_array_equal(col, p.color)
                n_checked += 1
                break
    assert n_checked > 250


def _depth_map_check(views, depths, X):
    """Over-approximations from depth maps: (some view may see X, every view may have X out of frame or behind a surface)."""
    seen_any = np.zeros(len(X), bool)
    blocked_all = np.ones(len(X), bool)
    for v in views:
        uv, z = v.project(X)
        inframe = (z > 0) & (uv[:, 0] >= 0) & (uv[:, 0] < W) & (uv[:, 1] >= 0) & (uv[:, 1] < H)
        D = np.pad(depths[v.name], 1, mode="edge")
        j = np.clip(np.floor(uv[:, 0]).astype(int), 0, W - 1) + 1
        i = np.clip(np.floor(uv[:, 1]).astype(int), 0, H - 1) + 1
        nb = np.stack([D[i + di, j + dj] for di in (-1, 0, 1) for dj in (-1, 0, 1)], -1)
        tol = 1e-4 * z
        lo, hi = nb.min(-1), nb.max(-1)
        in_front = lo < z - tol  # some surface of this view lies in front of X nearby
        # X is not behind the surfaces around its projection; the local depth range (capped at 2%) is
        # the slack for creases, image borders and sub-pixel gaps that pixel-centre depths cannot resolve
        not_behind = z - tol <= hi + np.minimum(hi - lo, 0.02 * z)
        seen_any |= inframe & not_behind
        blocked_all &= ~inframe | in_front
    return seen_any, blocked_all


def test_unseen_masks_agree_with_independent_depth_map_check(toys):
    """Unseen pixel -> with the objects, every object-inclusive view has it out of frame or behind a nearer surface
    of its gt depth, and without them some view would see it. Any other pixel -> some view sees it with the
    objects, or none would see it even without them (outside every frustum: not an inpainting target)."""
    sc = load_scene(toys)
    _, views = _cams(toys)
    inc = [v for v in views if not v.object_free]
    depths = {v.name: _depth(toys, v) for v in inc}
    free_depths = {v.name: render_view(sc, v, with_objects=False).depth for v in inc}
    total_unseen = 0
    out_of_all_frames = 0
    for tv in [v for v in views if v.object_free]:
        mask = np.array(Image.open(toys / "unseen_mask" / tv.name)) > 0
        assert set(np.unique(np.array(Image.open(toys / "unseen_mask" / tv.name)))) <= {0, 255}
        X = _backproject(tv, _depth(toys, tv))
        seen_any, blocked_all = _depth_map_check(inc, depths, X)
        seen_free, blocked_free = _depth_map_check(inc, free_depths, X)
        unseen = mask.ravel()
        total_unseen += unseen.sum()
        out_of_all_frames += (~unseen & ~seen_free).sum()
        assert blocked_all[unseen].all(), f"{tv.name}: unseen pixel visible by the depth-map check"
        assert seen_free[unseen].all(), f"{tv.name}: unseen pixel not visible even without the objects"
        assert (seen_any | blocked_free)[~unseen].all(), f"{tv.name}: pixel hidden only by the objects but not in the mask"
    assert total_unseen > 20  # the removed toys' footprints are never seen
    assert out_of_all_frames > 0  # the reduced orbit leaves backdrop no camera sees: excluded from the masks


def test_unseen_region_is_under_the_removed_objects(toys):
    """Most unseen pixels lie on the floor inside the removed objects' footprints (revealed surface)."""
    sc = load_scene(toys)
    objs = {o.id: o for o in sc.spec.objects}
    _, views = _cams(toys)
    near = 0
    count = 0
    for tv in [v for v in views if v.object_free]:
        m = np.array(Image.open(toys / "unseen_mask" / tv.name)).ravel() > 0
        X = _backproject(tv, _depth(toys, tv))[m]
        count += len(X)
        close = np.zeros(len(X), bool)
        for oid in sc.spec.removal_targets:
            c, r = objs[oid].bounds()
            close |= np.linalg.norm((X - c)[:, :2], axis=1) < r
        near += close.sum()
    assert count > 0 and near / count > 0.5


def test_instance_ids_match_geometry(toys):
    """Object pixels back-project into their object's bounding sphere; background pixels onto floor/walls/ceiling."""
    sc = load_scene(toys)
    objs = {o.id: o.bounds() for o in sc.spec.objects}
    _, views = _cams(toys)
    seen_ids = set()
    for v in views:
        inst = np.array(Image.open(toys / "gt" / "instance" / v.name)).ravel()
        X = _backproject(v, _depth(toys, v))
        for oid in np.unique(inst):
            sel = inst == oid
            if oid == 0:
                x = X[sel]
                on_floor = np.abs(x[:, 2]) < 1e-4
                on_wall = (np.abs(np.abs(x[:, 0]) - 4.0) < 1e-4) | (np.abs(np.abs(x[:, 1]) - 4.0) < 1e-4) | (np.abs(x[:, 2] - 2.95) < 1e-4)
                assert (on_floor | on_wall).all(), v.name
            else:
                c, r = objs[int(oid)]
                assert (np.linalg.norm(X[sel] - c, axis=1) <= r * (1 + 1e-5)).all(), (v.name, oid)
                seen_ids.add(int(oid))
        if v.object_free:
            assert not set(np.unique(inst)) & {1, 2}, f"removal target visible in {v.name}"
    assert seen_ids == {1, 2, 3}
    kept_in_tests = [3 in np.unique(np.array(Image.open(toys / "gt" / "instance" / v.name))) for v in views if v.object_free]
    assert any(kept_in_tests)


def test_instance_edges_are_depth_edges(toys):
    """Where the id changes between two neighbouring object/background pixels, depth jumps or the point sits on the floor line."""
    _, views = _cams(toys)
    for v in views[:6]:
        inst = np.array(Image.open(toys / "gt" / "instance" / v.name))
        d = _depth(toys, v)
        a, b = inst[:, :-1], inst[:, 1:]
        edge = (a != b)
        jump = np.abs(d[:, :-1] - d[:, 1:]) / np.minimum(d[:, :-1], d[:, 1:])
        flat = (a == b)
        if edge.any():
            assert np.median(jump[edge]) > 5 * np.median(jump[flat])


def test_render_view_reproduces_the_captures(toys):
    sc = load_scene(toys)
    _, views = _cams(toys)
    for v in (views[0], views[-1]):
        r = render_view(toys, v.camera if not v.object_free else v, with_objects=not v.object_free)
        np.testing.assert_array_equal(r.rgb8(), np.array(Image.open(toys / "images" / v.name)))
        np.testing.assert_array_equal(r.instance, np.array(Image.open(toys / "gt" / "instance" / v.name)))
        np.testing.assert_allclose(r.depth, _depth(toys, v), rtol=1e-6)
    # the object-free rendering of a training pose shows no removal targets but keeps the block tower where visible
    free = render_view(sc, views[0], with_objects=False)
    assert not set(np.unique(free.instance)) & {1, 2}
    only_ball_hidden = render_view(sc, views[0], hidden=[2])
    assert 2 not in np.unique(only_ball_hidden.instance)


def test_visibility_oracle(toys):
    sc = load_scene(toys)
    _, views = _cams(toys)
    tv = [v for v in views if v.object_free][0]
    m = np.array(Image.open(toys / "unseen_mask" / tv.name)).ravel() > 0
    # exact (float64) surface points of the test view: the oracle reproduces the stored mask bit for bit
    X = render_view(sc, tv, with_objects=False, supersample=1).points.reshape(-1, 3)
    seen_exact = seen_by_object_inclusive_views(sc, X)
    np.testing.assert_array_equal(m, ~seen_exact & seen_by_views(sc.world_free, sc.inclusive_views, X))
    # from a folder path too; a tolerance only ever adds points
    Xf = _backproject(tv, _depth(toys, tv))  # float32 depth: ~1e-7 relative off the surface
    seen_tol = seen_by_object_inclusive_views(toys, Xf, tol=1e-4)
    assert (seen_tol >= seen_by_object_inclusive_views(toys, Xf)).all()
    assert (seen_tol == seen_exact).mean() > 0.999
    # a point inside an object's volume (e.g. the ball's centre) is seen by no camera
    ball_centre = np.array([sc.spec.objects[1].bounds()[0]])
    assert not seen_by_object_inclusive_views(sc, ball_centre)[0]


def test_multi_object_scenes_have_occlusions():
    """In toys, fruits and garden one object hides part of another from part of the orbit."""
    for name in ("toys", "fruits", "garden"):
        sc = build_scene(name, reduced=True, width=64, height=48)
        ids = [o.id for o in sc.spec.objects]
        found = False
        for v in sc.inclusive_views[::2]:
            full = render(sc.world_full, v, supersample=1).instance
            for a in ids:
                without_a = render(World(sc.spec, {a}, sc.seed), v, supersample=1).instance
                if np.any((full == a) & (without_a != 0) & (without_a != a)):
                    found = True
                    break
            if found:
                break
        assert found, name


def test_catalogue():
    assert len(SCENES) >= 7
    single = [s for s in SCENES.values() if len(s.objects) == 1]
    multi = [s for s in SCENES.values() if len(s.objects) > 1]
    assert len(single) >= 4 and len(multi) >= 2
    for s in multi:  # object-aware removal: some objects removed, others kept
        assert 0 < len(s.removal_targets) < len(s.objects)
    for s in SCENES.values():
        ids = [o.id for o in s.objects]
        assert len(set(ids)) == len(ids) and min(ids) >= 1 and max(ids) <= 255
    # the thin structure: stool legs are 1-2.5 px wide in every full-size capture
    sc = build_scene("stool")
    legs = [p for p in sc.spec.objects[0].world_prims() if p[0].shape == "cylinder" and p[0].params[0] < 0.01]
    assert len(legs) >= 4
    for v in sc.inclusive_views:
        for prim, _, c in legs[:4]:
            dist = np.linalg.norm(v.center - c)
            assert 0.8 <= 2 * prim.params[0] * v.camera.fx / dist <= 2.5
    # the outdoor scene has a wider orbit than the indoor ones
    r_garden = orbit_geometry(SCENES["garden"], 256, 192)[1]
    assert all(r_garden > orbit_geometry(s, 256, 192)[1] for n, s in SCENES.items() if n != "garden")
    with pytest.raises(InputError):
        scene_spec("nope")
