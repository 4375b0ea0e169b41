"""One run per output folder at a time (docs/architecture.md, "Reliability"; ``io/lock.py``): while
one ``inpaint360gs run`` (or :func:`inpaint360gs.remove_object`) holds OUT, a second one is refused at
once with one line naming the holder's pid, and writes nothing; a lock left by a killed run is taken
over; the lock is released however the holder ends."""

from __future__ import annotations

import json
import multiprocessing
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from cli_harness import Case, check, ids_unique, restore_threads, run_cli, tree  # noqa: F401
from inpaint360gs.core.errors import InputError

LOCK_NAME = ".lock"  # io/lock.py's (spelled here too: the concurrency tests also run where that module is missing)

T = "inpaint360gs"
HOLD = """
import sys, time
from inpaint360gs.io.lock import folder_lock
with folder_lock(sys.argv[1]):
    print("held", flush=True)
    time.sleep(float(sys.argv[2]))
"""


def holder(folder: Path, seconds: float = 60.0) -> subprocess.Popen:
    """Another process holding ``folder``'s lock (until killed or ``seconds`` pass)."""
    p = subprocess.Popen([sys.executable, "-c", HOLD, str(folder), str(seconds)], stdout=subprocess.PIPE, text=True)
    assert p.stdout.readline().strip() == "held"
    return p


@pytest.fixture
def held(tmp_path):
    """OUT (an earlier, empty run's folder) locked by another process; yields (OUT, its pid)."""
    out = tmp_path / "out"
    out.mkdir()
    p = holder(out)
    yield out, p.pid
    p.kill()
    p.wait()


def run_argv(ch, out, *extra):
    return ["run", str(ch.scene), str(out), "--model", str(ch.model), "--id", "1", "--until", "segment", "--no-progress", "--threads", "2", *extra]


# --- refused while held: the CLI and the API, with any settings ------------------------------------


def locked_case(*extra: str):
    def make(c):
        out = c.tmp / "out"
        out.mkdir()
        p = holder(out)
        c.request.addfinalizer(lambda: (p.kill(), p.wait()))
        ch = c.request.getfixturevalue("chains")["cone"]
        c.watched.append(ch.run)
        return run_argv(ch, out, *extra), (str(out), "another run", f"pid {p.pid}")

    return make


CASES = [
    Case("run-into-a-locked-out", T, locked_case()),
    Case("run-into-a-locked-out-other-settings", T, locked_case("--seed", "4", "--association", "tracker")),  # issue: both said "ran"
    Case("run-into-a-locked-out-other-stage", T, locked_case("--until", "associate")),
]


@pytest.mark.parametrize("case", ids_unique(CASES))
def test_a_second_run_is_refused(case, tmp_path, request, capsys):
    check(case, tmp_path, request, capsys)


def test_the_api_is_refused_too(chains, held):
    import inpaint360gs

    out, pid = held
    before = tree(out)
    with pytest.raises(InputError, match=f"another run is writing this folder \\(pid {pid} "):
        inpaint360gs.remove_object(chains["cone"].scene, out, ids=[1], model=chains["cone"].model, until="segment")
    assert tree(out) == before


def test_the_holder_is_named_by_pid_host_and_start(tmp_path):
    from inpaint360gs.io.lock import folder_lock

    with folder_lock(tmp_path / "o") as path:
        info = json.loads(path.read_text())
        assert info["pid"] == os.getpid() and info["host"] and info["since"]
        with pytest.raises(InputError, match=f"pid {os.getpid()} on "):
            with folder_lock(tmp_path / "o"):
                pass
    assert not (tmp_path / "o").exists()  # made for the lock, left empty: removed


# --- stale locks: taken over -------------------------------------------------------------------------


def test_the_lock_of_a_killed_run_is_taken_over(chains, tmp_path, capsys):
    out = tmp_path / "out"
    out.mkdir()
    p = holder(out)
    os.kill(p.pid, signal.SIGKILL)
    p.wait()
    assert (out / LOCK_NAME).is_file()  # left behind, naming a process that is gone
    code, _, err = run_cli(T, run_argv(chains["cone"], out), capsys)
    assert code == 0, err
    assert not (out / LOCK_NAME).exists() and (out / "segment").is_dir()


def test_a_lock_file_without_its_process_is_taken_over(chains, tmp_path, capsys):
    """A lock file copied along with a run folder, or left by a process whose pid now belongs to a
    live one: only a held lock counts, not the pid written in it."""
    out = tmp_path / "out"
    out.mkdir()
    (out / LOCK_NAME).write_text(json.dumps({"pid": os.getppid(), "host": "elsewhere", "since": "long ago"}))
    code, _, err = run_cli(T, run_argv(chains["cone"], out), capsys)
    assert code == 0, err
    assert not (out / LOCK_NAME).exists()


def test_the_lock_is_released_when_the_run_fails(chains, tmp_path, capsys):
    out = tmp_path / "out"
    code, _, err = run_cli(T, run_argv(chains["cone"], out, "--click", "IMG_003.png:0,0", "--until", "remove"), capsys)
    assert code != 0 and not (out / LOCK_NAME).exists()
    code, _, err = run_cli(T, run_argv(chains["cone"], out), capsys)
    assert code == 0, err


def test_a_run_refused_before_writing_leaves_no_folder(chains, tmp_path, capsys):
    """OUT made only to hold the lock goes again when the run writes nothing (a stage refused)."""
    out = tmp_path / "new" / "out"
    code, _, err = run_cli(T, ["run", str(chains["toys"].scene), str(out), "--model", str(chains["cone"].model), "--id", "1", "--until", "segment",
                               "--no-progress", "--threads", "2"], capsys)  # fmt: skip
    assert code == 2 and "made from scene cone" in err, err
    assert not out.parent.exists()


def _contend(folder: str, start, results) -> None:
    from inpaint360gs.io.lock import folder_lock

    start.wait()
    try:
        with folder_lock(folder):
            results.put(("held", os.getpid()))
            time.sleep(1.0)
    except InputError as e:
        results.put(("refused", str(e)))


def test_of_processes_starting_together_one_holds_the_rest_are_refused(tmp_path):
    ctx = multiprocessing.get_context("spawn")
    start, results = ctx.Barrier(4), ctx.Queue()
    procs = [ctx.Process(target=_contend, args=(str(tmp_path / "o"), start, results)) for _ in range(4)]
    for p in procs:
        p.start()
    got = [results.get(timeout=60) for _ in procs]
    for p in procs:
        p.join(timeout=60)
    held = [g for g in got if g[0] == "held"]
    assert len(held) == 1, got
    assert all(f"pid {held[0][1]} " in msg for kind, msg in got if kind == "refused")


def test_two_runs_with_other_settings_into_one_out(chains, tmp_path, capsys):
    """The case that said "ran" twice and left the first one's result: a second ``run`` (other settings)
    while the first is working is refused at once, naming the first's pid; the first finishes."""
    ch = chains["cone"]
    out = tmp_path / "out"
    first = subprocess.Popen([sys.executable, "-m", "inpaint360gs.cli", *run_argv(ch, out, "--until", "distill", "--distill-iterations", "3000")],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)  # fmt: skip
    try:
        for _ in range(600):  # until it works in OUT (its record is there once the first stage started)
            if (out / "run.json").exists() or first.poll() is not None:
                break
            time.sleep(0.1)
        assert first.poll() is None, first.communicate()
        before = tree(out)
        code, _, err = run_cli(T, run_argv(ch, out, "--seed", "5", "--until", "segment"), capsys)
        assert code == 2 and len(err.strip().splitlines()) == 1 and f"pid {first.pid} " in err, err
        assert tree(out).keys() >= before.keys()  # the second run removed nothing
    finally:
        first.send_signal(signal.SIGINT)
        first.communicate(timeout=120)
