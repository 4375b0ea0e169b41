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


def _blob(width: int, height: int, cx: float, cy: float, sigma: float = 6.0) -> np.ndarray:
    """A grey Gaussian blob centred at (cx, cy) in COLMAP's pixel convention (pixel centres at +0.5)."""
    yy, xx = np.mgrid[0:height, 0:width] + 0.5
    return np.exp(-((xx - cx) ** 2 + (yy - cy) ** 2) / (2 * sigma**2))


def _centroid(img: np.ndarray) -> tuple[float, float]:
    yy, xx = np.mgrid[0 : img.shape[0], 0 : img.shape[1]] + 0.5
    return float((img * xx).sum() / img.sum()), float((img * yy).sum() / img.sum())


@pytest.mark.parametrize("scale", [0.5, 0.37, 0.8])
def test_working_copy_maps_points_by_exactly_the_scale_on_both_axes(tmp_path, scale):
    """A point at x in the photo is at scale * x in the SfM copy, whatever the rounding of the copy's size."""
    from PIL import Image

    from dataset_tools.capture.colmap import write_working_copy

    W, H = 301, 203
    for cx, cy in [(40.3, 30.7), (260.2, 180.9), (150.5, 101.5)]:
        src = tmp_path / "photo.png"
        Image.fromarray((_blob(W, H, cx, cy) * 255).round().astype(np.uint8)).save(src)
        w, h = write_working_copy(src, tmp_path / "copy.png", scale)
        small = np.asarray(Image.open(tmp_path / "copy.png"), float)
        assert small.shape == (h, w) == (round(H * scale), round(W * scale))
        mx, my = _centroid(small)
        assert abs(mx / scale - cx) < 0.05 and abs(my / scale - cy) < 0.05, (mx / scale, my / scale)


def test_working_copy_keeps_format_and_exif_and_reads_16_bit(tmp_path):
    from PIL import Image

    from dataset_tools.capture.colmap import write_working_copy

    exif = Image.Exif()
    exif[0x010F] = "TestMake"  # Make
    exif[0x920A] = 4.5  # FocalLength (mm): COLMAP's focal-length prior
    rgb = np.random.default_rng(0).integers(0, 256, (60, 80, 3), dtype=np.uint8)
    Image.fromarray(rgb).save(tmp_path / "a.jpg", exif=exif)
    assert write_working_copy(tmp_path / "a.jpg", tmp_path / "a_small.jpg", 0.5) == (40, 30)
    with Image.open(tmp_path / "a_small.jpg") as im:
        assert im.format == "JPEG" and im.mode == "RGB" and im.size == (40, 30)
        assert im.getexif()[0x010F] == "TestMake"
    deep = np.tile(np.repeat(np.array([0, 257 * 100, 65535], np.uint16), [20, 30, 30]), (60, 1))  # 16-bit grey
    Image.fromarray(deep).save(tmp_path / "d.png")
    write_working_copy(tmp_path / "d.png", tmp_path / "d_small.png", 0.5)
    with Image.open(tmp_path / "d_small.png") as im:
        small = np.asarray(im)
    assert small.dtype == np.uint8 and small.shape == (30, 40)
    assert list(small[0, [0, 15, 39]]) == [0, 100, 255]  # 65535 -> 255, as an 8-bit reader maps it


def test_reconstruction_from_copies_is_mapped_back_to_the_full_size():
    """SfM on copies shrunk by s: dividing focal, principal point and observations by s gives the full-size
    model, with the same poses and points and reprojection errors in full-size pixels."""
    from dataset_tools.capture.colmap import rescale_reconstruction

    full = sb.box_reconstruction(sb.box_scene())
    s = 0.37
    small = sb.box_reconstruction(sb.box_scene())  # made into what SfM on the copies gives
    for cam in small.cameras.values():
        cam.params = np.array(cam.params) * s  # PINHOLE: fx, fy, cx, cy
        cam.width, cam.height = round(cam.width * s), round(cam.height * s)
    for image in small.images.values():
        for p in image.points2D:
            p.xy = p.xy * s + 0.2  # 0.2 px of error at the working size
    small.update_point_3d_errors()
    assert abs(small.compute_mean_reprojection_error() - 0.2 * np.sqrt(2)) < 1e-6
    rescale_reconstruction(small, s, 160, 120)
    for cid, cam in small.cameras.items():
        assert (cam.width, cam.height) == (160, 120)
        np.testing.assert_allclose(cam.params, full.cameras[cid].params, rtol=1e-12)
    for iid, image in small.images.items():
        np.testing.assert_allclose(image.cam_from_world().matrix(), full.image(iid).cam_from_world().matrix())
        np.testing.assert_allclose([p.xy for p in image.points2D], [p.xy + 0.2 / s for p in full.image(iid).points2D])
    assert abs(small.compute_mean_reprojection_error() - 0.2 * np.sqrt(2) / s) < 1e-6  # now in full-size pixels
