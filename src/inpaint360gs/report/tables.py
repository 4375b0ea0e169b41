"""Collect per-scene ``metrics.json`` files into CSV and Markdown tables (pandas).

Every table carries its provenance (git commit, date, command inputs) so a figure in ``results/``
can be traced to the code that produced it.
"""

from __future__ import annotations

import datetime as _dt
import json
import platform
import subprocess
from pathlib import Path

import pandas as pd

from inpaint360gs.core.errors import InputError
from inpaint360gs.io.atomic import atomic_path, write_text


def git_commit() -> str:
    """Short commit hash of the working tree (with ``-dirty`` when tracked files outside ``results/``
    have changes), or ``unknown``. Committed tables under ``results/`` do not count: Snakemake deletes
    a job's old outputs before it runs, so the table being rewritten would always look modified."""
    try:
        rev = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, check=True)
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no", "--", ".", ":(exclude)results"],
                               capture_output=True, text=True)
        return rev.stdout.strip() + ("-dirty" if dirty.stdout.strip() else "")
    except (OSError, subprocess.CalledProcessError):
        return "unknown"


def provenance_line() -> str:
    now = _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    return f"commit {git_commit()}, {now}, {platform.machine()} {platform.processor() or ''}".strip()


def load_metrics(paths: list[str | Path]) -> list[dict]:
    rows = []
    for p in paths:
        p = Path(p)
        try:
            rows.append(json.loads(p.read_text()))
        except FileNotFoundError:
            raise InputError("metrics file not found", p) from None
        except json.JSONDecodeError as e:
            raise InputError(f"not valid JSON ({e.msg} at line {e.lineno})", p) from None
    if not rows:
        raise InputError("no metrics files given")
    return rows


def table_with_average(rows: list[dict], columns: dict[str, str], index: str = "scene") -> pd.DataFrame:
    """DataFrame of ``columns`` (json key -> column title) per row plus an ``average`` row."""
    missing = [(r.get(index, "?"), k) for r in rows for k in columns if k not in r]
    if missing:
        raise InputError(f"metrics lack fields: {missing[:5]}")
    df = pd.DataFrame([{index: r[index], **{title: r[k] for k, title in columns.items()}} for r in rows])
    df = df.set_index(index)
    df.loc["average"] = df.mean(numeric_only=True)
    return df


def write_tables(df: pd.DataFrame, csv: str | Path | None, md: str | Path | None, title: str, floatfmt: str) -> None:
    if csv is not None:
        with atomic_path(csv) as tmp:
            df.to_csv(tmp, float_format="%.6g")
    if md is not None:
        body = df.to_markdown(floatfmt=floatfmt)
        write_text(md, f"# {title}\n\n{body}\n\nProvenance: {provenance_line()}\n")
