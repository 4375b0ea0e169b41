"""Resources and signals (docs/architecture.md, "Reliability"): a full disk names the output being
written and exits 2 (``io/atomic.py``), a failed allocation names its size and exits 2 (the CLI
layer), and a Python program using the library that is stopped with SIGTERM ends without pycolmap's
native stack dump (``io.colmap.pycolmap_module``)."""

from __future__ import annotations

import errno
import os
import shutil
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

from cli_harness import IS_ROOT, restore_threads, run_cli, tree  # noqa: F401
from inpaint360gs.io import atomic

T = "inpaint360gs"
NATIVE_DUMP = ("*** Aborted", "stack trace", "*** SIGTERM")


# --- a full disk -----------------------------------------------------------------------------------------


@pytest.fixture
def small_disk(tmp_path):
    """A 200 KiB file system (tmpfs): needs root and a kernel that lets the test mount one."""
    mnt = tmp_path / "small"
    mnt.mkdir()
    if not IS_ROOT or shutil.which("mount") is None or subprocess.run(["mount", "-t", "tmpfs", "-o", "size=200k", "tmpfs", str(mnt)], capture_output=True).returncode:
        pytest.skip("cannot mount a small file system here")
    yield mnt
    subprocess.run(["umount", "-l", str(mnt)], check=False)  # lazy: a file of the failed run may still be open


def test_a_full_disk_during_a_checkpoint_names_it(chains, small_disk, capsys):
    """The case that was exit 1 with a message naming no path (torch's RuntimeError from its writer)."""
    out = small_disk / "out"
    code, _, err = run_cli(T, ["train", str(chains["cone"].scene), str(out), "--iterations", "6", "--checkpoint-every", "3", "--no-progress", "--threads", "2"], capsys)
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and "No space left on device" in lines[0], err
    assert str(out) in lines[0]
    assert not [p for p in small_disk.rglob("*") if ".tmp" in p.name]  # no temporary left


@pytest.fixture
def disk_full(monkeypatch):
    """The output's disk reports no free space (what a write that failed on a full disk finds)."""
    monkeypatch.setattr(atomic.shutil, "disk_usage", lambda p: shutil._ntuple_diskusage(10**9, 10**9, 0))


def test_a_checkpoint_write_failing_on_a_full_disk_is_one_line_exit_2(chains, tmp_path, monkeypatch, disk_full, capsys):
    from inpaint360gs.gs import checkpoint

    def full(obj, path, *a, **k):  # what torch's writer raises when its file cannot grow
        Path(path).write_bytes(b"PK")
        raise RuntimeError("[enforce fail at inline_container.cc:672] . unexpected pos 173888 vs 173780")

    monkeypatch.setattr(checkpoint.torch, "save", full)
    out = tmp_path / "out"
    code, _, err = run_cli(T, ["train", str(chains["cone"].scene), str(out), "--iterations", "4", "--checkpoint-every", "2", "--no-progress", "--threads", "2"], capsys)
    assert code == 2 and len(err.strip().splitlines()) == 1 and f"{out / 'checkpoint.pt'}: No space left on device" in err, err
    assert not [p for p in tmp_path.rglob("*") if ".tmp" in p.name]


@pytest.mark.parametrize("kind", ["errno-without-a-name", "write-error-on-a-full-disk"])
def test_a_folder_write_failing_on_a_full_disk_names_the_folder(tmp_path, monkeypatch, kind):
    if kind == "write-error-on-a-full-disk":
        monkeypatch.setattr(atomic.shutil, "disk_usage", lambda p: shutil._ntuple_diskusage(10**9, 10**9, 512))
    err = OSError(errno.ENOSPC, "No space left on device") if kind == "errno-without-a-name" else OSError(errno.EIO, "Input/output error")
    with pytest.raises(OSError) as e:
        with atomic.atomic_dir(tmp_path / "out") as tmp:
            (tmp / "a.txt").write_text("x")
            raise err
    assert e.value.errno == errno.ENOSPC and e.value.filename == str(tmp_path / "out")
    assert list(tmp_path.iterdir()) == []  # nothing half-written


def test_other_write_errors_are_left_as_they_are(tmp_path):
    with pytest.raises(RuntimeError, match="not about space"):
        with atomic.atomic_path(tmp_path / "f.txt"):
            raise RuntimeError("not about space")
    assert list(tmp_path.iterdir()) == []


# --- memory ---------------------------------------------------------------------------------------------


def _torch_huge():
    import torch

    return torch.empty(1 << 50, dtype=torch.uint8)  # a PiB: torch's allocator refuses


ALLOCATIONS = {
    "torch": (_torch_huge, "1.00 PiB"),
    "numpy": (lambda: np.empty(1 << 50, np.uint8), "1.00 PiB"),
    "memory-error": (lambda: (_ for _ in ()).throw(MemoryError()), "out of memory"),
}


@pytest.mark.parametrize("kind", list(ALLOCATIONS))
def test_a_failed_allocation_is_one_line_naming_its_size_exit_2(kind, chains, tmp_path, monkeypatch, capsys):
    """A stage that runs out of memory (here: asks for a PiB) is a resource problem, not a bug."""
    from inpaint360gs.segment import stage

    alloc, text = ALLOCATIONS[kind]
    monkeypatch.setattr(stage, "segment_stage", lambda *a, **k: alloc())
    ch = chains["cone"]
    code, _, err = run_cli(T, ["segment", str(ch.scene), str(ch.model), str(tmp_path / "out"), "--no-progress", "--threads", "2"], capsys)
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and "out of memory" in lines[0] and text in lines[0], err
    assert not (tmp_path / "out").exists()


# --- SIGTERM in a Python program -------------------------------------------------------------------------

SCRIPT = """
import sys, time
import inpaint360gs
scene = inpaint360gs.load_scene(sys.argv[1])  # pycolmap is imported here
print("ready", flush=True)
if sys.argv[3] == "run":
    inpaint360gs.remove_object(scene, sys.argv[2], ids=[1], model=sys.argv[4], until="distill")
time.sleep(60)
"""


@pytest.mark.parametrize("when", ["after-load-scene", "during-remove-object"])
def test_sigterm_ends_a_python_program_without_a_native_stack_dump(when, chains, tmp_path):
    """The CLI replaces pycolmap's SIGTERM handler; a Python program using the API gets Python's own
    handling back (the default: it ends, status -SIGTERM), not glog's 32-line native stack."""
    ch = chains["cone"]
    argv = [sys.executable, "-c", textwrap.dedent(SCRIPT), str(ch.scene), str(tmp_path / "out"), "run" if when.startswith("during") else "load", str(ch.model)]
    p = subprocess.Popen(argv, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env={**os.environ, "PYTHONUNBUFFERED": "1"})
    assert p.stdout.readline().strip() == "ready"
    if when.startswith("during"):
        time.sleep(3.0)  # into the stages (segmentation, then distillation)
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=60)
    assert p.returncode == -signal.SIGTERM, (p.returncode, err[-2000:])
    assert not any(s in err for s in NATIVE_DUMP), err[-2000:]


def test_sigterm_after_the_cli_still_is_one_line(chains, tmp_path):
    """The CLI's own handling is unchanged: one line, status 143, partial outputs removed."""
    ch = chains["cone"]
    p = subprocess.Popen([sys.executable, "-m", "inpaint360gs.cli", "distill", str(ch.scene), str(ch.model), str(ch.associate), str(tmp_path / "out"),
                          "--iterations", "100000", "--no-progress", "--threads", "2"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)  # fmt: skip
    time.sleep(8.0)
    p.send_signal(signal.SIGTERM)
    _, err = p.communicate(timeout=60)
    assert p.returncode == 143 and len(err.strip().splitlines()) == 1 and "terminated" in err, err
    assert not (tmp_path / "out").exists() and tree(tmp_path) == {}


def test_a_signal_raised_inside_a_compiled_kernel_still_reads_as_the_signal():
    """A SIGTERM handler's exception raised while a numba kernel returns reaches the CLI as a
    SystemError chained to it ("returned a result with an exception set"); the CLI must read the
    chain and report "terminated" (exit 143), not an internal error."""
    from inpaint360gs.cli.common import _interruption
    from inpaint360gs.core.errors import Terminated

    def wrapped(inner: BaseException) -> SystemError:
        try:
            try:
                raise inner
            except BaseException as t:
                raise SystemError("returned a result with an exception set") from t
        except SystemError as e:
            return e

    assert isinstance(_interruption(wrapped(Terminated())), Terminated)
    assert isinstance(_interruption(wrapped(KeyboardInterrupt())), KeyboardInterrupt)
    assert _interruption(wrapped(ValueError("a bug"))) is None
    assert _interruption(ValueError("a bug")) is None
