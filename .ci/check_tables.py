"""CI: every table the workflow wrote is complete (one row per expected run, no empty cell where a
metric is due) and finite, and the compared tables carry what docs/guide.md, "Tables of the paper", promises:
a seed spread on every mean, a paired bootstrap interval and a verdict on every difference, AMCR on
the runs' own removal masks next to the unseen share, and no "best" without an interval excluding 0.
Usage: python .ci/check_tables.py RESULTS_DIR N_RUNS"""

import json
import math
import sys
from pathlib import Path

import pandas as pd
import yaml

results, n_runs = Path(sys.argv[1]), int(sys.argv[2])
problems = []
COMPARED = ("psnr", "roi_psnr", "masked_psnr", "lpips", "roi_lpips", "masked_lpips")
tables = {}
for name in ("per_scene", "table1_average", "table3_ablation", "table2_runtime"):
    for ext in ("csv", "md", "tex"):
        if not (results / f"{name}.{ext}").is_file():
            problems.append(f"{name}.{ext} missing")
    if not (results / f"{name}.csv").is_file():
        continue
    df = tables[name] = pd.read_csv(results / f"{name}.csv")
    if df.empty:
        problems.append(f"{name}.csv has no rows")
    nums = df.select_dtypes("number")
    bad = [c for c in nums.columns if not nums[c].map(lambda v: math.isfinite(v) if not pd.isna(v) else True).all()]
    if bad:
        problems.append(f"{name}.csv: non-finite values in {bad}")
    if name != "table2_runtime":
        for col in (*COMPARED, "amcr", "roi_depth_off"):
            if col in df.columns and df.loc[df.get("row_type", pd.Series("mean", index=df.index)) != "difference", col].isna().any():
                problems.append(f"{name}.csv: empty cells in {col}")
            elif col not in df.columns:
                problems.append(f"{name}.csv: no column {col}")

per_scene = tables.get("per_scene")
if per_scene is not None:
    if len(per_scene) != n_runs:
        problems.append(f"per_scene.csv has {len(per_scene)} rows, expected {n_runs}")
    for col in ("seed", "unseen_share", "amcr"):
        if col not in per_scene.columns or per_scene[col].isna().any():
            problems.append(f"per_scene.csv: column {col} missing or incomplete")
    seeds = sorted(per_scene["seed"].dropna().unique()) if "seed" in per_scene.columns else []

for name in ("table1_average", "table3_ablation"):
    df = tables.get(name)
    if df is None or "row_type" not in df.columns:
        problems.append(f"{name}.csv: no row_type column (mean / difference rows)")
        continue
    means, diffs = df[df["row_type"] == "mean"], df[df["row_type"] == "difference"]
    if means.empty or diffs.empty:
        problems.append(f"{name}.csv: expected mean and difference rows, got {len(means)} and {len(diffs)}")
    for col in COMPARED:
        if len(seeds) > 1 and means[f"{col}_std"].isna().any():
            problems.append(f"{name}.csv: a mean without its seed spread in {col}")
        if (diffs["n_runs"] >= 3).any() and diffs.loc[diffs["n_runs"] >= 3, [f"{col}_ci_low", f"{col}_ci_high"]].isna().any().any():
            problems.append(f"{name}.csv: a difference without its interval in {col}")
        if not (diffs[f"{col}_ci_low"].fillna(0) <= diffs[f"{col}_ci_high"].fillna(0)).all():
            problems.append(f"{name}.csv: an interval with its ends swapped in {col}")
        if not diffs[f"{col}_mark"].isin(["better", "worse", "tied"]).all():
            problems.append(f"{name}.csv: a difference without a verdict in {col}")
        marks = means[f"{col}_mark"].fillna("")
        if not marks.isin(["best", "tied", ""]).all():
            problems.append(f"{name}.csv: unknown mark in {col}: {sorted(set(marks))}")
        # a best mean row: its difference rows in this column say it is better than what it is compared with
        for _, row in means[marks == "best"].iterrows():
            mine = diffs[(diffs["method"] == row["method"])] if name == "table1_average" else diffs.iloc[0:0]
            if (mine[f"{col}_mark"] == "tied").any():
                problems.append(f"{name}.csv: {row['method']} marked best in {col} while a difference with it is tied")

try:
    prov = json.loads((results / "provenance.json").read_text())
    for key in ("git_commit", "config", "packages", "machine", "weights", "seeds", "bootstrap"):
        if key not in prov:
            problems.append(f"provenance.json lacks {key}")
    # the recorded configuration is this run's (written with the tables), not an older file's
    used = yaml.safe_load(prov.get("config", {}).get("content") or "") or {}
    if Path(str(used.get("results_dir"))).resolve() != results.resolve():
        problems.append(f"provenance.json records the config of another run (results_dir {used.get('results_dir')!r})")
    if per_scene is not None and sorted(prov.get("seeds") or []) != [int(s) for s in seeds]:
        problems.append(f"provenance.json seeds {prov.get('seeds')} are not the runs' {seeds}")
except (OSError, ValueError, yaml.YAMLError) as e:
    problems.append(f"provenance.json unreadable ({type(e).__name__})")
if problems:
    print("tables incomplete: " + "; ".join(problems))
    sys.exit(1)
print(f"tables complete and finite ({n_runs} runs, seeds {', '.join(str(int(s)) for s in seeds)}) in {results}")
