"""How long `make benchmark` will take, from the job records of a committed run (no job runs).

The committed run's tables hold every stage's Snakemake benchmark wall time per scene and method
(``results/table2_runtime_detail.csv``: mean over the seeds) and ``results/README.md`` its wall-clock
total. Summing its jobs' wall times over the jobs it ran and dividing by that total gives how many
jobs ran side by side (`make benchmark` gives Snakemake twice the cores: two 2-thread jobs share the
two cores, each slower). A planned run's job list comes from a dry run of the workflow with the same
settings (``snakemake -n``, its "Job stats"); each job costs the committed run's mean for its rule,
and the sum divided by the same concurrency is the estimate. Jobs the committed tables do not time
(scene generation, the removal scores, records) are given on the command line, measured apart.

    python benchmarks/estimate_benchmark_time.py --committed-wall-min 161 --synth-min 4.0 --score-removal-min 0.3 \\
        --snakemake-args "--config seeds='[0,1,2]'"
"""

from __future__ import annotations

import argparse
import shlex
import subprocess
import sys
import tempfile
from pathlib import Path

import pandas as pd

ROOT = Path(__file__).resolve().parents[1]
STAGE_RULES = {"train": "train_3dgs", "segment": "segment", "associate": "associate", "distill": "distill", "remove": "remove",
               "render": "render_removed", "evaluate": "evaluate", "inpaint": "inpaint"}


def committed_job_minutes(detail: pd.DataFrame) -> dict[str, float]:
    """Mean wall minutes of one job of each rule in the committed run (per scene and seed, over the methods that ran it)."""
    rows = detail[detail["scene"] != "average"]
    out = {}
    for stage, rule in STAGE_RULES.items():
        col = f"{stage}_min"
        if col in rows:
            vals = rows[col].dropna()
            out[rule] = float(vals.mean()) if len(vals) else 0.0
    return out


def committed_job_counts(detail: pd.DataFrame, n_seeds: int, ablation_runs: int, tracker_runs: int) -> dict[str, int]:
    """The committed run's jobs per rule: its Tab. 2 methods on every scene and seed, plus the ablations' runs."""
    rows = detail[detail["scene"] != "average"]
    scenes = rows["scene"].nunique()
    runs = scenes * n_seeds
    methods = rows["method"].nunique()
    inpainting = rows[rows["inpaint_min"].notna()]["method"].nunique()
    return {"train_3dgs": scenes, "segment": runs, "associate": runs + tracker_runs, "distill": runs + tracker_runs, "remove": runs + tracker_runs,
            "render_removed": runs, "inpaint": inpainting * runs + ablation_runs, "evaluate": methods * runs + ablation_runs,
            "record": methods * runs + ablation_runs, "synth_scene": scenes}


def planned_job_counts(snakemake_args: str) -> dict[str, int]:
    """Job stats of a dry run of the workflow with ``snakemake_args`` (in a scratch data/out folder)."""
    with tempfile.TemporaryDirectory() as tmp:
        cmd = [sys.executable, "-m", "snakemake", "-n", "--cores", "4", "--directory", str(ROOT), "--snakefile", str(ROOT / "Snakefile"),
               *shlex.split(snakemake_args)]
        if "--config" not in cmd:
            cmd.append("--config")
        cmd += [f"data_dir={tmp}/data", f"out_dir={tmp}/out", f"results_dir={tmp}/results"]
        out = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, check=True).stdout
    counts, on = {}, False
    for line in out.splitlines():
        if line.startswith("Job stats"):
            on = True
            continue
        parts = line.split()
        if on and len(parts) == 2 and parts[1].isdigit():
            counts[parts[0]] = int(parts[1])
        elif on and counts and not parts:
            break
    return counts


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--detail", type=Path, default=ROOT / "results" / "table2_runtime_detail.csv")
    ap.add_argument("--committed-wall-min", type=float, required=True, help="the committed run's wall-clock minutes (results/README.md)")
    ap.add_argument("--committed-seeds", type=int, default=3)
    ap.add_argument("--committed-ablation-runs", type=int, default=30, help="ablation (scene, seed) runs of the committed run (each one inpainting)")
    ap.add_argument("--committed-tracker-runs", type=int, default=6, help="of those, ablation a)'s (its own association, distillation, removal)")
    ap.add_argument("--synth-min", type=float, required=True, help="minutes to generate one scene (measured apart)")
    ap.add_argument("--score-removal-min", type=float, required=True, help="minutes of one score_removal job (measured apart)")
    ap.add_argument("--record-min", type=float, default=0.03)
    ap.add_argument("--extra-inpaint-per-run", type=int, default=0,
                    help="inpainting methods not in the workflow yet, each costing the full method's inpainting + evaluation per main run")
    ap.add_argument("--snakemake-args", default="", help="the planned run's Snakemake options (as SNAKEMAKE_ARGS)")
    args = ap.parse_args()

    detail = pd.read_csv(args.detail)
    minutes = committed_job_minutes(detail)
    minutes.update(synth_scene=args.synth_min, score_removal=args.score_removal_min, record=args.record_min)
    done = committed_job_counts(detail, args.committed_seeds, args.committed_ablation_runs, args.committed_tracker_runs)
    job_min = sum(minutes.get(r, 0.0) * n for r, n in done.items())
    concurrency = job_min / args.committed_wall_min
    plan = planned_job_counts(args.snakemake_args)
    if args.extra_inpaint_per_run:
        main_runs = plan.get("render_removed", 0)  # one per main (scene, seed) run
        for rule in ("inpaint", "evaluate", "record"):
            plan[rule] = plan.get(rule, 0) + args.extra_inpaint_per_run * main_runs
    print(f"committed run: {sum(done.values())} jobs, {job_min:.0f} job-minutes in {args.committed_wall_min:.0f} min: concurrency {concurrency:.2f}\n")
    print("| rule | jobs | min per job | job-minutes |\n|---|---|---|---|")
    total = 0.0
    for rule, n in plan.items():
        if rule in ("all", "total"):
            continue
        m = minutes.get(rule, 0.0)
        total += m * n
        print(f"| {rule} | {n} | {m:.2f} | {m * n:.0f} |")
    print(f"\nplanned: {total:.0f} job-minutes / {concurrency:.2f} = {total / concurrency:.0f} min = {total / concurrency / 60:.2f} h")
    return 0


if __name__ == "__main__":
    sys.exit(main())
