"""`validate` on a good hand-built scene folder and on one broken copy per rule; CLI exit codes."""

from __future__ import annotations

import shutil
from pathlib import Path

import cv2
import numpy as np
import pycolmap
import pytest

import scene_builder as sb
from dataset_tools.capture.layout import write_downscaled
from dataset_tools.capture.leaks import remove_leaked_points
from dataset_tools.capture.validate import validate_scene
from dataset_tools.cli import main as dataset_main


@pytest.fixture(scope="module")
def good_scene(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("validate") / "good"
    scene = sb.box_scene()
    rec = sb.write_box_scene(scene, root)
    remove_leaked_points(rec)
    rec.write(root / "sparse" / "0")
    write_downscaled(root / "images", sorted(p.name for p in (root / "images").iterdir()), root, [2])
    return root


def _copy(good: Path, tmp_path: Path) -> Path:
    dst = tmp_path / "scene"
    shutil.copytree(good, dst)
    return dst


def test_good_scene_passes(good_scene, capsys):
    report = validate_scene(good_scene)
    assert report.ok, report.format()
    assert {c.name for c in report.checks} >= {"split", "sparse/0", "camera model", "registration", "image files",
                                                "images_2/", "unseen masks", "point leaks", "scene.json"}
    assert dataset_main(["validate", str(good_scene)]) == 0
    out = capsys.readouterr().out
    assert "=> PASS" in out and "[FAIL]" not in out


def _break_leak(s: Path) -> None:
    rec = sb.box_reconstruction(sb.box_scene())  # the model before leak removal
    rec.write(s / "sparse" / "0")


def _break_missing_mask(s: Path) -> None:
    (s / "unseen_mask" / "test_001.png").unlink()


def _break_mask_size(s: Path) -> None:
    cv2.imwrite(str(s / "unseen_mask" / "test_000.png"), np.zeros((60, 80), np.uint8))


def _break_unregistered(s: Path) -> None:
    cv2.imwrite(str(s / "images" / "IMG_999.png"), np.zeros((120, 160, 3), np.uint8))


def _break_distortion(s: Path) -> None:
    rec = pycolmap.Reconstruction(s / "sparse" / "0")
    cam = rec.cameras[1]
    cam.model = pycolmap.Camera(model="SIMPLE_RADIAL", width=160, height=120, params=[110, 80, 60, 0.01]).model
    cam.params = [110, 80, 60, 0.01]
    rec.write(s / "sparse" / "0")


def _break_no_test(s: Path) -> None:
    for p in (s / "images").glob("test_*"):
        p.unlink()


def _break_sparse(s: Path) -> None:
    (s / "sparse" / "0" / "points3D.bin").write_bytes(b"\x05\x00")


def _break_sparse_count(s: Path) -> None:
    import struct

    (s / "sparse" / "0" / "points3D.bin").write_bytes(struct.pack("<Q", 10**12) + bytes(64))  # pycolmap would allocate for minutes


def _break_missing_sparse(s: Path) -> None:
    shutil.rmtree(s / "sparse")


def _break_corrupt_image(s: Path) -> None:
    p = s / "images" / "IMG_003.png"
    p.write_bytes(p.read_bytes()[:100])


def _break_downscaled(s: Path) -> None:
    cv2.imwrite(str(s / "images_2" / "IMG_001.png"), np.zeros((61, 80, 3), np.uint8))


def _break_image_size(s: Path) -> None:
    cv2.imwrite(str(s / "images" / "IMG_002.png"), np.zeros((100, 160, 3), np.uint8))


def _break_scene_json(s: Path) -> None:
    (s / "scene.json").write_text("{not json")


# case -> (how to break the good scene, the checks that must then fail: exactly these)
BREAKS = {
    "leaked point": (_break_leak, {"point leaks"}),
    "missing unseen mask": (_break_missing_mask, {"unseen masks"}),
    "unseen mask size": (_break_mask_size, {"unseen masks"}),
    "unregistered image": (_break_unregistered, {"registration"}),
    "distortion model": (_break_distortion, {"camera model"}),
    "no test_ views": (_break_no_test, {"split", "registration", "unseen masks"}),  # their cameras and masks lose their files too
    "corrupt points3D.bin": (_break_sparse, {"sparse/0"}),
    "garbage count in points3D.bin": (_break_sparse_count, {"sparse/0"}),
    "missing sparse/": (_break_missing_sparse, {"sparse/0"}),
    "corrupt image": (_break_corrupt_image, {"image files"}),
    "downscaled size": (_break_downscaled, {"images_2/"}),
    "image size": (_break_image_size, {"image files"}),
    "scene.json": (_break_scene_json, {"scene.json"}),
}


@pytest.mark.parametrize("case", sorted(BREAKS))
def test_each_broken_rule_fails_its_check(good_scene, tmp_path, capsys, case):
    s = _copy(good_scene, tmp_path)
    breaker, expected = BREAKS[case]
    breaker(s)
    report = validate_scene(s)
    assert not report.ok
    assert {c.name for c in report.failed()} == expected, report.format()
    assert dataset_main(["validate", str(s)]) == 2
    out, err = capsys.readouterr()
    assert "=> FAIL" in out and len(err.splitlines()) == 1 and all(name in err for name in expected)


def test_unseen_masks_optional_flag_and_json(good_scene, tmp_path, capsys):
    s = _copy(good_scene, tmp_path)
    shutil.rmtree(s / "unseen_mask")
    assert not validate_scene(s).ok
    assert validate_scene(s, require_unseen_masks=False).ok
    js = tmp_path / "report.json"
    assert dataset_main(["validate", str(s), "--no-unseen-masks", "--json", str(js)]) == 0
    import json

    assert json.loads(js.read_text())["ok"] is True


def test_missing_folder_fails_cleanly(tmp_path, capsys):
    assert dataset_main(["validate", str(tmp_path / "nope")]) == 2
    assert "folder not found" in capsys.readouterr().err


# --- a scene without ground truth (object-inclusive photos only; docs/architecture.md, "Scene format") ---


def _set_scene_json(s: Path, **entries) -> None:
    import json

    data = json.loads((s / "scene.json").read_text())
    data.update(entries)
    for k in [k for k, v in entries.items() if v is None]:
        del data[k]
    (s / "scene.json").write_text(json.dumps(data))


@pytest.fixture(scope="module")
def no_gt_scene(tmp_path_factory) -> Path:
    """The box scene photographed with the box only: no test_ views, no unseen_mask/, scene.json says so."""
    root = tmp_path_factory.mktemp("validate") / "no_gt"
    rec = sb.write_box_scene(sb.box_scene(n_test=0), root)
    remove_leaked_points(rec)
    rec.write(root / "sparse" / "0")
    _set_scene_json(root, ground_truth=False, ground_truth_reason="object-inclusive photos only")
    return root


def test_scene_without_ground_truth_passes_when_scene_json_says_so(no_gt_scene, capsys):
    assert not (no_gt_scene / "unseen_mask").exists()
    assert not list((no_gt_scene / "images").glob("test_*"))
    report = validate_scene(no_gt_scene)
    assert report.ok, report.format()
    checks = {c.name: c for c in report.checks}
    assert "0 test_ views" in checks["split"].detail and "ground_truth false" in checks["split"].detail
    assert {"registration", "image files", "distinct images", "point leaks", "unseen masks"} <= set(checks)
    assert dataset_main(["validate", str(no_gt_scene)]) == 0
    assert "=> PASS" in capsys.readouterr().out


def _no_gt_undeclared(s: Path) -> None:
    _set_scene_json(s, ground_truth=None, ground_truth_reason=None)


def _no_gt_not_bool(s: Path) -> None:
    _set_scene_json(s, ground_truth="no")


def _no_gt_stray_unseen_mask(s: Path) -> None:
    (s / "unseen_mask").mkdir()
    cv2.imwrite(str(s / "unseen_mask" / "IMG_001.png"), np.zeros((120, 160), np.uint8))


def _no_gt_duplicate_photo(s: Path) -> None:
    shutil.copyfile(s / "images" / "IMG_002.png", s / "images" / "IMG_005.png")


# case -> (how to break the scene without ground truth, the checks that must then fail): every other rule still applies
NO_GT_BREAKS = {
    "no test_ views and scene.json silent": (_no_gt_undeclared, {"split"}),
    "ground_truth not a boolean": (_no_gt_not_bool, {"scene.json", "split"}),
    "unseen mask without a test_ view": (_no_gt_stray_unseen_mask, {"unseen masks"}),
    "duplicate photo": (_no_gt_duplicate_photo, {"distinct images"}),
    "unregistered image": (_break_unregistered, {"registration"}),
    "distortion model": (_break_distortion, {"camera model"}),
    "corrupt image": (_break_corrupt_image, {"image files"}),
}


@pytest.mark.parametrize("case", sorted(NO_GT_BREAKS))
def test_scene_without_ground_truth_keeps_every_other_check(no_gt_scene, tmp_path, case):
    s = _copy(no_gt_scene, tmp_path)
    breaker, expected = NO_GT_BREAKS[case]
    breaker(s)
    report = validate_scene(s)
    assert {c.name for c in report.failed()} == expected, report.format()


def test_ground_truth_false_with_test_views_fails(good_scene, tmp_path):
    s = _copy(good_scene, tmp_path)
    _set_scene_json(s, ground_truth=False)
    report = validate_scene(s)
    assert {c.name for c in report.failed()} == {"split"}, report.format()
    assert "yet test_ views exist" in report.failed()[0].detail
