"""The paper's tables from per-run records (:mod:`.records`): ``inpaint360gs table paper``.

Written into one folder, each table as ``.csv`` (full precision), ``.md`` and ``.tex`` (booktabs). A
*run* is one (scene, seed) of a method. The comparisons follow :mod:`.stats`: a row's value is its
mean over its runs ``±`` the seed spread; a Δ row is the mean paired difference with its 95 %
bootstrap interval resampling scenes and ``better`` / ``worse`` / ``tied``, or ``seed noise only``
over fewer than three scenes; a value is **bold** only when its row beats every other compared row
with a scene-level interval that excludes zero, otherwise the rows tied with the best are ``(tied)``.

The tables:

- ``per_scene``: every metric of every run (paper supp. "Per-Scene Breakdown"), no marks;
- ``table1_average``: methods and baselines, PSNR / SSIM / LPIPS full, ``masked_*`` and ``roi_*``
  (ROI PSNR left out: masked PSNR plus a per-scene constant), FID (or the labelled substitute
  ``fd_vgg16``) and the fill's geometry (``roi_depth_off``), with Δ rows for the method minus each
  baseline; AMCR (supp. Eq. 1, each run's own removal masks over the training views), the
  ground-truth removal scores and the unseen share as context columns (paper Tab. 1), and every run
  above a removal limit listed by name under it;
- ``table3_ablation``: ablations a)-e) against the full method on the runs each ablation has (one
  block per set of scenes), Δ rows and a note per ablation on what it changes (paper Tab. 3);
- ``table2_runtime`` and ``table2_runtime_detail``: minutes per stage, storage, peak RSS (paper
  Tab. 2 and supp. "Detailed Runtime"), no marks;
- ``provenance.json``: commit, config, package versions, machine, seeds, bootstrap settings (the
  resampling unit: the scene), weights files (basename, sha256) and the input records.

Averages use only the runs every compared row has (the notes say what was left out). Every table is
built, the compared ones checked (:mod:`.checks`), before the first file is written, each atomically.
Built by :mod:`.builders`, rendered by :mod:`.formats`, plotted by :mod:`.figures`, ``keep_failed``
copied by :mod:`.failed`; this module writes the files.
"""

from __future__ import annotations

import io
import json
from pathlib import Path

import pandas as pd

from inpaint360gs.io.atomic import atomic_path, write_text
from inpaint360gs.report.builders import per_scene_table, table1, table2, table2_detail, table3, views_sweep
from inpaint360gs.report.checks import compared_table_problems
from inpaint360gs.report.failed import keep_failed as copy_failed
from inpaint360gs.report.figures import sweep_plot
from inpaint360gs.report.formats import to_csv, to_latex, to_markdown
from inpaint360gs.report.provenance import provenance, provenance_line, read_config
from inpaint360gs.report.records import load_records
from inpaint360gs.report.table_model import Bootstrap, Table


COMPARED = ("table1_average", "table3_ablation")  # built with the bootstrap settings
TABLES = (("per_scene", per_scene_table), ("table1_average", table1), ("table3_ablation", table3),
          ("table2_runtime", table2), ("table2_runtime_detail", table2_detail))


def output_names() -> list[str]:
    """The file names the paper tables are written to (CSV, Markdown, LaTeX each, and provenance.json)."""
    return [f"{name}.{ext}" for name, _ in TABLES for ext in ("csv", "md", "tex")] + ["provenance.json"]


def paper_tables(record_paths: list[str | Path], out_dir: str | Path, *, config: str | Path | None = None,
                 seeds: list[int] | None = None, boot: Bootstrap = Bootstrap(), keep_failed: str | Path | None = None) -> dict[str, Table]:
    """Read the records, build every table and write them into ``out_dir`` (see the module docstring);
    with ``keep_failed``, copy the runs above a removal limit there (:mod:`.failed`).

    Everything is read, checked and rendered before the first file is written. A compared table that
    breaks :mod:`.checks` is a bug here: RuntimeError, nothing written."""
    records = load_records(list(record_paths))
    cfg = read_config(config)
    tables = {name: build(records, boot) if name in COMPARED else build(records) for name, build in TABLES}
    files: dict[str, str] = {}
    footer = f"Provenance: {provenance_line()}; inputs and versions in provenance.json."
    for name, t in tables.items():
        files[f"{name}.csv"] = to_csv(t)
        files[f"{name}.md"] = to_markdown(t, footer)
        files[f"{name}.tex"] = to_latex(t)
        if name in COMPARED:
            problems = compared_table_problems(name, pd.read_csv(io.StringIO(files[f"{name}.csv"])))
            if problems:
                raise RuntimeError(f"{name} breaks its own rules: {'; '.join(problems[:3])}")
    blobs: dict[str, bytes] = {}
    sweep = views_sweep(records)
    if sweep is not None:
        tables["views_sweep"] = sweep
        files["views_sweep.csv"] = to_csv(sweep)
        files["views_sweep.md"] = to_markdown(sweep, footer)
        files["views_sweep.tex"] = to_latex(sweep)
        blobs["views_sweep.png"] = sweep_plot(sweep)
    files["provenance.json"] = json.dumps(provenance(records, cfg, seeds, list(files), boot), indent=1, allow_nan=False, default=str) + "\n"
    out = Path(out_dir)
    for fname, text in files.items():
        write_text(out / fname, text)
    for fname, data in blobs.items():
        with atomic_path(out / fname) as tmp:
            tmp.write_bytes(data)
    if keep_failed is not None:
        copy_failed(records, keep_failed)
    return tables
