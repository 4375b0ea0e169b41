"""Point-leak removal on hand-built reconstructions: exact ids, counts and cleared references."""

from __future__ import annotations

import numpy as np
import pycolmap

import scene_builder as sb
from dataset_tools.capture.leaks import leaked_point_ids, object_free_influence, remove_leaked_points, remove_points_in_masks

NAMES = ["IMG_a.png", "IMG_b.png", "IMG_c.png", "test_x.png", "test_y.png"]  # ids 1..5; 4, 5 object-free


def _rec(tracks: list[list[tuple[int, int]]], kps_per_image: int = 6) -> pycolmap.Reconstruction:
    rec = pycolmap.Reconstruction()
    rec.add_camera_with_trivial_rig(pycolmap.Camera(model="PINHOLE", width=40, height=30,
                                                    params=[50, 50, 20, 15], camera_id=1))
    kp = np.array([[2.5 + 5 * k, 3.5 + 4 * k] for k in range(kps_per_image)])
    for iid, name in enumerate(NAMES, start=1):
        rec.add_image_with_trivial_frame(pycolmap.Image(name=name, keypoints=kp, camera_id=1, image_id=iid),
                                         pycolmap.Rigid3d(pycolmap.Rotation3d(), np.array([0.1 * iid, 0, 0])))
    for k, tr in enumerate(tracks):
        rec.add_point3D(np.array([0.0, 0.0, 5.0 + k]),
                        pycolmap.Track([pycolmap.TrackElement(i, j) for i, j in tr]))
    return rec


TRACKS = [
    [(1, 0), (2, 0)],  # 1: training only -> kept
    [(4, 0), (5, 0)],  # 2: test only -> leaked
    [(1, 1), (4, 1)],  # 3: training + test, one training view: as 5
    [(5, 2), (4, 2)],  # 4: test only -> leaked
    [(3, 3), (4, 3), (5, 3)],  # 5: one training observation: kept with min 1, removed with min 2 (default)
    [(4, 4), (5, 4)],  # 6: test only -> leaked
]


def test_leaked_points_are_exactly_the_test_only_tracks():
    rec = _rec(TRACKS)
    assert sorted(leaked_point_ids(rec)) == [2, 4, 6]
    rep = remove_leaked_points(rec, min_inclusive_views=1, min_inclusive_angle_deg=0)
    assert (rep.points_before, rep.removed, rep.points_after) == (6, 3, 3)
    assert (rep.removed_unseen, rep.removed_single_view) == (3, 0)
    assert sorted(rec.points3D) == [1, 3, 5]
    assert rep.removed_by_test_views == {"test_x.png": 3, "test_y.png": 3}
    # references in the images are cleared: test_x keeps only the observations of points 3 and 5
    tx = rec.image(4)
    assert [k for k, p in enumerate(tx.points2D) if p.has_point3D()] == [1, 3]
    assert tx.num_points3D == 2 and rec.image(5).num_points3D == 1
    assert leaked_point_ids(rec) == []
    assert remove_leaked_points(rec, min_inclusive_views=1, min_inclusive_angle_deg=0).removed == 0  # idempotent


def test_default_also_removes_points_one_training_view_cannot_triangulate():
    rec = _rec(TRACKS)
    assert sorted(leaked_point_ids(rec, min_inclusive_views=2)) == [2, 3, 4, 5, 6]
    rep = remove_leaked_points(rec, min_inclusive_angle_deg=0)  # default: at least 2 object-inclusive views
    assert (rep.removed, rep.removed_unseen, rep.removed_single_view, rep.points_after) == (5, 3, 2, 1)
    assert sorted(rec.points3D) == [1]
    assert rep.to_dict()["min_inclusive_views"] == 2
    assert rec.image(1).num_points3D == 1 and rec.image(3).num_points3D == 0


def test_default_also_removes_points_whose_training_rays_are_nearly_parallel():
    """Camera centres at (-0.1 i, 0, 0); point k at (0, 0, 5 + k). Point 1 (images 1, 2 at depth 5):
    rays 1.146° apart; point 2 (images 1, 3 + a test view, depth 6): atan(0.3/6) - atan(0.1/6) = 1.907°."""
    from dataset_tools.capture.leaks import inclusive_triangulation_angles

    tracks = [[(1, 0), (2, 0)], [(1, 1), (3, 1), (4, 1)]]
    ang = inclusive_triangulation_angles(_rec(tracks))
    assert abs(ang[1] - np.degrees(np.arctan(0.2 / 5) - np.arctan(0.1 / 5))) < 1e-9
    assert abs(ang[2] - np.degrees(np.arctan(0.3 / 6) - np.arctan(0.1 / 6))) < 1e-9
    rec = _rec(tracks)
    rep = remove_leaked_points(rec)  # default 1.5°
    assert (rep.removed, rep.removed_small_angle, rep.removed_single_view, rep.removed_unseen) == (1, 1, 0, 0)
    assert sorted(rec.points3D) == [2] and rep.to_dict()["min_inclusive_angle_deg"] == 1.5
    rec = _rec(tracks)
    assert remove_leaked_points(rec, min_inclusive_angle_deg=2.0).removed_small_angle == 2 and rec.num_points3D() == 0
    rec = _rec(tracks)
    assert remove_leaked_points(rec, min_inclusive_angle_deg=0).removed == 0


def test_leak_removal_survives_a_write_read_round_trip(tmp_path):
    rec = _rec(TRACKS)
    remove_leaked_points(rec, min_inclusive_views=1, min_inclusive_angle_deg=0)
    rec.write(tmp_path)
    back = pycolmap.Reconstruction(tmp_path)
    assert sorted(back.points3D) == [1, 3, 5] and leaked_point_ids(back) == []


def test_custom_inclusive_rule():
    rec = _rec(TRACKS)
    # with IMG_c no longer counted as object-inclusive, point 5 (IMG_c + test views) leaks too
    leaked = leaked_point_ids(rec, lambda n: n in ("IMG_a.png", "IMG_b.png"))
    assert sorted(leaked) == [2, 4, 5, 6]


def test_points_inside_unseen_masks_use_observations_and_pixel_centres():
    rec = _rec(TRACKS)
    remove_leaked_points(rec, min_inclusive_views=1, min_inclusive_angle_deg=0)  # points 1, 3, 5 remain; test_x observes 3 (kp 1) and 5 (kp 3)
    # keypoint 1 is at (7.5, 7.5) -> pixel (row 7, col 7); keypoint 3 at (17.5, 15.5) -> (15, 17)
    mask = np.zeros((30, 40), bool)
    mask[7, 7] = True
    assert remove_points_in_masks(rec, {"test_x.png": mask}) == 1
    assert sorted(rec.points3D) == [1, 5]
    mask = np.zeros((30, 40), bool)
    mask[15, 16] = True  # the pixel left of keypoint 3: not observed there
    mask[16, 17] = True  # the pixel below
    assert remove_points_in_masks(rec, {"test_x.png": mask}) == 0
    mask[15, 17] = True
    assert remove_points_in_masks(rec, {"test_x.png": mask, "unknown.png": mask}) == 1
    assert sorted(rec.points3D) == [1]


def test_handmade_scene_leaks_are_the_floor_under_the_box():
    rec = sb.box_reconstruction(sb.box_scene())
    leaked = leaked_point_ids(rec)
    X = np.array([rec.point3D(i).xyz for i in leaked])
    # every leaked floor point lies under the box footprint, and every footprint point seen by test views leaked
    assert np.all((np.abs(X[:, 0]) <= 0.5 + 1e-9) & (np.abs(X[:, 1]) <= 0.5 + 1e-9))
    under = [pid for pid, p in rec.points3D.items() if np.all(np.abs(p.xyz[:2]) < 0.5 - 1e-6)]
    assert set(under) <= set(leaked) and len(under) == 81  # 9 x 9 grid points strictly inside
    rep = remove_leaked_points(rec, min_inclusive_views=1, min_inclusive_angle_deg=0)
    assert rep.removed == len(leaked) and rep.points_after == rep.points_before - len(leaked)


def test_object_free_influence_closed_form():
    """Cameras on the x axis looking down +z (t = (0.1 i, 0, 0)); a point seen exactly by every view
    is not moved by the object-free ones; shifting the object-free observations moves it, and a point
    with one object-inclusive observation cannot be triangulated without them."""
    X = np.array([0.3, -0.2, 6.0])
    cam_x = [-0.1 * iid for iid in range(1, 6)]  # camera centres: C = -t
    kp = np.array([[50 * (X[0] - cx) / X[2] + 20, 50 * X[1] / X[2] + 15] for cx in cam_x])  # exact projections
    rec = pycolmap.Reconstruction()
    rec.add_camera_with_trivial_rig(pycolmap.Camera(model="PINHOLE", width=40, height=30, params=[50, 50, 20, 15], camera_id=1))
    for iid, name in enumerate(NAMES, start=1):
        pts = np.stack([kp[iid - 1]] * 4 + [kp[iid - 1] + [3.0, 0.0]])  # keypoints 0-3 exact, 4 shifted by 3 px
        rec.add_image_with_trivial_frame(pycolmap.Image(name=name, keypoints=pts, camera_id=1, image_id=iid),
                                         pycolmap.Rigid3d(pycolmap.Rotation3d(), np.array([0.1 * iid, 0, 0])))
    exact = rec.add_point3D(X, pycolmap.Track([pycolmap.TrackElement(i, 0) for i in range(1, 6)]))
    moved = rec.add_point3D(X, pycolmap.Track([pycolmap.TrackElement(i, 1) for i in (1, 2, 3)]
                                              + [pycolmap.TrackElement(i, 4) for i in (4, 5)]))
    train_only = rec.add_point3D(X, pycolmap.Track([pycolmap.TrackElement(i, 2) for i in (1, 2, 3)]))
    single = rec.add_point3D(X, pycolmap.Track([pycolmap.TrackElement(i, 3) for i in (1, 4, 5)]))
    shift = object_free_influence(rec, [exact, moved, train_only, single])
    assert shift[0] < 1e-9 and shift[2] == 0.0 and np.isnan(shift[3])
    # object-free rays shifted by 3 px: the joint triangulation moves towards them by a sizeable
    # fraction of the depth error those rays alone imply (baseline 0.1-0.5, depth 6)
    assert 0.05 < shift[1] < 6.0
    # relative: divided by the distance to the nearest object-inclusive camera (IMG_a at x = -0.1)
    rel = object_free_influence(rec, [moved], relative=True)
    assert abs(rel[0] - shift[1] / np.linalg.norm(X - [-0.1, 0, 0])) < 1e-12


def test_point_colours_come_from_object_inclusive_images_only(tmp_path):
    import cv2

    from dataset_tools.capture.leaks import recolor_from_inclusive_views

    rec = _rec(TRACKS)
    # IMG_a red, IMG_b blue, IMG_c green; the object-free views white (must not count)
    fill = {"IMG_a.png": (255, 0, 0), "IMG_b.png": (0, 0, 255), "IMG_c.png": (0, 255, 0), "test_x.png": (255, 255, 255), "test_y.png": (255, 255, 255)}
    for name, rgb in fill.items():
        img = np.zeros((30, 40, 3), np.uint8)
        img[:] = rgb[::-1]  # OpenCV writes BGR
        cv2.imwrite(str(tmp_path / name), img)
    assert recolor_from_inclusive_views(rec, tmp_path) > 0
    assert rec.point3D(1).color.tolist() == [128, 0, 128]  # mean of red (IMG_a) and blue (IMG_b)
    assert rec.point3D(3).color.tolist() == [255, 0, 0]  # IMG_a + test_x: red only
    assert rec.point3D(5).color.tolist() == [0, 255, 0]  # IMG_c + two test views: green only
    assert rec.point3D(2).color.tolist() == [0, 0, 0]  # test-only point: untouched (removal deletes it)
