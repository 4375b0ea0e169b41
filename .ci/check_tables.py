"""CI: every table the workflow wrote is complete (one row per expected run, no empty cell where a
metric is due) and finite. Usage: python .ci/check_tables.py RESULTS_DIR N_RUNS"""

import json
import math
import sys
from pathlib import Path

import pandas as pd
import yaml

results, n_runs = Path(sys.argv[1]), int(sys.argv[2])
problems = []
for name in ("per_scene", "table1_average", "table3_ablation", "table2_runtime"):
    for ext in ("csv", "md", "tex"):
        if not (results / f"{name}.{ext}").is_file():
            problems.append(f"{name}.{ext} missing")
    if not (results / f"{name}.csv").is_file():
        continue
    df = pd.read_csv(results / f"{name}.csv")
    if df.empty:
        problems.append(f"{name}.csv has no rows")
    nums = df.select_dtypes("number")
    bad = [c for c in nums.columns if not nums[c].map(lambda v: math.isfinite(v) if not pd.isna(v) else True).all()]
    if bad:
        problems.append(f"{name}.csv: non-finite values in {bad}")
    if name != "table2_runtime":
        for col in ("psnr", "roi_psnr", "masked_psnr", "lpips", "roi_lpips", "masked_lpips"):
            hits = [c for c in df.columns if c == col or c.startswith(col + " ") or c.endswith(" " + col)]
            for c in hits:
                if df[c].isna().any():
                    problems.append(f"{name}.csv: empty cells in {c}")
per_scene = pd.read_csv(results / "per_scene.csv") if (results / "per_scene.csv").is_file() else None
if per_scene is not None and len(per_scene) != n_runs:
    problems.append(f"per_scene.csv has {len(per_scene)} rows, expected {n_runs}")
try:
    prov = json.loads((results / "provenance.json").read_text())
    for key in ("git_commit", "config", "packages", "machine", "weights"):
        if key not in prov:
            problems.append(f"provenance.json lacks {key}")
    # the recorded configuration is this run's (written with the tables), not an older file's
    used = yaml.safe_load(prov.get("config", {}).get("content") or "") or {}
    if Path(str(used.get("results_dir"))).resolve() != results.resolve():
        problems.append(f"provenance.json records the config of another run (results_dir {used.get('results_dir')!r})")
except (OSError, ValueError, yaml.YAMLError) as e:
    problems.append(f"provenance.json unreadable ({type(e).__name__})")
if problems:
    print("tables incomplete: " + "; ".join(problems))
    sys.exit(1)
print(f"tables complete and finite ({n_runs} runs) in {results}")
