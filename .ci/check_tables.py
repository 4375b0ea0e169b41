"""CI: every table the workflow wrote is complete (one row per expected run, no empty cell where a
metric is due) and finite, and the compared tables carry what docs/guide.md, "Tables of the paper", promises:
a seed spread on every mean; on every difference over at least three scenes an interval that resamples
scenes and a verdict that agrees with it, and over fewer the mark "seed noise only" and no first place
(inpaint360gs.report.checks); no "best" without an interval excluding 0; AMCR over the training views
next to the silhouette at the test cameras and the unseen share; every run's ground-truth removal
scores, and every run above a removal limit named under Tab. 1; provenance.json saying that the
intervals resample scenes.
Usage: python .ci/check_tables.py RESULTS_DIR N_RUNS"""

import json
import math
import sys
from pathlib import Path

import pandas as pd
import yaml

from inpaint360gs.metrics.removal import limits_exceeded
from inpaint360gs.report.checks import compared_table_problems

results, n_runs = Path(sys.argv[1]), int(sys.argv[2])
problems = []
COMPARED = ("psnr", "masked_psnr", "lpips", "roi_lpips", "masked_lpips")
CONTEXT = ("amcr", "silhouette_test", "unseen_share", "residual", "collateral", "gt_footprint_share")
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
seeds = []
if per_scene is not None:
    if len(per_scene) != n_runs:
        problems.append(f"per_scene.csv has {len(per_scene)} rows, expected {n_runs}")
    for col in ("seed", *CONTEXT):
        if col not in per_scene.columns or per_scene[col].isna().any():
            problems.append(f"per_scene.csv: column {col} missing or incomplete")
    seeds = sorted(per_scene["seed"].dropna().unique()) if "seed" in per_scene.columns else []

for name in ("table1_average", "table3_ablation"):
    df = tables.get(name)
    if df is None or "row_type" not in df.columns:
        problems.append(f"{name}.csv: no row_type column (mean / difference rows)")
        continue
    if "roi_psnr" in df.columns:
        problems.append(f"{name}.csv: averages ROI PSNR, masked PSNR plus a per-scene constant (one result twice)")
    means, diffs = df[df["row_type"] == "mean"], df[df["row_type"] == "difference"]
    if means.empty or diffs.empty:
        problems.append(f"{name}.csv: expected mean and difference rows, got {len(means)} and {len(diffs)}")
    for col in COMPARED:
        if len(seeds) > 1 and means[f"{col}_std"].isna().any():
            problems.append(f"{name}.csv: a mean without its seed spread in {col}")
    problems += compared_table_problems(name, df)

t1_md = results / "table1_average.md"
if per_scene is not None and t1_md.is_file():  # every run above a removal limit is named under Tab. 1
    listed = [line for line in t1_md.read_text().splitlines() if "ABOVE LIMIT: " in line]
    for _, row in per_scene.iterrows():
        run = row["scene"] if pd.isna(row.get("seed")) else f"{row['scene']} (seed {int(row['seed'])})"
        for limit, value, _most in limits_exceeded({k: (None if pd.isna(row.get(k)) else row.get(k)) for k in CONTEXT}):
            if not any(f"ABOVE LIMIT: {run} [" in line and f"]: {limit} " in line
                       and row["method"] in line.split("method(s) ")[-1].rstrip(".").split(", ") for line in listed):
                problems.append(f"table1_average.md does not name {run} {row['method']} above its {limit} limit ({value:.2f})")

try:
    prov = json.loads((results / "provenance.json").read_text())
    for key in ("git_commit", "config", "packages", "machine", "weights", "seeds", "bootstrap"):
        if key not in prov:
            problems.append(f"provenance.json lacks {key}")
    if (prov.get("bootstrap") or {}).get("resampling_unit") != "scene":
        problems.append("provenance.json does not say that the intervals resample scenes (bootstrap.resampling_unit)")
    # the recorded configuration is this run's (written with the tables), not an older file's
    used = yaml.safe_load((prov.get("config") or {}).get("content") or "") or {}
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
