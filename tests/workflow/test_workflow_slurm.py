"""The workflow through the SLURM profile on a real single-node SLURM (slurmctld + slurmd + munge on
this host, no accounting database), started by the test in a temporary folder.

Needs Debian's ``slurm-wlm`` and ``munge`` (``.ci/run`` installs them when apt can) and root (slurmd
launches the jobs); skips with the reason otherwise. The profile is used as a site would: the
partition named on the command line and ``--slurm-status-command squeue`` (the executor plugin
asks ``sacct`` by default, which needs the accounting database).
"""

from __future__ import annotations

import json
import os
import shutil
import socket
import subprocess
import sys
import time
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
PROGRAMS = ("mungekey", "munged", "slurmctld", "slurmd", "sbatch", "srun", "squeue", "sinfo", "scontrol")
PARTITION = "testq"


def _free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _slurm_conf(d: Path, host: str) -> str:
    mem_mb = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES") // 2**20 - 1024
    return "\n".join([
        "ClusterName=inpaint360gs-test", f"SlurmctldHost={host}", "SlurmUser=root", "SlurmdUser=root",
        "AuthType=auth/munge", "CredType=cred/munge", f"AuthInfo=socket={d}/munge.sock",
        f"SlurmctldPort={_free_port()}", f"SlurmdPort={_free_port()}",
        f"StateSaveLocation={d}/state", f"SlurmdSpoolDir={d}/spool",
        f"SlurmctldPidFile={d}/slurmctld.pid", f"SlurmdPidFile={d}/slurmd.pid",
        f"SlurmctldLogFile={d}/slurmctld.log", f"SlurmdLogFile={d}/slurmd.log",
        "ProctrackType=proctrack/linuxproc", "TaskPlugin=task/none", "MpiDefault=none", "SwitchType=switch/none",
        "SelectType=select/cons_tres", "SelectTypeParameters=CR_Core_Memory", "SchedulerType=sched/backfill",
        "JobAcctGatherType=jobacct_gather/none", "AccountingStorageType=accounting_storage/none", "JobCompType=jobcomp/none",
        "ReturnToService=2",
        f"NodeName={host} CPUs={os.cpu_count()} RealMemory={mem_mb} State=UNKNOWN",
        f"PartitionName={PARTITION} Nodes=ALL Default=YES MaxTime=INFINITE State=UP",
    ]) + "\n"  # fmt: skip


@pytest.fixture
def slurm_cluster(tmp_path):
    """A running single-node cluster; yields the environment that reaches it."""
    missing = [p for p in PROGRAMS if shutil.which(p) is None]
    if missing:
        pytest.skip(f"single-node SLURM needs Debian's slurm-wlm and munge ({', '.join(missing)} not found)")
    if os.geteuid() != 0:
        pytest.skip("single-node SLURM: slurmd must run as root to launch jobs")
    d = tmp_path / "slurm"
    for sub in ("state", "spool", "bin"):
        (d / sub).mkdir(parents=True)
    host = socket.gethostname().split(".")[0]
    conf = d / "slurm.conf"
    conf.write_text(_slurm_conf(d, host))
    # The jobstep executor drops SLURM_* variables before its inner `srun`, so a cluster whose
    # config is not at the default path (/etc/slurm/slurm.conf) is found through this shim.
    shim = d / "bin" / "srun"
    shim.write_text(f'#!/bin/sh\nSLURM_CONF={conf} exec {shutil.which("srun")} "$@"\n')
    shim.chmod(0o755)
    env = {**os.environ, "SLURM_CONF": str(conf), "PATH": f"{d / 'bin'}:{Path(sys.executable).parent}:{os.environ.get('PATH', '')}"}

    def run(*cmd: str) -> subprocess.CompletedProcess:
        return subprocess.run(cmd, capture_output=True, text=True, env=env, timeout=60)

    key = d / "munge.key"
    started = [
        run("mungekey", "--create", "--keyfile", str(key)),
        run("munged", "--force", "--socket", str(d / "munge.sock"), "--key-file", str(key), "--pid-file", str(d / "munged.pid"),
            "--log-file", str(d / "munged.log"), "--seed-file", str(d / "munge.seed")),  # fmt: skip
        run("slurmctld", "-c", "-f", str(conf)),
        run("slurmd", "-f", str(conf)),
    ]
    try:
        bad = next((p for p in started if p.returncode != 0), None)
        if bad is not None:
            pytest.skip(f"single-node SLURM did not start: {' '.join(bad.args[:1])}: {(bad.stderr or bad.stdout).strip()[-300:]}")
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            p = run("sinfo", "--noheader", "--format=%t", "--partition", PARTITION)
            if p.returncode == 0 and p.stdout.strip() == "idle":
                break
            time.sleep(0.5)
        else:
            pytest.skip(f"single-node SLURM: the node did not become idle within 60 s (sinfo: {p.stdout.strip() or p.stderr.strip()})")
        yield env
    finally:
        run("scontrol", "shutdown")
        for pid_file in ("slurmd.pid", "slurmctld.pid", "munged.pid"):
            try:
                os.kill(int((d / pid_file).read_text().split()[0]), 15)
            except (OSError, ValueError):
                pass


@pytest.mark.slow
def test_reduced_workflow_runs_as_slurm_jobs(slurm_cluster, tmp_path):
    """The reduced workflow's dataset, 3DGS, reconstruction-table and object-field rules (segment,
    associate, distill) are submitted by the SLURM profile and run by slurmd. (The later rules need
    longer training than a test affords; CI runs them all through the local profile.)"""
    pytest.importorskip("snakemake_executor_plugin_slurm")
    cmd = [sys.executable, "-m", "snakemake", "--profile", str(ROOT / "workflow/profiles/slurm"), "--directory", str(ROOT),
           "--snakefile", str(ROOT / "Snakefile"),
           "--config", f"data_dir={tmp_path}/data", f"out_dir={tmp_path}/out", f"results_dir={tmp_path}/results",
           "scenes=[cone]", "train_scenes=[cone]", "reduced=true", "methods=[]", "distill={iterations: 50}",
           "train={iterations: 200, schedule_scale: auto, max_gaussians: 20000, backend: auto, extra_args: ''}",
           # the site settings: partition, job sizes that fit the node, squeue for job status (no accounting)
           "--default-resources", f"slurm_partition={PARTITION}", "runtime=30", "mem_mb=2000", "cpus_per_task=1",
           "--set-resources", "train_3dgs:mem_mb=4000", "distill:mem_mb=4000", "inpaint:mem_mb=4000",
           "--slurm-status-command", "squeue", "--slurm-init-seconds-before-status-checks", "1", "--seconds-between-status-checks", "2",
           "--slurm-logdir", str(tmp_path / "slurm_logs"), "--slurm-keep-successful-logs",
           "all", f"{tmp_path}/out/cone/seed0/geometric/kom/distill/distill.json"]  # fmt: skip
    p = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, env=slurm_cluster, timeout=1200)
    assert p.returncode == 0, p.stderr[-3000:]
    submitted = p.stdout + p.stderr
    rules = ("synth_scene", "train_3dgs", "table_3dgs", "segment", "associate", "distill")
    for rule in rules:
        assert f"rule {rule}:" in submitted
    assert submitted.count("has been submitted with SLURM jobid") == len(rules)
    # the jobs ran under slurmd (each left its SLURM log) and wrote what the next rules read
    assert len(list((tmp_path / "slurm_logs").rglob("*.log"))) == len(rules)
    assert json.loads((tmp_path / "out" / "cone" / "3dgs" / "metrics.json").read_text())["psnr"] > 15
    assert (tmp_path / "results" / "3dgs_reconstruction.csv").is_file()
    assert (tmp_path / "out" / "cone" / "seed0" / "geometric" / "kom" / "distill" / "distill.json").is_file()
