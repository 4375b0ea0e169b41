"""The oracle segmenter: seeded SAM-like damage of ground-truth instance masks that keeps most of each
object; it reads gt/ by design and says so in every output; bad gt/ input is one line."""

from __future__ import annotations

import json

import numpy as np
import pytest
from segment_scenes import best_iou, two_blobs, write_scene

from inpaint360gs.cli import main
from inpaint360gs.core.errors import InputError
from inpaint360gs.io.images import write_labels
from inpaint360gs.io.scene import load_scene
from inpaint360gs.segment import get_segmenter, segment_stage
from inpaint360gs.segment.oracle import OracleConfig, damage


def instance_image() -> np.ndarray:
    """Three objects, 1 and 2 touching, 3 apart with a stray 3-px crumb."""
    gt = np.zeros((96, 128), np.uint8)
    gt[20:60, 10:50] = 1
    gt[30:70, 50:80] = 2
    gt[40:80, 95:120] = 3
    gt[5, 5:8] = 3
    return gt


def _rng(seed: int) -> np.random.Generator:
    return np.random.default_rng(seed)


def test_damage_is_seeded():
    gt = instance_image()
    a = damage(gt, OracleConfig(), _rng(4))
    assert np.array_equal(a, damage(gt, OracleConfig(), _rng(4)))
    assert any(not np.array_equal(a, damage(gt, OracleConfig(), _rng(s))) for s in range(5, 10))
    assert a.dtype == np.uint16


def test_damage_keeps_most_of_each_object_and_shuffles_ids():
    gt = instance_image()
    ious = {1: [], 2: [], 3: []}
    covered = {1: [], 2: [], 3: []}
    first_id, splits, merges = set(), 0, 0
    for s in range(60):
        ids = damage(gt, OracleConfig(), _rng(s))
        for k in ious:
            ious[k].append(best_iou(ids, gt == k))
            covered[k].append((ids[gt == k] > 0).mean())
        first_id.add(int(np.bincount(ids[gt == 3]).argmax()))
        n = int(ids.max())
        splits += n > 3
        merges += n < 3 and (np.bincount(ids[gt == 1]).argmax() == np.bincount(ids[gt == 2]).argmax())
        assert ids[5, 5:8].max() == 0  # the 3-px crumb is a missed small part
    # 25-40 px wide objects: a 2-px edge shift alone costs ~20% IoU; a split or merge halves it
    assert all(np.mean(v) > 0.65 and np.median(v) > 0.75 for v in ious.values())
    # erosion by <= 2 px (and a neighbour dilated over it) is the most an object loses
    assert all(min(v) > 0.7 and np.mean(v) > 0.9 for v in covered.values())
    assert len(first_id) >= 3  # ids are shuffled per view
    assert splits > 5 and merges > 2  # both kinds of damage happen at the default rates


def test_erosion_of_a_thin_object_keeps_the_share_a_disk_keeps():
    """A 4-px wide, 60-px long bar: its equivalent radius (8.7 px) allows a 1-px erosion at
    edge_rel 0.15 and 2 px at 0.25, but a 2-px erosion leaves nothing of it and 1 px half. The share
    rule (a disk eroded by edge_rel x its radius keeps (1 - edge_rel)^2) shrinks the radius until
    that share holds, else leaves the bar as it is; a disk is eroded as before."""
    from inpaint360gs.segment.oracle import _erode

    bar = np.zeros((40, 80), bool)
    bar[18:22, 10:70] = True
    assert _erode(bar, 2, (1 - 0.15) ** 2, 10).sum() == bar.sum()  # 1 px would take half: left as it was
    wide = np.zeros((40, 80), bool)
    wide[10:30, 10:70] = True  # 20 px wide: 1 px takes ~13%, 2 px ~26%, 3 px ~38%
    kept = _erode(wide, 3, (1 - 0.15) ** 2, 10).sum() / wide.sum()
    assert (1 - 0.15) ** 2 <= kept < 0.8  # the largest radius that keeps 72%: 2 px
    yy, xx = np.mgrid[:80, :80]
    disk = (yy - 40) ** 2 + (xx - 40) ** 2 <= 20**2
    import cv2

    two = cv2.erode(disk.astype(np.uint8), cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (5, 5))).astype(bool)
    assert np.array_equal(_erode(disk, 2, (1 - 0.15) ** 2, 10), two)  # 2 px of a 20-px disk: within the share
    for s in range(40):  # through damage(): the bar never loses more than a disk would
        ids = damage(bar.astype(np.uint8), OracleConfig(split_prob=0, merge_prob=0), _rng(s))
        assert (ids[bar] > 0).mean() >= (1 - 0.15) ** 2


def test_no_damage_settings_give_the_ground_truth_up_to_ids():
    gt = instance_image()
    gt[5, 5:8] = 0
    ids = damage(gt, OracleConfig(split_prob=0, merge_prob=0, edge_px=0), _rng(0))
    for k in (1, 2, 3):
        assert best_iou(ids, gt == k) == 1.0


def test_config_is_checked():
    with pytest.raises(InputError, match="split_prob"):
        OracleConfig(split_prob=1.5).validate()


@pytest.fixture(scope="module")
def scene_with_gt(tmp_path_factory):
    model, _ = two_blobs()
    root = write_scene(tmp_path_factory.mktemp("oracle") / "blobs", model)
    scene = load_scene(root)
    for v in scene.views:  # a stand-in ground truth: a box per view
        gt = np.zeros((v.camera.height, v.camera.width), np.uint8)
        gt[10:30, 10:30] = 1
        gt[15:40, 35:60] = 2
        write_labels(root / "gt" / "instance" / f"{v.stem}.png", gt)
    return root


def test_stage_with_the_oracle_labels_its_outputs(scene_with_gt, tmp_path):
    scene = load_scene(scene_with_gt)
    info = segment_stage(scene, None, tmp_path / "seg", get_segmenter("oracle", seed=3))
    meta = json.loads((tmp_path / "seg" / "segment.json").read_text())
    assert meta["segmenter"] == "oracle" and meta["reads_ground_truth"] is True and info["settings"]["seed"] == 3
    assert all(1 <= v["segments"] <= 4 for v in meta["views"].values())


def test_oracle_bad_ground_truth_is_one_line(scene_with_gt, tmp_path, capsys):
    ply = tmp_path / "unused.ply"
    ply.write_bytes(b"not read by the oracle")
    bad = scene_with_gt / "gt" / "instance" / "IMG_003.png"
    keep = bad.read_bytes()
    try:
        bad.write_bytes(b"garbage")
        assert main(["segment", str(scene_with_gt), str(ply), str(tmp_path / "o"), "--segmenter", "oracle", "--no-progress"]) == 2
        err = capsys.readouterr().err.strip()
        assert "IMG_003.png" in err and "cannot decode" in err and len(err.splitlines()) == 1
        bad.unlink()
        assert main(["segment", str(scene_with_gt), str(ply), str(tmp_path / "o"), "--segmenter", "oracle", "--no-progress"]) == 2
        assert "not found" in capsys.readouterr().err
    finally:
        bad.write_bytes(keep)
    assert main(["segment", str(scene_with_gt), str(ply), str(tmp_path / "o"), "--segmenter", "oracle", "--no-progress", "--seed", "2"]) == 0
    assert "from ground truth" in capsys.readouterr().out
