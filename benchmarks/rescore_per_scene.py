"""The differences of a committed ``per_scene.csv`` with the tables' current statistics (report/stats.py:
intervals that resample scenes, "seed noise only" below three scenes): reporting only, no run.

For each baseline (and each ablation, on the runs it has) against the full method, per compared
metric: the mean paired difference, its interval and the verdict, as a Markdown table. With
``--against OLD.csv`` instead: each method of the file against itself in ``OLD.csv`` (new − old,
paired over the (scene, seed) runs both have), the test that a change of the code made no method
worse.

    python benchmarks/rescore_per_scene.py results/per_scene.csv [--seeds 0 1]
    python benchmarks/rescore_per_scene.py outputs/results/per_scene.csv --against results/per_scene.csv --seeds 0 1
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import pandas as pd

from inpaint360gs.report.builders import AVERAGE_METRICS, GEOMETRY_METRICS, METRIC_COLUMNS
from inpaint360gs.report.stats import paired_difference


def runs(df: pd.DataFrame, method: str, metric: str) -> dict:
    rows = df[df["method"] == method]
    return {(r["scene"], str(r["seed"])): (None if pd.isna(r[metric]) else float(r[metric])) for _, r in rows.iterrows()}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("per_scene", type=Path)
    ap.add_argument("--method", default="full")
    ap.add_argument("--seeds", type=int, nargs="+", help="only these seeds (default: all the file has)")
    ap.add_argument("--against", type=Path, help="an older per_scene.csv: each method against itself there (new − old)")
    args = ap.parse_args()
    df = pd.read_csv(args.per_scene)
    if args.seeds is not None:
        df = df[df["seed"].isin(args.seeds)]
    metrics = [m for m in (*AVERAGE_METRICS, "fid", "fd_vgg16", *GEOMETRY_METRICS) if m in df.columns and df[m].notna().any()]
    if args.against is not None:
        old = pd.read_csv(args.against)
        metrics = [m for m in metrics if m in old.columns and old[m].notna().any()]
        print("| new − old | scenes × seeds | " + " | ".join(METRIC_COLUMNS[m][0] for m in metrics) + " |")
        print("|---|---|" + "---|" * len(metrics))
        for method in [m for m in dict.fromkeys(df["method"]) if m in set(old["method"])]:
            cells, shape = [], ""
            for m in metrics:
                iv = paired_difference(runs(df, method, m), runs(old, method, m))
                if iv is None:
                    cells.append("n/a")
                    continue
                shape = f"{iv.scenes} × {iv.n // max(iv.scenes, 1)}"
                fmt = METRIC_COLUMNS[m][2]
                ci = f" [{iv.low:{fmt}}, {iv.high:{fmt}}]" if iv.low is not None else ""
                cells.append(f"{iv.mean:+{fmt}}{ci} {iv.verdict(METRIC_COLUMNS[m][1])}")
            print(f"| {method} | {shape} | " + " | ".join(cells) + " |")
        return 0
    others = [m for m in dict.fromkeys(df["method"]) if m != args.method]
    print("| Δ | scenes × seeds | " + " | ".join(METRIC_COLUMNS[m][0] for m in metrics) + " |")
    print("|---|---|" + "---|" * len(metrics))
    for other in others:
        kind = df[df["method"] == other]["kind"].iloc[0]
        cells, shape = [], ""
        for m in metrics:
            a, b = runs(df, args.method, m), runs(df, other, m)
            if kind == "ablation":  # ablation - method, on the ablation's runs
                a, b = b, {k: v for k, v in a.items() if k in b}
            iv = paired_difference(a, b)
            shape = f"{iv.scenes} × {iv.n // max(iv.scenes, 1)}"
            fmt = METRIC_COLUMNS[m][2]
            ci = f" [{iv.low:{fmt}}, {iv.high:{fmt}}]" if iv.low is not None else ""
            cells.append(f"{iv.mean:+{fmt}}{ci} {iv.verdict(METRIC_COLUMNS[m][1])}")
        label = f"{other} − {args.method}" if kind == "ablation" else f"{args.method} − {other}"
        print(f"| {label} | {shape} | " + " | ".join(cells) + " |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
