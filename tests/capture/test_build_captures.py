"""Capture discovery and every bad-input case of `build`: one-line errors naming the file, nothing written."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from dataset_tools.capture.captures import CaptureConfig, collect_captures
from dataset_tools.cli import main as dataset_main
from inpaint360gs.core.errors import InputError


def _img(path: Path, w: int = 32, h: int = 24, seed: int = 0) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(seed)
    assert cv2.imwrite(str(path), rng.integers(0, 256, (h, w, 3), dtype=np.uint8))
    return path


def _two_folders(root: Path, n_in: int = 4, n_free: int = 2, ext: str = ".png") -> Path:
    for i in range(n_in):
        _img(root / "with_objects" / f"IMG_{i:03d}{ext}", seed=i)
    for i in range(n_free):
        _img(root / "without_objects" / f"IMG_{100 + i:03d}{ext}", seed=100 + i)
    return root


def _cli_fails(args: list[str], capsys) -> str:
    """Run the CLI, expect the one-line error exit (2), return that line."""
    assert dataset_main(args) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1, err
    return err[0]


def test_two_folder_layout_renames_object_free_to_test(tmp_path):
    root = _two_folders(tmp_path / "cap")
    (root / "notes.txt").write_text("x")
    (root / "with_objects" / "readme.md").write_text("x")
    cs = collect_captures(root)
    assert cs.layout == "two-folders" and (cs.width, cs.height) == (32, 24)
    assert [c.out_name for c in cs.object_inclusive] == [f"IMG_{i:03d}.png" for i in range(4)]
    assert [c.out_name for c in cs.object_free] == ["test_IMG_100.png", "test_IMG_101.png"]
    assert set(cs.skipped) == {str(root / "notes.txt"), str(root / "with_objects" / "readme.md")}


def test_one_folder_layout_uses_test_prefix(tmp_path):
    root = tmp_path / "cap"
    for i in range(3):
        _img(root / f"a_{i}.jpg", seed=i)
    _img(root / "test_b.jpg", seed=9)
    _img(root / "test_c.jpg", seed=10)
    cs = collect_captures(root)
    assert cs.layout == "one-folder"
    assert [c.out_name for c in cs.object_free] == ["test_b.jpg", "test_c.jpg"]
    assert len(cs.object_inclusive) == 3
    cs2 = collect_captures(root, CaptureConfig(test_prefix="a_"))  # the naming rule is configurable
    assert len(cs2.object_free) == 3 and cs2.object_free[0].out_name == "a_0.jpg"


def test_mixed_resolutions_name_the_odd_file(tmp_path):
    root = _two_folders(tmp_path / "cap")
    odd = _img(root / "with_objects" / "IMG_050.png", w=40, h=24)
    with pytest.raises(InputError) as e:
        collect_captures(root)
    assert e.value.path == odd and "40x24 differs from 32x24" in str(e.value)


def test_empty_object_free_folder_is_refused(tmp_path):
    root = tmp_path / "cap"
    for i in range(3):
        _img(root / "with_objects" / f"IMG_{i}.png", seed=i)
    (root / "without_objects").mkdir()  # there, but empty: photos that were meant to be in it
    with pytest.raises(InputError, match="no object-free photos") as e:
        collect_captures(root)
    assert e.value.path == root / "without_objects" and "remove the empty folder" in str(e.value)


def test_object_inclusive_photos_only_no_ground_truth(tmp_path):
    """Photos with the object only (the method's real use): accepted, no ground truth."""
    one = tmp_path / "one"  # one folder without any test_* photo
    for i in range(3):
        _img(one / f"IMG_{i}.png", seed=i)
    two = tmp_path / "two"  # with_objects/ alone
    for i in range(3):
        _img(two / "with_objects" / f"IMG_{i}.png", seed=i)
    for root, layout in ((one, "one-folder"), (two, "two-folders")):
        cs = collect_captures(root)
        assert cs.layout == layout and not cs.has_ground_truth and not cs.object_free
        assert [c.out_name for c in cs.object_inclusive] == ["IMG_0.png", "IMG_1.png", "IMG_2.png"]
    _img(two / "with_objects" / "IMG_9.png", seed=1)  # the checks still apply: a duplicate photo
    with pytest.raises(InputError, match="duplicate photo"):
        collect_captures(two)
    for p in sorted(one.iterdir())[1:]:
        p.unlink()
    with pytest.raises(InputError, match="fewer than 2 object-inclusive"):  # one photo is no capture
        collect_captures(one)


def test_duplicate_names(tmp_path):
    root = _two_folders(tmp_path / "cap")
    _img(root / "with_objects" / "IMG_001.jpg", seed=7)  # same stem as IMG_001.png
    with pytest.raises(InputError, match="duplicate name"):
        collect_captures(root)
    root2 = _two_folders(tmp_path / "cap2")
    _img(root2 / "without_objects" / "test_IMG_100.png", seed=7)  # collides with renamed IMG_100.png
    with pytest.raises(InputError, match="duplicate name"):
        collect_captures(root2)


def test_object_inclusive_photo_with_reserved_prefix(tmp_path):
    root = _two_folders(tmp_path / "cap")
    bad = _img(root / "with_objects" / "test_x.png")
    with pytest.raises(InputError) as e:
        collect_captures(root)
    assert e.value.path == bad


@pytest.mark.parametrize("kind", ["truncated-jpeg", "garbage-png"])
def test_corrupt_image_is_an_error_or_a_reported_skip(tmp_path, kind):
    root = _two_folders(tmp_path / "cap", ext=".jpg")
    if kind == "truncated-jpeg":
        bad = _img(root / "with_objects" / "IMG_009.jpg", w=32, h=24, seed=5)
        data = bad.read_bytes()
        bad.write_bytes(data[: len(data) // 2])
    else:
        bad = root / "with_objects" / "IMG_009.png"
        bad.write_bytes(b"\x89PNG\r\n\x1a\n" + bytes(range(200)))
    with pytest.raises(InputError) as e:
        collect_captures(root)
    assert e.value.path == bad and "cannot decode" in str(e.value)
    cs = collect_captures(root, CaptureConfig(skip_unreadable=True))
    assert str(bad) in cs.skipped and "unreadable" in cs.skipped[str(bad)]
    assert bad not in {c.source for c in cs.captures}


def test_missing_object_inclusive_folder(tmp_path):
    root = tmp_path / "cap"
    for i in range(3):
        _img(root / "without_objects" / f"IMG_{i}.png", seed=i)
    with pytest.raises(InputError) as e:
        collect_captures(root)
    assert e.value.path == root / "with_objects"


def test_unseen_masks_without_object_free_photos_refused_before_sfm(tmp_path, capsys):
    root = _two_folders(tmp_path / "cap", n_free=0)  # with_objects/ only
    masks = tmp_path / "masks"
    masks.mkdir()
    cv2.imwrite(str(masks / "IMG_000.png"), np.zeros((24, 32), np.uint8))
    line = _cli_fails(["build", str(root), str(tmp_path / "out"), "--unseen-masks", str(masks), "--no-progress"], capsys)
    assert "--unseen-masks" in line and "object-free" in line
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("case", ["mixed", "no-free", "duplicate", "corrupt", "missing"])
def test_build_cli_bad_input_one_line_and_nothing_written(tmp_path, capsys, case):
    root = _two_folders(tmp_path / "cap")
    out = tmp_path / "out"
    if case == "mixed":
        _img(root / "without_objects" / "IMG_200.png", w=48, h=24)
    elif case == "no-free":
        for p in (root / "without_objects").iterdir():
            p.unlink()
    elif case == "duplicate":
        _img(root / "without_objects" / "IMG_100.jpg")
    elif case == "corrupt":
        (root / "with_objects" / "IMG_000.png").write_bytes(b"not a png")
    elif case == "missing":
        root = tmp_path / "nope"
    line = _cli_fails(["build", str(root), str(out), "--no-progress"], capsys)
    assert line.startswith("inpaint360gs-dataset build: error: ")
    assert not out.exists()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".out")]  # no temporary left behind


def test_build_refuses_to_replace_existing_output(tmp_path, capsys):
    root = _two_folders(tmp_path / "cap")
    out = tmp_path / "out"
    out.mkdir()
    (out / "keep.txt").write_text("precious")
    line = _cli_fails(["build", str(root), str(out), "--no-progress"], capsys)
    assert "--overwrite" in line
    assert (out / "keep.txt").read_text() == "precious"


def test_unseen_masks_for_build_are_checked_before_sfm(tmp_path, capsys):
    root = _two_folders(tmp_path / "cap")
    masks = tmp_path / "masks"
    masks.mkdir()
    cv2.imwrite(str(masks / "IMG_100.png"), np.zeros((24, 32), np.uint8))
    out = tmp_path / "out"
    line = _cli_fails(["build", str(root), str(out), "--unseen-masks", str(masks), "--no-progress"], capsys)
    assert "no unseen mask for IMG_101.png" in line  # the first one exists (named like the photo)
    cv2.imwrite(str(masks / "test_IMG_101.png"), np.zeros((12, 32), np.uint8))  # named like the output
    line = _cli_fails(["build", str(root), str(out), "--unseen-masks", str(masks), "--no-progress"], capsys)
    assert "test_IMG_101.png" in line and "32x12" in line
    assert not out.exists()


@pytest.mark.parametrize("flag,value", [("--min-train-views", "0"), ("--min-train-angle", "-1"), ("--min-train-angle", "90")])
def test_leak_rule_settings_are_checked_before_sfm(tmp_path, capsys, flag, value):
    root = _two_folders(tmp_path / "cap")
    out = tmp_path / "out"
    line = _cli_fails(["build", str(root), str(out), flag, value, "--no-progress"], capsys)
    assert flag in line and value in line
    assert not out.exists()
