"""The Snakemake workflow parses, validates its config (including values given with --config) and
plans the expected jobs (dry run: nothing is executed)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


def _dry_run(tmp_path, *config: str) -> subprocess.CompletedProcess:
    cmd = [sys.executable, "-m", "snakemake", "-n", "--cores", "1", "--directory", str(ROOT), "--snakefile", str(ROOT / "Snakefile"),
           "--config", f"data_dir={tmp_path}/data", f"out_dir={tmp_path}/out", f"results_dir={tmp_path}/results", *config]
    return subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, timeout=120)


def test_dry_run_with_typed_command_line_values(tmp_path):
    p = _dry_run(tmp_path, "reduced=true", "poses=colmap", "scenes=[cone,toys]", "train_scenes=[cone]",
                 "train={iterations: 1000, schedule_scale: auto, max_gaussians: 0, backend: auto, extra_args: ''}")
    assert p.returncode == 0, p.stderr[-2000:]
    out = p.stdout + p.stderr
    # two generated scenes and their COLMAP rebuilds, one training run, the table
    for rule, n in [("synth_scene", 2), ("colmap_scene", 2), ("train_3dgs", 1), ("table_3dgs", 1)]:
        assert any(line.split()[:2] == [rule, str(n)] for line in out.splitlines()), (rule, out[-3000:])


@pytest.mark.parametrize("bad,named", [("reduced=maybe", "reduced"), ("poses=guess", "poses"), ("train_scenes=[nosuchscene]", "nosuchscene")])
def test_bad_config_values_are_refused(tmp_path, bad, named):
    p = _dry_run(tmp_path, bad)
    assert p.returncode != 0
    assert named in (p.stderr + p.stdout)
