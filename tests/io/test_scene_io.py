"""Scene loader: good folders (cameras, splits, points, pixels, masks, resize) and bad ones."""

from __future__ import annotations

import json
import shutil

import cv2
import numpy as np
import pytest
import torch
from scene_builder import orbit_cameras, simple_scene, write_model, write_png

from inpaint360gs.core.errors import InputError
from inpaint360gs.core.errors import TestPixelAccessError
from inpaint360gs.io.scene import load_scene


def _project(cam, x):
    xc = cam.R.double() @ torch.as_tensor(x, dtype=torch.float64) + cam.t.double()
    return cam.fx * xc[0] / xc[2] + cam.cx, cam.fy * xc[1] / xc[2] + cam.cy


@pytest.fixture()
def scene_dir(tmp_path):
    root = tmp_path / "scene"
    cams, pts = simple_scene(root, n_train=18, n_test=3)
    return root, cams, pts


def test_good_scene_cameras_points_and_splits(scene_dir):
    root, cams, pts = scene_dir
    s = load_scene(root)
    assert [v.name for v in s.views] == sorted(c.name for c in cams)
    others = sorted(c.name for c in cams if not c.name.startswith("test_"))
    assert [v.name for v in s.holdout_views] == [others[0], others[8], others[16]]  # llffhold = 8, index 0, 8, 16
    assert len(s.train_views) == 15 and {v.name for v in s.test_views} == {"test_000.png", "test_001.png", "test_002.png"}
    by_name = {c.name: c for c in cams}
    for v in s.views:
        c = by_name[v.name]
        assert torch.allclose(v.camera.R, c.R, atol=1e-6) and torch.allclose(v.camera.t, c.t, atol=1e-6)
        assert (v.camera.fx, v.camera.fy, v.camera.cx, v.camera.cy, v.camera.width, v.camera.height) == (c.fx, c.fy, c.cx, c.cy, 64, 48)
    assert torch.allclose(s.points.double(), torch.as_tensor(pts), atol=1e-6)
    # scene extent = 1.1 x largest distance of training camera centres from their mean (3DGS)
    centres = torch.stack([v.camera.center.double() for v in s.train_views])
    assert s.extent == pytest.approx(1.1 * (centres - centres.mean(0)).norm(dim=1).max().item(), rel=1e-6)


def test_pixels_and_test_view_protection(scene_dir):
    root, _, _ = scene_dir
    s = load_scene(root)
    v = s.train_views[0]
    ref = cv2.cvtColor(cv2.imread(str(root / "images" / v.name)), cv2.COLOR_BGR2RGB)
    img = s.load_image(v)
    assert img.dtype == torch.float32 and img.shape == (48, 64, 3)
    assert torch.equal(img, torch.from_numpy(ref).float() / 255)
    t = s.test_views[0]
    with pytest.raises(TestPixelAccessError):
        s.load_image(t)
    assert s.load_image(t, allow_test=True).shape == (48, 64, 3)


def test_llffhold_zero_and_simple_pinhole(tmp_path):
    root = tmp_path / "s"
    cams = orbit_cameras(5)
    write_model(root / "sparse" / "0", cams, np.zeros((3, 3)), np.zeros((3, 3)), model="SIMPLE_PINHOLE")
    for c in cams:
        write_png(root / "images" / c.name, np.zeros((48, 64, 3), np.uint8))
    s = load_scene(root, llffhold=0)
    assert len(s.train_views) == 5 and not s.holdout_views and s.views[0].camera.fy == cams[0].fx


def test_resize_on_load_scales_intrinsics_consistently(scene_dir):
    root, cams, _ = scene_dir
    s1, s2 = load_scene(root), load_scene(root, resize=2)
    x = (0.3, -0.2, 0.4)
    for v1, v2 in zip(s1.views, s2.views):
        c1, c2 = v1.camera, v2.camera
        assert (c2.width, c2.height) == (32, 24) and c2.fx == c1.fx / 2 and c2.cx == c1.cx / 2
        u1, w1 = _project(c1, x)
        u2, w2 = _project(c2, x)
        assert float(u2 / c2.width) == pytest.approx(float(u1 / c1.width), abs=1e-9)
        assert float(w2 / c2.height) == pytest.approx(float(w1 / c1.height), abs=1e-9)
    v = s2.train_views[0]
    full = cv2.cvtColor(cv2.imread(str(root / "images" / v.name)), cv2.COLOR_BGR2RGB)
    expect = cv2.resize(full, (32, 24), interpolation=cv2.INTER_AREA)
    assert np.array_equal(s2.load_image_raw(v), expect)


def test_resize_prefers_images_r_folder(scene_dir):
    root, cams, _ = scene_dir
    for c in cams:
        write_png(root / "images_2" / c.name, np.full((24, 32, 3), 7, np.uint8))
    s = load_scene(root, resize=2)
    v = s.train_views[0]
    assert v.image_path == root / "images_2" / v.name
    assert int(s.load_image_raw(v).max()) == 7
    write_png(root / "images_2" / v.name, np.zeros((20, 30, 3), np.uint8))
    with pytest.raises(InputError) as e:
        load_scene(root, resize=2)
    assert e.value.path == root / "images_2" / v.name and "30x20" in str(e.value)


def test_masks_are_indexed_resized_and_size_checked(scene_dir):
    root, _, _ = scene_dir
    m = np.zeros((48, 64), np.uint8)
    m[10:20, 30:50] = 255
    (root / "unseen_mask").mkdir()
    cv2.imwrite(str(root / "unseen_mask" / "test_000.png"), m)
    s = load_scene(root)
    t0, t1 = s.test_views[0], s.test_views[1]
    assert s.has_mask(t0) and not s.has_mask(t1)
    got = s.load_mask(t0)
    assert got.dtype == bool and got.sum() == 200
    s2 = load_scene(root, resize=2)
    assert s2.load_mask(s2.view("test_000.png")).shape == (24, 32)
    with pytest.raises(InputError):
        s.load_mask(t1)
    bad = root / "unseen_mask" / "test_001.png"
    cv2.imwrite(str(bad), np.zeros((40, 64), np.uint8))
    with pytest.raises(InputError) as e:
        load_scene(root)
    assert e.value.path == bad and "mask is 64x40" in str(e.value)


# ---- bad folders: one InputError naming the offending file ------------------------------------


def test_missing_sparse(scene_dir):
    root, _, _ = scene_dir
    shutil.rmtree(root / "sparse")
    with pytest.raises(InputError) as e:
        load_scene(root)
    assert e.value.path == root / "sparse" / "0"


def test_registered_image_missing_on_disk(scene_dir):
    root, _, _ = scene_dir
    (root / "images" / "IMG_003.png").unlink()
    with pytest.raises(InputError) as e:
        load_scene(root)
    assert e.value.path == root / "images" / "IMG_003.png" and "missing on disk" in str(e.value)


def test_corrupt_images(scene_dir):
    root, _, _ = scene_dir
    garbage = root / "images" / "IMG_004.png"
    garbage.write_bytes(b"not an image at all" * 10)
    with pytest.raises(InputError) as e:  # header unreadable: caught while loading the scene
        load_scene(root)
    assert e.value.path == garbage
    shutil.copy(root / "images" / "IMG_005.png", garbage)
    data = (root / "images" / "IMG_006.png").read_bytes()
    (root / "images" / "IMG_006.png").write_bytes(data[: len(data) // 2])  # valid header, truncated data
    s = load_scene(root)
    with pytest.raises(InputError) as e:
        s.load_image(s.view("IMG_006.png"))
    assert e.value.path == root / "images" / "IMG_006.png"


def test_truncated_jpeg_is_detected(tmp_path):
    from inpaint360gs.io.images import read_image

    p = tmp_path / "a.jpg"
    cv2.imwrite(str(p), np.random.default_rng(0).integers(0, 255, (48, 64, 3), dtype=np.uint8))
    assert read_image(p).shape == (48, 64, 3)
    data = p.read_bytes()
    p.write_bytes(data[: len(data) * 2 // 3])
    with pytest.raises(InputError, match="truncated JPEG"):
        read_image(p)


def test_unregistered_image_is_an_error_or_a_warning(scene_dir):
    root, _, _ = scene_dir
    stray = root / "images" / "test_999.png"
    write_png(stray, np.zeros((48, 64, 3), np.uint8))
    with pytest.raises(InputError) as e:
        load_scene(root)
    assert e.value.path == stray and "not registered" in str(e.value)
    with pytest.warns(UserWarning, match="not registered"):
        s = load_scene(root, unregistered="warn")
    assert s.unregistered == ["test_999.png"] and "test_999.png" not in [v.name for v in s.views]


def test_empty_train_split(tmp_path):
    root = tmp_path / "s"
    cams = orbit_cameras(3, prefix="test_")
    write_model(root / "sparse" / "0", cams, np.zeros((3, 3)), np.zeros((3, 3)))
    for c in cams:
        write_png(root / "images" / c.name, np.zeros((48, 64, 3), np.uint8))
    with pytest.raises(InputError, match="no training views") as e:
        load_scene(root)
    assert e.value.path == root / "sparse" / "0"


def test_distorted_camera_model_is_rejected(tmp_path):
    root = tmp_path / "s"
    cams = orbit_cameras(4)
    write_model(root / "sparse" / "0", cams, np.zeros((3, 3)), np.zeros((3, 3)), model="OPENCV", params=[60, 60, 32, 24, 0.1, 0, 0, 0])
    for c in cams:
        write_png(root / "images" / c.name, np.zeros((48, 64, 3), np.uint8))
    with pytest.raises(InputError, match=r"camera \d+ uses model OPENCV.*undistort") as e:
        load_scene(root)
    assert e.value.path == root / "sparse" / "0" / "cameras.bin"


def test_image_size_must_match_camera(scene_dir):
    root, _, _ = scene_dir
    p = root / "images" / "IMG_002.png"
    write_png(p, np.zeros((50, 64, 3), np.uint8))
    with pytest.raises(InputError, match="64x50 but camera") as e:
        load_scene(root)
    assert e.value.path == p


def test_scene_json(scene_dir):
    root, _, _ = scene_dir
    (root / "scene.json").write_text(json.dumps({"objects": [{"id": 1, "label": "cone"}], "removal_targets": [1]}))
    assert load_scene(root).info["removal_targets"] == [1]
    (root / "scene.json").write_text("{not json")
    with pytest.raises(InputError) as e:
        load_scene(root)
    assert e.value.path == root / "scene.json"


def test_bad_resize_and_missing_folder(tmp_path, scene_dir):
    with pytest.raises(InputError):
        load_scene(tmp_path / "nope")
    with pytest.raises(InputError, match="resize"):
        load_scene(scene_dir[0], resize=0)
