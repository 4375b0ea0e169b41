"""Fingerprints cover every input a stage reads (docs/architecture.md, "Reliability";
``Scene.read_fingerprint`` and ``Segmenter.input_files``): a changed ``images_<R>/`` photo reruns
3DGS at ``--resize R``, a changed ``gt/`` mask reruns the oracle's segmentation, and what no method
stage reads (a ``test_`` photo, ``gt/`` under another segmenter, the copies of another resize)
changes nothing. The bookkeeping runs with stub stages (``test_run.StubRunner``); the 3DGS
checkpoint and a stage's provenance identity are checked with the real stages."""

from __future__ import annotations

import dataclasses
import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from test_run import StubRunner

from cli_harness import restore_threads, run_cli  # noqa: F401
from inpaint360gs.io.images import write_labels
from inpaint360gs.io.scene import load_scene
from inpaint360gs.pipeline.run import STAGES, RunConfig

TRAIN_VIEW, TEST_VIEW = "IMG_003", "test_000"


def _scaled(root: Path, factor: int = 2) -> None:
    from PIL import Image

    (root / f"images_{factor}").mkdir()
    for p in (root / "images").iterdir():
        with Image.open(p) as im:
            im.resize(((im.width + factor - 1) // factor, (im.height + factor - 1) // factor)).save(root / f"images_{factor}" / p.name)


def _gt(root: Path) -> None:
    for v in load_scene(root).views:
        m = np.zeros((v.camera.height, v.camera.width), np.uint8)
        m[4:12, 6:14] = 1
        write_labels(root / "gt" / "instance" / f"{v.stem}.png", m)


@pytest.fixture
def scene(tiny_scene, tmp_path) -> Path:
    """A copy of the tiny scene with ``images_2/``, ``gt/instance/`` and clicks in ``scene.json``."""
    root = shutil.copytree(tiny_scene[0], tmp_path / "scene")
    _scaled(root)
    _gt(root)
    (root / "scene.json").write_text(json.dumps({"clicks": [{"view": f"{TRAIN_VIEW}.png", "x": 16, "y": 12}], "objects": [{"id": 1, "label": "blob"}]}))
    return root


def _ran(root: Path, out: Path, cfg: RunConfig, resize: int) -> list[str]:
    r = StubRunner(load_scene(root, resize=resize, load_masks=False), out, cfg, log=[], progress=False)
    r.run()
    return r.log


def _brighter(path: Path) -> None:
    from PIL import Image

    with Image.open(path) as im:
        a = np.asarray(im.convert("RGB")).copy()
    a[0, 0] = (a[0, 0].astype(int) + 40) % 256
    Image.fromarray(a).save(path)


def _relabel(path: Path) -> None:
    from inpaint360gs.io.images import read_mask

    m = read_mask(path).copy()
    m[0:3, 0:3] = 2
    write_labels(path, m)


def _clicks(root: Path) -> None:
    info = json.loads((root / "scene.json").read_text())
    info["clicks"][0]["x"] = 17
    (root / "scene.json").write_text(json.dumps(info))


def _label(root: Path) -> None:
    info = json.loads((root / "scene.json").read_text())
    info["objects"][0]["label"] = "ball"
    (root / "scene.json").write_text(json.dumps(info))


EVERY = list(STAGES)
FROM_SEGMENT = list(STAGES[1:])
CASES = {  # name -> (change to the scene, resize of the run, segmenter, the stages that rerun)
    "images_2-training-photo-at-resize-2": (lambda r: _brighter(r / "images_2" / f"{TRAIN_VIEW}.png"), 2, "geometric", EVERY),  # issue
    "images_2-training-photo-at-resize-1": (lambda r: _brighter(r / "images_2" / f"{TRAIN_VIEW}.png"), 1, "geometric", []),
    "images_2-test-photo-at-resize-2": (lambda r: _brighter(r / "images_2" / f"{TEST_VIEW}.png"), 2, "geometric", []),
    "images-training-photo": (lambda r: _brighter(r / "images" / f"{TRAIN_VIEW}.png"), 1, "geometric", EVERY),
    "images-training-photo-at-resize-2": (lambda r: _brighter(r / "images" / f"{TRAIN_VIEW}.png"), 2, "geometric", EVERY),
    "images-test-photo": (lambda r: _brighter(r / "images" / f"{TEST_VIEW}.png"), 1, "geometric", []),
    "gt-mask-oracle": (lambda r: _relabel(r / "gt" / "instance" / f"{TRAIN_VIEW}.png"), 1, "oracle", FROM_SEGMENT),  # issue
    "gt-mask-oracle-at-resize-2": (lambda r: _relabel(r / "gt" / "instance" / f"{TRAIN_VIEW}.png"), 2, "oracle", FROM_SEGMENT),
    "gt-mask-geometric": (lambda r: _relabel(r / "gt" / "instance" / f"{TRAIN_VIEW}.png"), 1, "geometric", []),
    "gt-test-mask-oracle": (lambda r: _relabel(r / "gt" / "instance" / f"{TEST_VIEW}.png"), 1, "oracle", []),
    "scene-json-clicks": (_clicks, 1, "geometric", ["remove", "inpaint"]),
    "scene-json-other-keys": (_label, 1, "geometric", []),
}


@pytest.mark.parametrize("name", list(CASES))
def test_a_changed_input_reruns_what_reads_it(name, scene, tmp_path):
    change, resize, segmenter, want = CASES[name]
    cfg = dataclasses.replace(RunConfig(), segmenter=segmenter)
    out = tmp_path / "out"
    assert _ran(scene, out, cfg, resize) == EVERY
    assert _ran(scene, out, cfg, resize) == []
    change(scene)
    assert _ran(scene, out, cfg, resize) == want


def test_the_3dgs_checkpoint_is_not_resumed_after_a_copy_changed(scene, tmp_path, capsys):
    """``train --resume`` at ``--resize 2`` continues a checkpoint only while ``images_2/`` is unchanged."""
    out = tmp_path / "run"
    argv = ["train", str(scene), str(out), "--resize", "2", "--iterations", "4", "--checkpoint-every", "2", "--no-progress", "--threads", "2"]
    assert run_cli("inpaint360gs", argv, capsys)[0] == 0
    _brighter(scene / "images_2" / f"{TRAIN_VIEW}.png")
    code, _, err = run_cli("inpaint360gs", [*argv, "--iterations", "6", "--resume"], capsys)
    assert code == 2 and "different content" in err and "checkpoint.pt" in err, err


def test_a_stage_identity_follows_the_copies_it_read(scene):
    """The provenance identity of a segmentation at ``--resize 2`` changes with ``images_2/``; the
    scene's content hash (resize-independent, what ties a model to its scene) does not."""
    from inpaint360gs.io import provenance

    before = load_scene(scene, resize=2, load_masks=False)
    rec_a = provenance.make("segment", before, {}, {})
    _brighter(scene / "images_2" / f"{TRAIN_VIEW}.png")
    after = load_scene(scene, resize=2, load_masks=False)
    rec_b = provenance.make("segment", after, {}, {})
    assert rec_a["scene"]["content_sha256"] == rec_b["scene"]["content_sha256"]
    assert rec_a["identity"] != rec_b["identity"]
    assert provenance.make("segment", load_scene(scene, load_masks=False), {}, {})["identity"] == provenance.make("segment", load_scene(scene, load_masks=False), {}, {})["identity"]
