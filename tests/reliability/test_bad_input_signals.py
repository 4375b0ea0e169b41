"""Interruptions and file modes (docs/architecture.md, "Reliability"): SIGTERM / SIGINT during
``train`` end with 143 / 130, one line and no temporaries, and ``--resume`` then finishes with the
bytes of an uninterrupted run; after a SIGKILL the next run removes the dead process's temporaries
and resumes; outputs get the modes the umask asks for."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import scene_builder as sb
from cli_harness import restore_threads, run_cli, tree  # noqa: F401 (autouse fixture)
from inpaint360gs.core.errors import EXIT_SIGINT, EXIT_SIGTERM

ROOT = Path(__file__).resolve().parents[2]
ENV = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), str(ROOT)])}
ENV.pop("INPAINT360GS_DEBUG", None)
# torch backend: bit-identical across processes whatever state numba's kernel cache is in (gs/trainer.py)
TRAIN = ["--iterations", "60", "--schedule-scale", "auto", "--checkpoint-every", "10", "--backend", "torch", "--threads", "2", "--no-progress"]


@pytest.fixture(scope="module")
def scene(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("signals") / "scene"
    sb.simple_scene(root, n_train=10, n_test=2, width=32, height=24)
    return root


@pytest.fixture(scope="module")
def reference(scene) -> bytes:
    """The PLY of an uninterrupted run (in-process: the same code and settings as the subprocesses)."""
    from inpaint360gs.cli import main

    out = scene.parent / "reference"
    assert main(["train", str(scene), str(out), *TRAIN]) == 0
    return (out / "point_cloud.ply").read_bytes()


def debris(folder: Path) -> list[str]:
    """Hidden temporaries (``.NAME.<pid>.<random>.tmp*``) under ``folder`` and beside it."""
    places = [folder.parent, *(p for p in folder.rglob("*") if p.is_dir())] + ([folder] if folder.is_dir() else [])
    return sorted(str(p) for d in places for p in d.iterdir() if p.name.startswith(".") and ".tmp" in p.name)


def start_train(scene: Path, out: Path) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", "inpaint360gs.cli", "train", str(scene), str(out), *TRAIN],
                            env=ENV, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)


def wait_for_checkpoint(proc: subprocess.Popen, out: Path, timeout: float = 300.0) -> None:
    t0 = time.monotonic()
    while not (out / "checkpoint.pt").is_file():
        assert proc.poll() is None, f"training ended before its first checkpoint: {proc.communicate()}"
        assert time.monotonic() - t0 < timeout, "no checkpoint appeared"
        time.sleep(0.01)


def resume(scene: Path, out: Path, capsys) -> bytes:
    code, _, err = run_cli("inpaint360gs", ["train", str(scene), str(out), *TRAIN, "--resume"], capsys)
    assert code == 0, err
    return (out / "point_cloud.ply").read_bytes()


@pytest.mark.slow
@pytest.mark.parametrize("sig,code,word", [(signal.SIGTERM, EXIT_SIGTERM, "terminated"), (signal.SIGINT, EXIT_SIGINT, "interrupted")])
def test_signal_during_train_then_resume_gives_the_uninterrupted_bytes(scene, reference, tmp_path, capsys, sig, code, word):
    out = tmp_path / "run"
    proc = start_train(scene, out)
    wait_for_checkpoint(proc, out)
    proc.send_signal(sig)
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == code, (proc.returncode, stderr)
    lines = stderr.strip().splitlines()
    assert lines == [f"inpaint360gs train: {word} (partial outputs removed; rerun to continue)"], stderr
    assert "Traceback" not in stdout and "SIGTERM" not in stderr  # no Python or C++ (glog) stack dump
    assert debris(out) == []
    assert (out / "checkpoint.pt").is_file() and not (out / "point_cloud.ply").exists()  # what resumes it, no half result
    assert resume(scene, out, capsys) == reference
    assert debris(out) == []


@pytest.mark.slow
def test_sigkill_during_train_then_resume(scene, reference, tmp_path, capsys):
    out = tmp_path / "run"
    proc = start_train(scene, out)
    wait_for_checkpoint(proc, out)
    proc.kill()
    proc.communicate(timeout=60)
    assert proc.returncode == -signal.SIGKILL
    assert resume(scene, out, capsys) == reference
    assert debris(out) == []


def dead_pid() -> int:
    p = subprocess.Popen(["true"])
    p.wait()
    return p.pid


def test_stale_temporaries_of_a_killed_run_are_removed_and_the_run_resumes(scene, tmp_path, capsys):
    """What a SIGKILL before the first checkpoint leaves (a config, a log, half-written temporaries of
    a dead process) does not stop ``--resume``, which starts afresh; a live writer's temporary stays."""
    out = tmp_path / "run"
    out.mkdir()
    (out / "config.yaml").write_text("half a config\n")
    (out / "train_log.csv").write_text("step,loss\n1,0.5\n")
    pid = dead_pid()
    stale = [out / f".checkpoint.pt.{pid}.k1ll3d.tmp.pt", out / f".point_cloud.ply.{pid}.abc.tmp.ply", out / f".train_log.csv.{pid}.x.tmp.csv"]
    for p in stale:
        p.write_bytes(b"half written")
    live = out / f".metrics.json.{os.getppid()}.alive.tmp.json"  # a running process's temporary (our parent)
    live.write_bytes(b"being written")
    argv = ["train", str(scene), str(out), "--iterations", "3", "--backend", "torch", "--threads", "2", "--no-progress", "--resume"]
    code, _, err = run_cli("inpaint360gs", argv, capsys)
    assert code == 0, err
    assert (out / "point_cloud.ply").is_file() and (out / "train_log.csv").read_text().startswith("step,loss,l1")
    assert debris(out) == [str(live)]
    live.unlink()


@pytest.mark.parametrize("umask", [0o022, 0o002])
def test_outputs_respect_the_umask(scene, tmp_path, capsys, umask):
    """Files 0666 & ~umask, folders 0777 & ~umask, for every output of train, render, table,
    validate --json, import and unseen-masks (atomic files, atomic folders, plain folders, copies)."""
    from test_build_importers import _source, _usid_name

    src, _, exact = _source(tmp_path / "usid", _usid_name)  # a 360-USID scene to import, its files private:
    for name in exact:  # the imported copies must get the umask's modes, not the source's
        sb.write_mask(src / "unseen_masks" / name, np.zeros((120, 160), bool))
    for f in src.rglob("*"):
        f.chmod(0o700 if f.is_dir() else 0o600)
    work = tmp_path / "w"
    old = os.umask(umask)
    try:
        work.mkdir()
        run = work / "run"
        steps = [
            ("inpaint360gs", ["train", str(scene), str(run), "--iterations", "3", "--backend", "torch", "--threads", "2", "--no-progress"], 0),
            ("inpaint360gs", ["render", str(run / "point_cloud.ply"), str(scene), str(work / "renders"), "--backend", "torch", "--no-progress"], 0),
            ("inpaint360gs", ["table", "reconstruction", str(run / "metrics.json"), "--csv", str(work / "t" / "t.csv"), "--md", str(work / "t" / "t.md")], 0),
            # the random scene's points are observed by no view: not valid, the report is written all the same
            ("inpaint360gs-dataset", ["validate", str(scene), "--no-unseen-masks", "--json", str(work / "v" / "report.json")], 2),
            ("inpaint360gs-dataset", ["import", "360usid", str(src), str(work / "imported")], 0),
        ]
        for prog, argv, expected in steps:
            code, _, err = run_cli(prog, argv, capsys)
            assert code == expected, err
        masks = tmp_path / "masks"  # unseen-masks writes into the scene: a copy of it inside the umask
        for name in ("test_000.png", "test_001.png"):
            sb.write_mask(masks / name, np.zeros((24, 32), bool))
        shutil.copytree(scene, work / "scene")
        code, _, err = run_cli("inpaint360gs-dataset", ["unseen-masks", str(work / "scene"), "--import", str(masks)], capsys)
        assert code == 0, err
    finally:
        os.umask(old)
    created = {k: v for k, v in tree(work).items() if not k.startswith("scene") or k.startswith("scene/unseen_mask")}
    assert {"run/point_cloud.ply", "run/checkpoint.pt", "renders/color", "renders/render.json", "t/t.csv", "v/report.json",
            "scene/unseen_mask/test_000.png", "imported/images/IMG_000.png", "imported/sparse/0"} <= created.keys()
    wrong = {k: oct(mode) for k, (kind, mode, _) in created.items() if mode != (0o777 if kind == 0o040000 else 0o666) & ~umask}
    assert not wrong, wrong
    assert json.loads((work / "v" / "report.json").read_text())["ok"] is False
