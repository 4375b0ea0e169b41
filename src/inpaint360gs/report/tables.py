"""Collect per-scene ``metrics.json`` files into CSV and Markdown tables (pandas).

Every table carries its provenance (git commit, date, command inputs) so a figure in ``results/``
can be traced to the code that produced it.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import pandas as pd

from inpaint360gs.core.errors import InputError
from inpaint360gs.core.files import check_readable
from inpaint360gs.io.atomic import atomic_path, write_text
from inpaint360gs.report.provenance import provenance_line


def load_metrics(paths: list[str | Path]) -> list[dict]:
    """Read per-scene ``metrics.json`` files: each must be a JSON object; the same file twice is refused."""
    rows, seen = [], {}
    for p in paths:
        p = Path(p)
        check_readable(p, "a metrics.json file", missing="metrics file not found")
        try:
            key = p.resolve()
            if key in seen:
                raise InputError(f"given twice (also as {seen[key]}); each scene must count once in the average", p)
            seen[key] = p
            data = json.loads(p.read_text())
        except FileNotFoundError:
            raise InputError("metrics file not found", p) from None
        except UnicodeDecodeError:
            raise InputError("not a text file (expected metrics.json)", p) from None
        except json.JSONDecodeError as e:
            raise InputError(f"not valid JSON ({e.msg} at line {e.lineno})", p) from None
        if not isinstance(data, dict):
            raise InputError(f"expected a JSON object of metrics, found a JSON {type(data).__name__}", p)
        data["_path"] = str(p)
        rows.append(data)
    if not rows:
        raise InputError("no metrics files given")
    return rows


def table_with_average(rows: list[dict], columns: dict[str, str], index: str = "scene") -> pd.DataFrame:
    """DataFrame of ``columns`` (json key -> column title) per row plus an ``average`` row.

    Every cell must be a finite number: a missing, null, non-numeric or infinite value is refused
    (an average over a different set of rows than the table shows would be wrong), and so are two
    rows for the same scene.
    """
    names: dict[str, str] = {}
    for r in rows:
        where = r.get("_path", "metrics")
        if not isinstance(r.get(index), str):
            raise InputError(f"no {index!r} name (a string) in the metrics", where)
        if r[index] in names:
            raise InputError(f"{index} {r[index]!r} appears twice (also in {names[r[index]]})", where)
        names[r[index]] = where
        for k in columns:
            if k not in r:
                raise InputError(f"field {k!r} missing (every table column needs it in every file)", where)
            v = r[k]
            if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
                raise InputError(f"field {k!r} must be a finite number, got {v!r}", where)
    df = pd.DataFrame([{index: r[index], **{title: r[k] for k, title in columns.items()}} for r in rows])
    df = df.set_index(index)
    df.loc["average"] = df.mean(numeric_only=True)
    return df


def write_tables(df: pd.DataFrame, csv: str | Path | None, md: str | Path | None, title: str, floatfmt: str) -> None:
    """Write ``df`` as CSV to ``csv`` and as Markdown (with ``title`` and a provenance line) to ``md``, each when not
    None."""
    if csv is not None:
        with atomic_path(csv) as tmp:
            df.to_csv(tmp, float_format="%.6g")
    if md is not None:
        body = df.to_markdown(floatfmt=floatfmt)
        write_text(md, f"# {title}\n\n{body}\n\nProvenance: {provenance_line()}\n")
