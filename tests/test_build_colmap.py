"""SfM helpers without running SfM: pair selection, camera-model handling, corrupt-model reading, pose scoring."""

from __future__ import annotations

import itertools
import struct

import numpy as np
import pycolmap
import pytest
from scipy.spatial.transform import Rotation

import scene_builder as sb
from dataset_tools.capture.colmap import SfMConfig, _pair_list, needs_undistortion
from dataset_tools.capture.posecheck import pose_accuracy, rotation_angle_deg
from inpaint360gs.core.errors import InputError
from inpaint360gs.io.colmap import read_model, to_pinhole

INC = [f"IMG_{i:03d}.png" for i in range(40)]
FREE = [f"test_{i:03d}.png" for i in range(10)]


def test_exhaustive_pairs_are_all_pairs():
    names = INC[:7] + FREE[:3]
    pairs, how = _pair_list(names, set(FREE), SfMConfig(matcher="exhaustive"))
    assert how == "exhaustive" and len(pairs) == 45 and set(pairs) == {tuple(sorted(p)) for p in itertools.combinations(names, 2)}


def test_sequential_pairs_wrap_the_orbit_and_link_both_captures():
    cfg = SfMConfig(matcher="sequential", overlap=3, cross_pairs=5)
    pairs, how = _pair_list(INC + FREE, set(FREE), cfg)
    assert how == "sequential" and len(pairs) == len(set(pairs))
    ps = set(pairs)
    assert ("IMG_000.png", "IMG_039.png") in ps and ("IMG_001.png", "IMG_039.png") in ps  # wraps around
    assert ("IMG_000.png", "IMG_002.png") in ps and ("IMG_000.png", "IMG_008.png") in ps  # overlap + 2^k
    assert ("IMG_000.png", "IMG_005.png") not in ps
    assert ("test_000.png", "test_009.png") in ps  # the object-free sequence is an orbit too
    for f in FREE:
        partners = {a for a, b in pairs if b == f and a in INC} | {b for a, b in pairs if a == f and b in INC}
        assert len(partners) == 5
    # together the cross pairs reach all around the object-inclusive orbit
    cross = {a for a, b in pairs if a in INC and b in FREE}
    assert len(cross) >= 30
    assert len(pairs) < len(list(itertools.combinations(INC + FREE, 2))) / 3


def test_auto_switches_on_size():
    names = INC + FREE
    assert _pair_list(names, set(FREE), SfMConfig(matcher="auto", exhaustive_max_images=60))[1] == "exhaustive"
    assert _pair_list(names, set(FREE), SfMConfig(matcher="auto", exhaustive_max_images=49))[1] == "sequential"


def test_bad_config_values_are_input_errors():
    with pytest.raises(InputError, match="matcher"):
        SfMConfig(matcher="vocab")
    with pytest.raises(InputError, match="camera model"):
        SfMConfig(camera_model="FISHEYE")


def test_simple_pinhole_becomes_pinhole():
    rec = sb.box_reconstruction(sb.box_scene())
    cam = rec.cameras[1]
    cam.model = pycolmap.Camera(model="SIMPLE_PINHOLE", width=160, height=120, params=[110, 80, 60]).model
    cam.params = [110.0, 80.0, 60.0]
    assert not needs_undistortion(rec)
    to_pinhole(rec)
    assert rec.cameras[1].model_name == "PINHOLE" and list(rec.cameras[1].params) == [110, 110, 80, 60]
    cam.model = pycolmap.Camera(model="SIMPLE_RADIAL", width=160, height=120, params=[110, 80, 60, 0.0]).model
    assert needs_undistortion(rec)


def test_read_model_rejects_corrupt_files_quickly(tmp_path):
    rec = sb.box_reconstruction(sb.box_scene())
    rec.write(tmp_path)
    assert read_model(tmp_path).num_points3D() == rec.num_points3D()
    (tmp_path / "images.bin").write_bytes(struct.pack("<Q", 2**40) + bytes(100))
    with pytest.raises(InputError, match="header claims"):
        read_model(tmp_path)
    (tmp_path / "images.bin").write_bytes(b"")
    with pytest.raises(InputError, match="truncated"):
        read_model(tmp_path)
    with pytest.raises(InputError, match="missing"):
        read_model(tmp_path / "nope")


def _true_poses():
    """Poses of the box scene's cameras, made exact rotations (they are float32 look-at poses)."""
    out = {}
    for c in sb.box_scene(n_train=12, n_test=4).cameras:
        R = Rotation.from_matrix(sb.pose(c)[0]).as_matrix()
        out[c.name] = (R, -R @ sb.centre(c))
    return out


def test_pose_accuracy_is_zero_under_any_similarity():
    true = _true_poses()
    Rs = Rotation.random(random_state=3).as_matrix()
    s, ts = 0.37, np.array([5.0, -2.0, 1.0])
    est = {}
    for n, (R, t) in true.items():
        c = -R.T @ t
        R2 = R @ Rs.T
        est[n] = (R2, -R2 @ (s * Rs @ c + ts))
    acc = pose_accuracy(est, true, orbit_radius=3.0)
    assert acc.matched == 16 and acc.missing == []
    assert acc.center_err_max_pct < 1e-9 and acc.rot_err_max_deg < 1e-9
    assert abs(acc.scale - 1 / s) < 1e-9 and acc.passes()


def test_pose_accuracy_reports_a_known_rotation_error_and_missing_views():
    true = _true_poses()
    est = dict(true)
    R, t = true["IMG_005.png"]
    c = -R.T @ t
    dR = Rotation.from_rotvec(np.radians(0.8) * np.array([0.0, 0.6, 0.8])).as_matrix()
    est["IMG_005.png"] = (dR @ R, -(dR @ R) @ c)  # same centre, rotated 0.8 degrees
    del est["test_002.png"]
    acc = pose_accuracy(est, true, orbit_radius=3.0)
    assert acc.missing == ["test_002.png"] and not acc.passes()
    assert abs(acc.rot_err_max_deg - 0.8) < 1e-9 and acc.worst_rotation == "IMG_005.png"
    assert acc.center_err_max_pct < 1e-9
    assert abs(rotation_angle_deg(dR, np.eye(3)) - 0.8) < 1e-12
