"""End to end: a reduced synthetic capture (images only) -> `build` -> poses, registration, leaks, validate.

The generator renders its reduced set of views (32 object-inclusive + 8 object-free); they are exported as raw photos
(no poses), a featureless photo that cannot register is added, and the build is scored against the
generator's true poses and visibility oracle. 256x192 rather than the 128x96 `--reduced` size: at
128x96 there are about 180 SIFT features per view of the floor-board scene; all 40 views register
but poses come out 1.03% / 0.73° off (measured), above the targets this test checks.
"""

from __future__ import annotations

import json

import cv2
import numpy as np
import pytest

from dataset_tools.capture.leaks import inclusive_triangulation_angles, inclusive_view_counts, object_free_influence
from dataset_tools.capture.pipeline import BuildConfig, build_dataset
from dataset_tools.capture.synth_export import export_raw_captures, leak_check, object_free_observations, score_build, to_truth_frame
from dataset_tools.capture.unseen import UnseenConfig, derive_unseen_masks, load_object_masks, mask_iou
from dataset_tools.capture.validate import validate_scene
from dataset_tools.cli import main as dataset_main
from inpaint360gs.core.errors import InputError
from inpaint360gs.io.colmap import read_model

pytestmark = pytest.mark.slow  # ~30 s: rendering the capture dominates


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    from dataset_tools.synth import generate_scene

    root = tmp_path_factory.mktemp("synthbuild")
    truth = generate_scene("cone", root / "truth", reduced=True, width=256, height=192)
    cap = export_raw_captures(truth, root / "captures", object_masks=True, unseen_masks=True)
    cv2.imwrite(str(cap / "with_objects" / "IMG_9999.png"), np.full((192, 256, 3), 128, np.uint8))  # no features
    out = root / "scene"
    report = build_dataset(cap, out, BuildConfig(downscale=(2,), unseen_masks=cap / "unseen_masks", progress=False))
    return truth, cap, out, report


def _counts(truth) -> tuple[int, int]:
    names = [p.name for p in (truth / "images").iterdir()]
    return len(names), sum(n.startswith("test_") for n in names)


def test_every_real_photo_registers_and_the_blank_one_is_reported(built):
    truth, cap, out, report = built
    n_all, n_free = _counts(truth)
    reg = report.registration
    assert reg["total"] == n_all + 1 and reg["registered"] == n_all
    assert reg["unregistered"] == {"IMG_9999.png": str(cap / "with_objects" / "IMG_9999.png")}
    names = sorted(p.name for p in (out / "images").iterdir())
    assert "IMG_9999.png" not in names and len(names) == n_all
    assert sum(n.startswith("test_") for n in names) == n_free  # object-free photos renamed back to test_*
    saved = json.loads((out / "build_report.json").read_text())
    assert saved["registration"]["unregistered"] == reg["unregistered"]
    assert saved["points"]["final"] == read_model(out / "sparse" / "0").num_points3D()


def test_pose_accuracy_after_sim3_alignment(built):
    truth, _, out, _ = built
    score = score_build(out, truth)
    assert score.registered == score.total == _counts(truth)[0]
    assert score.poses.center_err_max_pct <= 1.0, score.poses
    assert score.poses.rot_err_max_deg <= 0.5, score.poses


def test_undistorted_pinhole_output_and_downscaled_copies(built):
    _, _, out, report = built
    rec = read_model(out / "sparse" / "0")
    (cam,) = rec.cameras.values()
    assert cam.model_name == "PINHOLE" and report.output["undistorted"]
    w, h = cam.width, cam.height
    assert cv2.imread(str(out / "images" / "IMG_0000.png")).shape[:2] == (h, w)
    assert cv2.imread(str(out / "images_2" / "IMG_0000.png")).shape[:2] == (round(h / 2), round(w / 2))
    assert cv2.imread(str(out / "unseen_mask" / "test_0000.png"), 0).shape == (h, w)  # masks undistorted too


def test_no_point_without_an_object_inclusive_observation_and_validate_passes(built, capsys):
    truth, _, out, report = built
    assert report.points["leak_removal"]["points_after"] == report.points["final"]
    v = validate_scene(out)
    assert v.ok, v.format()
    assert dataset_main(["validate", str(out)]) == 0


def test_geometric_leak_check_against_the_generator(built):
    truth, _, out, report = built
    rec = read_model(out / "sparse" / "0")
    pids = list(rec.points3D)
    kept = leak_check(truth, to_truth_frame(rec, truth, np.array([rec.point3D(p).xyz for p in pids])))
    # Points the rule removed are the ones that can sit on the unseen floor; what remains flagged are
    # phantom points SfM triangulates from object-inclusive views at the object's occlusion contour
    # (inside its base, within a few cm of seen surfaces): a handful at most, and the object-free views
    # do not locate them: with or without their observations the point moves < 0.5% of its depth
    # (no information from the ground truth; measured <= 0.15% on all ten full-size scenes).
    assert kept.leaked.sum() <= max(3, 0.005 * len(kept.leaked)), kept.summary()
    flagged = [pids[i] for i in np.flatnonzero(kept.leaked)]
    shift = object_free_influence(rec, flagged, relative=True)
    assert np.all(shift < 0.005), (shift, object_free_observations(rec, flagged))
    # and every kept point is triangulated by the object-inclusive views alone (>= 2 views, >= 1.5°)
    counts, angles = inclusive_view_counts(rec), inclusive_triangulation_angles(rec)
    assert min(counts.values()) >= 2 and min(angles.values()) >= 1.5
    assert report.leaked_xyz.shape == (report.points["leak_removal"]["removed"], 3)


def test_unseen_masks_derived_from_object_masks_match_the_generator(built, tmp_path):
    truth, cap, out, _ = built
    # the object masks were drawn on the original photos; they are undistorted like the photos
    masks = load_object_masks(out, cap / "object_masks")
    derived = derive_unseen_masks(out, masks, UnseenConfig())
    exact = {n: cv2.imread(str(out / "unseen_mask" / n), 0) > 127 for n in derived}
    ious = [mask_iou(derived[n], exact[n]) for n in derived]
    assert len(ious) == _counts(truth)[1]
    assert np.mean(ious) >= 0.8, ious  # measured 0.90 (0.63-0.96); limits in dataset_tools/capture/README.md


def test_cli_sequential_matcher_one_folder_layout(built, tmp_path, capsys):
    truth, cap, _, _ = built
    # one-folder layout: object-free photos carry the test_ prefix
    one = tmp_path / "one"
    one.mkdir()
    for p in (cap / "with_objects").glob("IMG_0*.png"):
        (one / p.name).write_bytes(p.read_bytes())
    for p in (cap / "without_objects").iterdir():
        (one / f"test_{p.name}").write_bytes(p.read_bytes())
    out = tmp_path / "seq"
    args = ["build", str(one), str(out), "--matcher", "sequential", "--overlap", "4", "--cross-pairs", "8",
            "--camera-model", "SIMPLE_PINHOLE", "--no-progress"]
    assert dataset_main(args) == 0
    text = capsys.readouterr().out
    n_all = _counts(truth)[0]
    assert f"registered {n_all}/{n_all}" in text and "matcher sequential" in text
    score = score_build(out, truth)
    assert score.poses.passes(), score.poses
    assert cv2.imread(str(out / "images" / "IMG_0000.png")).shape[:2] == (192, 256)  # pinhole: no crop


def test_synthetic_scene_rebuilt_through_colmap_keeps_ground_truth(built, tmp_path, capsys):
    from dataset_tools.capture.synth_colmap import build_synthetic_with_colmap

    truth, _, _, _ = built
    out = tmp_path / "cone_colmap"
    assert dataset_main(["synth-colmap", str(truth), str(out), "--no-progress"]) == 0
    assert "rotation error max" in capsys.readouterr().out
    assert validate_scene(out).ok
    frame = json.loads((out / "gt" / "colmap_frame.json").read_text())
    assert frame["pose_accuracy"]["center_err_max_pct"] <= 1.0
    meta = json.loads((out / "scene.json").read_text())
    assert meta["removal_targets"] == [1] and meta["provenance"]["poses"] == "colmap"
    for n in sorted(p.name for p in (truth / "unseen_mask").iterdir()):  # exact masks, unchanged (no crop)
        assert (cv2.imread(str(out / "unseen_mask" / n), 0) == cv2.imread(str(truth / "unseen_mask" / n), 0)).all()
    with pytest.raises(InputError, match="--overwrite"):
        build_synthetic_with_colmap(truth, out)  # exists: refuses without overwrite


def test_an_unplaced_object_free_photo_is_left_out_of_a_rebuilt_scene_and_named(built, tmp_path):
    """An object-free photo SfM cannot place (here: featureless) is a test view the scene can do
    without: the rebuild keeps every training view, drops that test view with its unseen mask, names
    it in gt/colmap_frame.json, and still validates. Asked for every test view, the build stops
    naming it."""
    import shutil

    from dataset_tools.capture.synth_colmap import build_synthetic_with_colmap

    truth, _, _, _ = built
    copy = tmp_path / "truth"
    shutil.copytree(truth, copy)
    blank = sorted(p.name for p in (copy / "images").iterdir() if p.name.startswith("test_"))[3]
    shape = cv2.imread(str(copy / "images" / blank)).shape
    cv2.imwrite(str(copy / "images" / blank), np.full(shape, 128, np.uint8))
    n_free = _counts(truth)[1]
    out = tmp_path / "scene"
    report = build_synthetic_with_colmap(copy, out, BuildConfig(progress=False), min_test_registered=0.75)
    assert sorted(report.registration["unregistered"]) == [blank]
    names = {p.name for p in (out / "images").iterdir()}
    assert blank not in names and len(names) == _counts(truth)[0] - 1
    assert sum(n.startswith("test_") for n in names) == n_free - 1
    assert not (out / "unseen_mask" / blank).exists() and len(list((out / "unseen_mask").iterdir())) == n_free - 1
    assert json.loads((out / "gt" / "colmap_frame.json").read_text())["unplaced_test_views"] == [blank]
    assert validate_scene(out).ok
    with pytest.raises(InputError, match=f"only {n_free - 1} of {n_free} object-free photos registered .*{blank}"):
        build_synthetic_with_colmap(copy, tmp_path / "strict", BuildConfig(progress=False), min_test_registered=1.0)
    assert not (tmp_path / "strict").exists()


def test_the_test_view_rule_refuses_an_unplaced_training_photo_and_too_few_test_views(tmp_path):
    from dataset_tools.capture.pipeline import BuildReport
    from dataset_tools.capture.synth_colmap import _check_test_views_placed, build_synthetic_with_colmap

    def report(unplaced, n_free=16):
        return BuildReport(out="x", captures={"object_free": n_free}, registration={"unregistered": dict.fromkeys(unplaced, "src")},
                           points={}, output={}, timings={})

    assert _check_test_views_placed(report([]), 0.9, tmp_path) == []
    assert _check_test_views_placed(report(["test_0005.png"]), 0.9, tmp_path) == ["test_0005.png"]  # 15 of 16
    with pytest.raises(InputError, match="only 14 of 16 object-free photos registered \\(needs 15\\)"):
        _check_test_views_placed(report(["test_0001.png", "test_0005.png"]), 0.9, tmp_path)
    with pytest.raises(InputError, match="1 object-inclusive photo\\(s\\) could not be placed .*IMG_0004.png"):
        _check_test_views_placed(report(["IMG_0004.png", "test_0005.png"]), 0.0, tmp_path)
    with pytest.raises(InputError, match="fraction"):
        build_synthetic_with_colmap(tmp_path, tmp_path / "out", min_test_registered=1.5)


def test_points_observed_inside_given_unseen_masks_can_be_removed(built, tmp_path):
    truth, cap, _, _ = built
    grown = tmp_path / "grown"
    grown.mkdir()
    for p in (cap / "unseen_masks").iterdir():  # grow the exact masks so that they reach observed floor points
        m = cv2.imread(str(p), 0)
        cv2.imwrite(str(grown / p.name), cv2.dilate(m, np.ones((31, 31), np.uint8)))
    out = tmp_path / "scene"
    report = build_dataset(cap, out, BuildConfig(unseen_masks=grown, remove_unseen_points=True, progress=False))
    removed = report.points["unseen_mask_removed"]
    assert removed > 0
    assert report.points["final"] == report.points["leak_removal"]["points_after"] - removed
    rec = read_model(out / "sparse" / "0")
    for iid in rec.reg_image_ids():
        im = rec.image(iid)
        if not im.name.startswith("test_"):
            continue
        mask = cv2.imread(str(out / "unseen_mask" / im.name), 0) > 127
        for p2d in im.points2D:
            if p2d.has_point3D():
                x, y = int(p2d.xy[0]), int(p2d.xy[1])
                assert not mask[y, x]


def test_photos_with_the_object_only_build_a_scene_without_ground_truth(built, tmp_path, capsys):
    """The method's real use: only photos with the object. build -> validate -> evaluate says no ground truth."""
    from inpaint360gs.cli import main as method_main
    from inpaint360gs.core.layout import NO_GROUND_TRUTH
    from inpaint360gs.io.scene import load_scene

    truth, cap, _, _ = built
    own = tmp_path / "own"
    (own / "with_objects").mkdir(parents=True)  # no without_objects/ at all
    for p in sorted((cap / "with_objects").glob("IMG_0*.png")):
        (own / "with_objects" / p.name).write_bytes(p.read_bytes())
    out = tmp_path / "scene"
    assert dataset_main(["build", str(own), str(out), "--no-progress"]) == 0
    text = capsys.readouterr().out
    n_in = _counts(truth)[0] - _counts(truth)[1]
    assert f"registered {n_in}/{n_in}" in text and "0 object-free" in text and "no ground truth" in text
    assert not list((out / "images").glob("test_*")) and not (out / "unseen_mask").exists()
    meta = json.loads((out / "scene.json").read_text())
    assert meta["ground_truth"] is False and "object-inclusive photos only" in meta["ground_truth_reason"]
    report = json.loads((out / "build_report.json").read_text())
    assert report["output"]["num_test_images"] == 0 and report["output"]["ground_truth"] is False
    score = score_build(out, truth)  # poses as good as with the object-free photos
    assert score.poses.center_err_max_pct <= 1.0 and score.poses.rot_err_max_deg <= 0.5, score.poses

    v = validate_scene(out)
    assert v.ok, v.format()
    assert dataset_main(["validate", str(out)]) == 0
    scene = load_scene(out)
    assert scene.test_views == [] and not scene.has_ground_truth and len(scene.train_views) > 0

    renders = tmp_path / "renders"
    renders.mkdir()
    assert method_main(["evaluate", str(renders), str(out), str(tmp_path / "m.json")]) == 0
    assert NO_GROUND_TRUTH in capsys.readouterr().out
    assert json.loads((tmp_path / "m.json").read_text())["mean"]["psnr"] is None


def test_too_few_registered_photos_stop_the_build_naming_them(built, tmp_path, capsys):
    """Two noise photos among 12 real ones: 12/14 < 90 % registered is refused with one line naming the
    two; a lower --min-registered keeps the model and reports them as skipped."""
    from dataset_tools.capture.posecheck import reconstruction_poses

    _, cap, _, _ = built
    root = tmp_path / "cap"
    (root / "with_objects").mkdir(parents=True)
    for p in sorted((cap / "with_objects").glob("IMG_0*.png"))[:12]:  # a 135° arc of the orbit
        (root / "with_objects" / p.name).write_bytes(p.read_bytes())
    rng = np.random.default_rng(7)
    noise = ["IMG_5000.png", "IMG_5001.png"]  # unrelated pictures: nothing to match
    for n in noise:
        cv2.imwrite(str(root / "with_objects" / n), rng.integers(0, 256, (192, 256, 3), dtype=np.uint8))
    out = tmp_path / "scene"
    for flags in ([], ["--require-all-registered"]):
        assert dataset_main(["build", str(root), str(out), "--no-progress", *flags]) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1, err
        line = err[0]
        assert "only 12 of 14 photos registered" in line and "could not place" in line, line
        assert all(f"with_objects/{n}" in line for n in noise) and "IMG_0000" not in line, line
        assert ("--require-all-registered needs 14" if flags else "--min-registered 0.9 needs 13") in line, line
        assert not out.exists() and not [p for p in tmp_path.iterdir() if p.name.startswith(".scene")]
    assert dataset_main(["build", str(root), str(out), "--no-progress", "--min-registered", "0.85"]) == 0
    text = capsys.readouterr().out
    assert "registered 12/14" in text and all(f"not registered (skipped): {root / 'with_objects' / n}" in text for n in noise)
    assert sorted(reconstruction_poses(read_model(out / "sparse" / "0"))) == sorted(p.name for p in (cap / "with_objects").glob("IMG_0*.png"))[:12]


def test_working_size_sfm_gives_full_size_cameras_and_the_same_poses(built, tmp_path):
    """SfM on copies at 230/256 (230x172, the height rounded): the camera is for the 256x192 photos
    (focal as the generator's, principal point at their centre), the scene keeps full-size images, and
    the poses agree with the full-size build's up to a similarity and with the generator's."""
    from dataset_tools.capture.colmap import SfMConfig
    from dataset_tools.capture.posecheck import pose_accuracy, reconstruction_poses

    truth, cap, full_out, full_report = built
    out = tmp_path / "scene"
    report = build_dataset(cap, out, BuildConfig(sfm=SfMConfig(sfm_max_size=230), progress=False))
    reg = report.registration
    s = 230 / 256
    assert reg["sfm_size"] == [230, 172] and full_report.registration["sfm_size"] == [256, 192]
    assert reg["registered"] == full_report.registration["registered"]
    cam = reg["camera"]  # the SfM camera, before undistortion
    assert cam["model"] == "SIMPLE_RADIAL" and (cam["width"], cam["height"]) == (256, 192)
    f_true = json.loads((truth / "gt" / "cameras.json").read_text())["fx"]
    assert abs(cam["params"][0] / f_true - 1) < 0.01, (cam["params"], f_true)  # not 230/256 of it
    assert np.allclose(cam["params"][1:3], [128.0, 96.0], rtol=0, atol=1e-9), cam["params"]  # not 172 / 2 / s
    # observations mapped back too: the error in full-size pixels is the working size's / s
    assert abs(reg["mean_reprojection_error_px"] - reg["sfm_reprojection_error_px"] / s) < 1e-6
    assert reg["mean_reprojection_error_px"] < 1.0
    rec = read_model(out / "sparse" / "0")
    (pin,) = rec.cameras.values()
    assert abs(pin.width - 256) <= 4 and abs(pin.height - 192) <= 4  # undistorted full-size photos
    assert cv2.imread(str(out / "images" / "IMG_0000.png")).shape[:2] == (pin.height, pin.width)
    agree = pose_accuracy(reconstruction_poses(rec), reconstruction_poses(read_model(full_out / "sparse" / "0")), orbit_radius=None)
    assert agree.matched == reg["registered"] and agree.center_err_max_pct <= 1.0 and agree.rot_err_max_deg <= 0.5, agree
    assert score_build(out, truth).poses.passes(), score_build(out, truth).poses


def test_photo_names_with_spaces_and_other_scripts_are_built(built, tmp_path):
    """COLMAP's pair list is space-separated: a photo named ``IMG 0003.png`` was never matched and
    was reported only as "not registered". Every photo is kept, under its own name."""
    truth, cap, _, _ = built
    one = tmp_path / "one"
    one.mkdir()
    renamed = {"IMG_0003.png": "IMG 0003.png", "IMG_0005.png": "IMG_ü0005.png", "IMG_0007.png": "photo (7) ;$x.png"}
    for p in sorted((cap / "with_objects").glob("IMG_0*.png")):
        (one / renamed.get(p.name, p.name)).write_bytes(p.read_bytes())
    out = tmp_path / "scene"
    report = build_dataset(one, out, BuildConfig(progress=False))
    n = len(list(one.iterdir()))
    assert report.registration["registered"] == report.registration["total"] == n, report.registration
    names = {im.name for im in read_model(out / "sparse" / "0").images.values()}
    assert set(renamed.values()) <= names and set(renamed.values()) <= {p.name for p in (out / "images").iterdir()}
    checks = {c.name: c.status for c in validate_scene(out).checks}
    assert checks["registration"] == checks["inside the scene"] == checks["distinct stems"] == "pass", checks
