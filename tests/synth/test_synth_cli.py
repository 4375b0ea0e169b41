"""``inpaint360gs-dataset synth``: determinism, atomic output, one-line errors that write nothing."""

from __future__ import annotations

from pathlib import Path

import pytest

from dataset_tools.cli import main

SMALL = ["--reduced", "--width", "48", "--height", "36", "--quiet"]


def _tree(root: Path) -> dict[str, bytes]:
    return {str(p.relative_to(root)): p.read_bytes() for p in sorted(root.rglob("*")) if p.is_file()}


def test_two_runs_give_identical_bytes(tmp_path):
    assert main(["synth", str(tmp_path / "a"), "--scenes", "cone", "--seed", "7", *SMALL]) == 0
    assert main(["synth", str(tmp_path / "b"), "--scenes", "cone", "--seed", "7", *SMALL]) == 0
    a, b = _tree(tmp_path / "a"), _tree(tmp_path / "b")
    assert len(a) > 100 and a.keys() == b.keys()
    assert all(a[k] == b[k] for k in a), [k for k in a if a[k] != b[k]][:5]
    # another seed changes textures and poses
    assert main(["synth", str(tmp_path / "c"), "--scenes", "cone", "--seed", "8", *SMALL]) == 0
    c = _tree(tmp_path / "c")
    assert a["cone/images/IMG_0000.png"] != c["cone/images/IMG_0000.png"]
    assert a["cone/gt/cameras.json"] != c["cone/gt/cameras.json"]


@pytest.mark.parametrize(
    "args, message",
    [
        (["--scenes", "cone", "nope"], "unknown synthetic scene 'nope'"),
        (["--scenes", "cone", "--width", "64"], "give both --width and --height"),
        (["--scenes", "cone", "--width", "4", "--height", "4"], "--width: must be >= 16"),
        (["--scenes", "cone", "--seed", "-1"], "--seed: must be >= 0"),
        (["--scenes", "cone", "--suite", "dev"], "--suite: give --scenes or --suite, not both"),
        (["--suite", "train"], "--suite: invalid choice: 'train'"),
        (["--scenes", "dozer-dev1", "--poses", "sfm"], "--poses: invalid choice: 'sfm'"),
    ],
)
def test_bad_arguments_exit_2_and_write_nothing(tmp_path, capsys, args, message):
    out = tmp_path / "out"
    assert main(["synth", str(out), *args, "--quiet"]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and message in err and err.startswith("inpaint360gs-dataset synth: error:")
    assert not out.exists()


def test_existing_scene_needs_overwrite(tmp_path, capsys):
    out = tmp_path / "out"
    (out / "cube").mkdir(parents=True)
    (out / "cube" / "keep.txt").write_text("mine")
    # cone would be fine, cube exists: nothing is written, not even cone
    assert main(["synth", str(out), "--scenes", "cone", "cube", *SMALL]) == 2
    assert "exists and is not empty" in capsys.readouterr().err
    assert sorted(p.name for p in out.iterdir()) == ["cube"] and (out / "cube" / "keep.txt").read_text() == "mine"
    assert main(["synth", str(out), "--scenes", "cube", "--overwrite", *SMALL]) == 0
    assert not (out / "cube" / "keep.txt").exists() and (out / "cube" / "scene.json").is_file()
    assert sorted(p.name for p in out.iterdir()) == ["cube"]  # no temporary leftovers


def test_list(capsys):
    from dataset_tools.synth import SCENES
    from dataset_tools.synth.catalogue import LOW_UNSEEN_SHARE

    assert main(["synth", "--list"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert len(lines) == len(SCENES) and any(line.startswith("toys") for line in lines)
    for line in lines:  # each scene's suite, family and poses; the scenes below the unseen minimum marked
        name, suite, family = line.split()[:3]
        spec = SCENES[name]
        assert (suite, family) == (spec.suite, spec.family) and f"poses={spec.poses}" in line
        assert ("unseen<1%" in line) == (name in LOW_UNSEEN_SHARE)


def test_realistic_scene_with_true_poses_and_its_unseen_share(tmp_path, capsys):
    import json

    assert main(["synth", str(tmp_path), "--scenes", "duck-dev1", "--poses", "generator", *SMALL]) == 0
    out = capsys.readouterr().out
    assert "unseen share of the test views: mean" in out
    meta = json.loads((tmp_path / "duck-dev1" / "scene.json").read_text())
    assert meta["provenance"]["suite"] == "dev" and "poses" not in meta["provenance"]  # the generator's own model
    assert (tmp_path / "duck-dev1" / "gt" / "photometric.json").is_file()


def test_missing_out(capsys):
    assert main(["synth", "--scenes", "cone"]) == 2
    assert "OUT" in capsys.readouterr().err


def test_same_scene_twice_in_one_call_is_written_once(tmp_path):
    assert main(["synth", str(tmp_path), "--scenes", "cone", "cone", *SMALL]) == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["cone"]


def test_photos_sfm_cannot_register_is_one_line_and_writes_nothing(tmp_path, capsys):
    """The realistic family's poses come from pycolmap; at 48x36 it registers almost nothing."""
    out = tmp_path / "out"
    assert main(["synth", str(out), "--scenes", "duck-dev1", *SMALL]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "duck-dev1: poses from pycolmap failed" in err and "--poses generator" in err
    assert not out.exists() or not any(out.iterdir())
