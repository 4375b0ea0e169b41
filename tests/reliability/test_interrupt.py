"""SIGINT, SIGTERM and SIGKILL at a random point of every stage and of ``run`` (docs/architecture.md,
"Reliability"): an interrupted command exits 130 / 143 with one line and leaves no temporary and no
half-written output (an output is absent, or complete and the same as an uninterrupted run's); after
a SIGKILL, and after each interruption, the same command again writes the bytes of an uninterrupted
run and leaves no debris. Training is interrupted the same way in ``test_bad_input_signals.py``.

The point is drawn, with a seeded generator, among the calls into the package's own code that the
uninterrupted command makes (``interrupt.py``): anywhere in argument checks, loading, the work or the
atomic writes, whatever the machine's speed. SIGINT and SIGTERM are sent inside the test process;
SIGKILL to a child process (a fresh one makes more calls before the stage's work than a warm one, so
the drawn point is always reached)."""

from __future__ import annotations

import json
import os
import random
import re
import signal
import subprocess
import sys
from pathlib import Path

import pytest

from cli_harness import restore_threads, tree  # noqa: F401
from inpaint360gs.core.errors import EXIT_SIGINT, EXIT_SIGTERM
from reliability.chains import DISTILL, INPAINT, QUIET
from reliability.interrupt import run_counted

pytestmark = pytest.mark.slow
ROOT = Path(__file__).resolve().parents[2]
ENV = {**os.environ, "PYTHONPATH": os.pathsep.join([str(ROOT / "src"), str(ROOT)])}
ENV.pop("INPAINT360GS_DEBUG", None)
# timings, memory and thread counts differ from run to run, and so does the sha256 of a JSON holding
# them (distill.json's objects_sha256, of objects.json); everything else an output holds must not
VOLATILE = re.compile(r"second|timing|_s$|rss|threads|wall|elapsed|ms_per_view|steps_per|^objects_sha256$")


def commands(ch, out: Path) -> dict[str, tuple[str, list[str], list[str]]]:
    """stage -> (program, command line writing under ``out``, the flags that let it replace a complete output)."""
    S, M = str(ch.scene), str(ch.model)
    labels = ["--label", f"scene={ch.name}", "--label", "method=full", "--label", "segmenter=geometric"]
    return {
        "segment": ("inpaint360gs", ["segment", S, M, str(out), "--no-progress", *QUIET], ["--overwrite"]),
        "associate": ("inpaint360gs", ["associate", S, M, str(ch.segment), str(out)], ["--overwrite"]),
        "distill": ("inpaint360gs", ["distill", S, M, str(ch.associate), str(out), *DISTILL, "--no-progress", *QUIET], ["--overwrite"]),
        "remove": ("inpaint360gs", ["remove", S, str(ch.distill), str(out), "--id", "1", *QUIET], ["--overwrite"]),
        "inpaint": ("inpaint360gs", ["inpaint", S, str(ch.distill), str(ch.removed), str(out), *INPAINT, "--no-progress", *QUIET], ["--overwrite"]),
        "render": ("inpaint360gs", ["render", str(ch.removed / "point_cloud.ply"), S, str(out), "--no-progress", *QUIET], ["--overwrite"]),
        "evaluate": ("inpaint360gs", ["evaluate", str(ch.inpainted / "renders" / "test"), S, str(out / "eval.json"), "--nets", "vgg", *QUIET], []),
        "record": ("inpaint360gs", ["table", "record", str(out / "record.json"), *labels, "--eval", str(ch.eval), "--model", str(ch.inpainted / "point_cloud.ply")], []),
        "run": ("inpaint360gs", ["run", S, str(out), "--model", M, "--id", "1", "--distill-iterations", "20", *INPAINT, "--no-progress", "--accept", *QUIET], []),  # --accept: 20 steps fail the check
        "synth": ("inpaint360gs-dataset", ["synth", str(out), "--scenes", "cone", "--reduced", "--width", "48", "--height", "36", "--quiet"], ["--overwrite"]),
    }  # fmt: skip


def in_process(prog: str, argv: list[str], sig: int | None = None, at: int = 0, capsys=None) -> tuple[int, int, list[str]]:
    """(exit code, calls into the package, stderr lines) of one command run here, with ``sig`` sent to
    this process at call ``at``."""
    capsys.readouterr()
    code, calls = run_counted(prog, argv, sig, at)
    return code, calls, capsys.readouterr().err.strip().splitlines()


def snapshot(folder: Path, out: Path) -> dict[str, object]:
    """What ``folder`` holds, comparable between runs: file bytes, and JSON files without volatile
    keys (with ``out``, the command's output path, written as OUT)."""

    def stable(v):
        if isinstance(v, dict):  # run.json's manifest: which folders, not their inodes
            return {k: sorted(x) if k == "created" else stable(x) for k, x in v.items() if not VOLATILE.search(k)}
        return [stable(x) for x in v] if isinstance(v, list) else v

    got = {}
    for p in sorted(folder.rglob("*")):
        if p.is_file():
            data = p.read_bytes()
            if p.suffix == ".json":
                data = stable(json.loads(data.decode().replace(str(out), "OUT")))
            got[str(p.relative_to(folder))] = data
    return got


def debris(folder: Path) -> list[str]:
    return sorted(k for k in tree(folder) if any(part.startswith(".") and (".tmp" in part or part.endswith(".old")) for part in Path(k).parts))


STAGES = ["segment", "associate", "distill", "remove", "inpaint", "render", "evaluate", "record", "run", "synth"]


@pytest.fixture(scope="module")
def uninterrupted(chains, tmp_path_factory):
    """``get(stage, capsys)``: the stage's uninterrupted output (made here, on first use) and the calls
    it makes. Made twice, the count from the second run: warm, as the interrupted runs here are."""
    base, made = tmp_path_factory.mktemp("uninterrupted"), {}

    def get(stage: str, capsys):
        if stage not in made:
            for name in (f"{stage}-first", stage):
                prog, argv, _ = commands(chains["cone"], base / name)[stage]
                code, calls, err = in_process(prog, argv, capsys=capsys)
                assert code == 0, err
            made[stage] = (snapshot(base / stage, base / stage), calls)
        return made[stage]

    return get


@pytest.mark.parametrize("stage", STAGES)
def test_interrupted_anywhere_then_rerun_gives_the_uninterrupted_bytes(stage, chains, uninterrupted, tmp_path, capsys):
    ch = chains["cone"]
    ref, calls = uninterrupted(stage, capsys)
    rng = random.Random(f"interrupt {stage}")
    for sig, code, word in ((signal.SIGINT, EXIT_SIGINT, "interrupted"), (signal.SIGTERM, EXIT_SIGTERM, "terminated"), (signal.SIGKILL, -signal.SIGKILL, None)):
        out = tmp_path / sig.name / "out"
        out.parent.mkdir(parents=True)
        prog, argv, again = commands(ch, out)[stage]
        at = rng.randint(1, max(1, calls - 1))
        where = f"{stage}, {sig.name} at call {at} of {calls}"
        if sig == signal.SIGKILL:
            proc = subprocess.run([sys.executable, str(Path(__file__).with_name("interrupt.py")), "KILL", str(at), str(tmp_path / "calls"), prog, *argv],
                                  env=ENV, capture_output=True, text=True, timeout=600)  # fmt: skip
            assert proc.returncode == code, (where, proc.returncode, proc.stderr[-2000:])
        else:
            got, _, err = in_process(prog, argv, sig, at, capsys)
            assert got == code and err == [f"{prog} {argv[0]}: {word} (partial outputs removed; rerun to continue)"], (where, got, err)
            assert debris(out.parent) == [], where
            if out.exists():  # interrupted once its output (or, for run, a stage's) was complete: it is whole
                partial = snapshot(out, out)
                # run.json and the check report describe the run so far (the check after remove, before inpaint)
                so_far = ("run.json", "check.json", "check.png")
                assert all(partial[k] == ref[k] for k in partial if k not in so_far), (where, [k for k in partial if k not in so_far and partial[k] != ref.get(k)])
        got, _, err = in_process(prog, [*argv, *again], capsys=capsys)
        assert got == 0, (where, err)
        assert snapshot(out, out) == ref, where
        assert debris(out.parent) == [], where
