"""Removal against the ground truth over several whole-run seeds (README "Robustness"; targets:
residual ≤ 1 % and collateral ≤ 1 % in every run, the run's own selection check passing on every
correct run).

For each synthetic scene and each seed, ``inpaint360gs run SCENE OUT --until remove --seed S`` (the
3DGS and every later stage reseeded; the scene's own clicks) and then ``inpaint360gs score-removal``
(:mod:`inpaint360gs.evaluate.removal`). A run is judged by the worst seed, not the mean: the table
gives every run, then per scene the worst residual and collateral, then the runs above a limit by
name. Finished runs (``OUT/<scene>/seed<S>.row.json`` beside the run folder) are reused, so the
script resumes; delete one to rerun it (``run`` resumes its stages and its check). A run whose check
failed (exit 4) keeps its folder for inspection and is scored all the same.

    inpaint360gs-dataset synth data/dev --scenes teapot-test2 dozer-test1 duck-dev1
    python benchmarks/bench_removal_seeds.py data/dev runs/dev --scenes teapot-test2 dozer-test1 duck-dev1 --seeds 0 1 2
    python benchmarks/bench_removal_seeds.py data/dev runs/dev-sfm-only --scenes plush-dev1 "--extra=--support-init off"
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
import time
from pathlib import Path

from inpaint360gs.core.errors import EXIT_CHECK
from inpaint360gs.metrics.removal import LIMIT_TEXT, LIMITS


def run_one(scene: Path, out: Path, seed: int, threads: int, extra: tuple[str, ...] = ()) -> dict:
    """One run to the removal and its scores; the record of the table's row."""
    scores_path = out.parent / f"{out.name}.removal_scores.json"  # beside the run folder: a run's OUT holds only its stages
    row_path = out.parent / f"{out.name}.row.json"
    if row_path.is_file() and scores_path.is_file():
        return json.loads(row_path.read_text())
    inp = shutil.which("inpaint360gs") or str(Path(sys.executable).with_name("inpaint360gs"))
    t0 = time.perf_counter()
    out.parent.mkdir(parents=True, exist_ok=True)
    with open(out.parent / f"{out.name}.log", "w") as log:
        rc = subprocess.call([inp, "run", str(scene), str(out), "--until", "remove", "--seed", str(seed), "--threads", str(threads),
                              "--no-progress", *extra], stdout=log, stderr=subprocess.STDOUT)
    wall = time.perf_counter() - t0
    row = {"scene": scene.name, "seed": seed, "exit": rc, "run_s": round(wall, 1)}
    check = out / "check.json"
    if check.is_file():
        c = json.loads(check.read_text())
        row["check"] = "pass" if c.get("passed") else "FAIL: " + ", ".join(str(f) for f in c.get("failed", []))
    if (out / "removed" / "removal.json").is_file():
        with open(out.parent / f"{out.name}.score.log", "w") as log:
            src = subprocess.call([inp, "score-removal", str(scene), str(out / "removed"), str(scores_path), "--threads", str(threads)],
                                  stdout=log, stderr=subprocess.STDOUT)
        if src == 0:
            s = json.loads(scores_path.read_text())
            row.update({k: s["scores"].get(k) for k in ("residual", "collateral", "amcr", "gt_footprint_share")})
            row["above"] = [a["limit"] for a in s["above_limits"]]
        row["over_removal"] = (json.loads((out / "removed" / "removal.json").read_text()).get("over_removal") or {}).get("ratio")
    row_path.write_text(json.dumps(row, indent=1))
    return row


def fmt(v) -> str:
    return "—" if v is None else f"{v:.2f}"


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("data", type=Path, help="folder of generated synthetic scenes (inpaint360gs-dataset synth)")
    ap.add_argument("out", type=Path, help="runs go to OUT/<scene>/seed<S>/")
    ap.add_argument("--scenes", nargs="+", required=True)
    ap.add_argument("--seeds", nargs="+", type=int, default=[0, 1, 2])
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--extra", default="", help="extra options for every `inpaint360gs run`, one string (e.g. '--extra=--support-init off'; use another OUT)")
    a = ap.parse_args(argv)
    missing = [s for s in a.scenes if not (a.data / s / "scene.json").is_file()]
    if missing:
        print(f"bench_removal_seeds: not generated in {a.data}: {', '.join(missing)} (inpaint360gs-dataset synth {a.data} --scenes ...)", file=sys.stderr)
        return 2
    rows = []
    for name in a.scenes:
        for seed in a.seeds:
            r = run_one(a.data / name, a.out / name / f"seed{seed}", seed, a.threads, tuple(a.extra.split()))
            rows.append(r)
            print(f"  {name} seed {seed}: exit {r['exit']}, residual {fmt(r.get('residual'))} %, collateral {fmt(r.get('collateral'))} %, "
                  f"{r.get('check', 'no check')} ({r['run_s']:.0f} s)", flush=True)
    print()
    print("| scene | seed | exit | selection/removal check | residual % | collateral % | AMCR % | true footprint % | over-removal |")
    print("|---|---|---|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['scene']} | {r['seed']} | {r['exit']} | {r.get('check', '—')} | {fmt(r.get('residual'))} | {fmt(r.get('collateral'))} "
              f"| {fmt(r.get('amcr'))} | {fmt(r.get('gt_footprint_share'))} | {fmt(r.get('over_removal'))} |")
    print()
    print(f"Worst over seeds {a.seeds} (limits: {', '.join(LIMIT_TEXT[k] for k in ('residual', 'collateral'))}):")
    print("| scene | worst residual % | worst collateral % | runs whose check failed |")
    print("|---|---|---|---|")
    for name in a.scenes:
        rs = [r for r in rows if r["scene"] == name]
        worst = {k: max((r[k] for r in rs if r.get(k) is not None), default=None) for k in ("residual", "collateral")}
        print(f"| {name} | {fmt(worst['residual'])} | {fmt(worst['collateral'])} | {sum(r['exit'] == EXIT_CHECK for r in rs)} of {len(rs)} |")
    bad = [r for r in rows if r.get("above") and any(k in ("residual", "collateral") for k in r["above"])]
    silent = [r for r in bad if r["exit"] == 0]
    print()
    print(f"Runs above the residual or collateral limit ({LIMITS['residual']:g} %, {LIMITS['collateral']:g} %): "
          + (", ".join(f"{r['scene']} seed {r['seed']} ({', '.join(r['above'])}; exit {r['exit']})" for r in bad) or "none"))
    print(f"Of them, exited 0 (a silent failure): {len(silent)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
