"""Unseen masks: geometric derivation on an exact hand-built scene, import of the user's masks, the CLI."""

from __future__ import annotations

import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest

import scene_builder as sb
from dataset_tools.capture.leaks import remove_leaked_points
from dataset_tools.capture.unseen import (
    UnseenConfig,
    _views,
    derive_unseen_masks,
    import_unseen_masks,
    mask_iou,
    sparse_depth,
)
from dataset_tools.capture.validate import validate_scene
from dataset_tools.cli import main as dataset_main
from inpaint360gs.core.errors import InputError


@pytest.fixture(scope="module")
def scene(tmp_path_factory):
    """Hand-built scene folder (leaks removed, unseen_mask/ taken away) plus its exact geometry."""
    root = tmp_path_factory.mktemp("unseen") / "scene"
    geo = sb.box_scene()
    rec = sb.write_box_scene(geo, root)
    remove_leaked_points(rec)
    rec.write(root / "sparse" / "0")
    exact = {p.name: cv2.imread(str(p), 0) > 127 for p in (root / "unseen_mask").iterdir()}
    shutil.rmtree(root / "unseen_mask")
    masks_dir = root.parent / "object_masks"
    masks_dir.mkdir()
    for cam in geo.cameras:
        if not cam.name.startswith("test_"):
            cv2.imwrite(str(masks_dir / cam.name), sb.box_mask(cam).astype(np.uint8) * 255)
    return root, geo, exact, masks_dir


def _copy(root: Path, tmp_path: Path) -> Path:
    dst = tmp_path / "scene"
    shutil.copytree(root, dst)
    return dst


def test_sparse_depth_is_exact_on_a_plane(scene):
    root, geo, _, _ = scene
    from inpaint360gs.io.colmap import read_model

    views = _views(read_model(root / "sparse" / "0"), max_err=2.0)
    tv = views["test_000.png"]
    depth = sparse_depth(tv)
    cam = next(c for c in geo.cameras if c.name == "test_000.png")
    jj, ii = np.meshgrid(np.arange(geo.width) + 0.5, np.arange(geo.height) + 0.5)
    rays = np.stack([jj, ii, np.ones_like(jj)], -1) @ np.linalg.inv(geo.K).T  # camera-frame, z = 1
    # floor z = 0: with x_cam = R X + t and n = R e_z, n . x_cam = n . t, so z = (n . t) / (n . ray)
    R, t = sb.pose(cam)
    n_cam = R @ np.array([0.0, 0.0, 1.0])
    z_true = (n_cam @ t) / (rays @ n_cam)
    assert (z_true > 0).all()
    # inside the convex hull of the observed points the linear inverse-depth interpolation is exact
    hull = cv2.convexHull(tv.obs_xy.astype(np.float32))
    inside = np.array([[cv2.pointPolygonTest(hull, (float(x), float(y)), False) > 0 for x in jj[0]] for y in ii[:, 0]])
    rel = np.abs(depth - z_true) / z_true
    assert inside.mean() > 0.3
    assert rel[inside].max() < 1e-9


def test_derived_masks_match_exact_occlusion(scene):
    root, geo, exact, masks_dir = scene
    masks = {p.name: cv2.imread(str(p), 0) > 127 for p in masks_dir.iterdir()}
    derived = derive_unseen_masks(root, masks, UnseenConfig(mask_dilate_px=0))
    assert sorted(derived) == sorted(exact) == ["test_000.png", "test_001.png"]
    for name in derived:
        assert exact[name].sum() > 300  # a real hole, not an empty mask
        assert mask_iou(derived[name], exact[name]) > 0.95
    # dilating the object masks only grows the result
    grown = derive_unseen_masks(root, masks, UnseenConfig(mask_dilate_px=3))
    for name in derived:
        assert (grown[name] >= derived[name]).all() and grown[name].sum() > derived[name].sum()


def test_derivation_needs_a_mask_of_the_right_size_for_every_training_view(scene):
    root, _, _, masks_dir = scene
    masks = {p.name: cv2.imread(str(p), 0) > 127 for p in masks_dir.iterdir()}
    missing = dict(masks)
    missing.pop("IMG_003.png")
    with pytest.raises(InputError, match="IMG_003.png"):
        derive_unseen_masks(root, missing)
    wrong = dict(masks)
    wrong["IMG_002.png"] = np.zeros((10, 10), bool)
    with pytest.raises(InputError, match="10x10"):
        derive_unseen_masks(root, wrong)


def test_cli_derive_then_validate(scene, tmp_path, capsys):
    root, _, exact, masks_dir = scene
    s = _copy(root, tmp_path)
    assert dataset_main(["unseen-masks", str(s), "--object-masks", str(masks_dir)]) == 0
    assert "wrote 2 unseen masks" in capsys.readouterr().out
    for name, m in exact.items():
        got = cv2.imread(str(s / "unseen_mask" / name), 0)
        assert set(np.unique(got)) <= {0, 255} and mask_iou(got > 127, m) > 0.95
    assert validate_scene(s).ok
    # a second run must not silently replace the masks
    assert dataset_main(["unseen-masks", str(s), "--object-masks", str(masks_dir)]) == 2
    assert "--overwrite" in capsys.readouterr().err
    assert dataset_main(["unseen-masks", str(s), "--object-masks", str(masks_dir), "--overwrite"]) == 0


def test_cli_missing_object_mask_is_one_line(scene, tmp_path, capsys):
    root, _, _, masks_dir = scene
    s = _copy(root, tmp_path)
    partial = tmp_path / "partial"
    shutil.copytree(masks_dir, partial)
    (partial / "IMG_005.png").unlink()
    assert dataset_main(["unseen-masks", str(s), "--object-masks", str(partial)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no object mask for IMG_005.png" in err[0]
    assert not (s / "unseen_mask").exists()


def test_import_checks_names_and_sizes(scene, tmp_path, capsys):
    root, _, exact, _ = scene
    s = _copy(root, tmp_path)
    user = tmp_path / "user_masks"
    user.mkdir()
    cv2.imwrite(str(user / "test_000.png"), exact["test_000.png"].astype(np.uint8) * 255)
    cv2.imwrite(str(user / "001.jpg"), exact["test_001.png"].astype(np.uint8) * 200)  # named like the raw photo
    cv2.imwrite(str(user / "extra.png"), np.zeros((5, 5), np.uint8))
    masks, ignored = import_unseen_masks(s, user)
    assert sorted(masks) == ["test_000", "test_001"] and ignored == ["extra.png"]
    assert (masks["test_000"] == exact["test_000.png"]).all()
    assert dataset_main(["unseen-masks", str(s), "--import", str(user)]) == 0
    out = capsys.readouterr().out
    assert "ignored" in out and "extra.png" in out
    assert validate_scene(s).ok

    (user / "001.jpg").unlink()
    with pytest.raises(InputError, match="no unseen mask for test_001.png"):
        import_unseen_masks(s, user)
    cv2.imwrite(str(user / "test_001.png"), np.zeros((60, 80), np.uint8))
    with pytest.raises(InputError) as e:
        import_unseen_masks(s, user)
    assert e.value.path == user / "test_001.png" and "80x60" in str(e.value)


def test_read_mask_conventions(tmp_path):
    from dataset_tools.capture.layout import read_mask

    m = np.zeros((6, 8), np.uint8)
    m[2:4, 3:6] = 1
    cv2.imwrite(str(tmp_path / "label01.png"), m)  # 0/1 labels (SPIn-NeRF style)
    cv2.imwrite(str(tmp_path / "mask255.png"), m * 255)
    cv2.imwrite(str(tmp_path / "gray.png"), m * 100 + 20)  # 20/120: nothing above half range
    rgb = np.dstack([m * 0, m * 255, m * 0])
    cv2.imwrite(str(tmp_path / "rgb.png"), rgb)
    cv2.imwrite(str(tmp_path / "m16.png"), m.astype(np.uint16) * 65535)
    for name in ("label01.png", "mask255.png", "rgb.png", "m16.png"):
        assert (read_mask(tmp_path / name) == m.astype(bool)).all(), name
    assert not read_mask(tmp_path / "gray.png").any()
