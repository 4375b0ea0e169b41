"""What a compared table (``table1_average``, ``table3_ablation``) must satisfy to carry its verdicts
(docs/guide.md, "Tables of the paper"), checked on its CSV: ``inpaint360gs table paper`` checks every
table it builds before writing it, and the CI's table check (``.ci/check_tables.py``) every table the
workflow wrote.

- every row says over how many runs and scenes it is (``n_runs``, ``n_scenes``);
- a difference over fewer than :data:`.stats.MIN_SCENES` scenes is marked :data:`.stats.SEED_NOISE`
  in every compared column, and no mean row over so few scenes is bold (``best``) or ``(tied)``;
- a difference over enough scenes has its interval (from :data:`.stats.MIN_PAIRS` runs on) and a
  verdict that agrees with it: ``better`` / ``worse`` only when the interval excludes zero, ``tied``
  only when it does not;
- a row marked ``best`` has no tied difference (Tab. 1, where the differences name their row).
"""

from __future__ import annotations

import pandas as pd

from inpaint360gs.report import stats

VERDICTS = ("better", "worse", "tied")


def _text(v) -> str:
    return "" if v is None or (isinstance(v, float) and pd.isna(v)) else str(v)


def _compared_columns(df: pd.DataFrame) -> list[str]:
    """The statistics columns (those with ``_mark`` and ``_ci_low`` beside them)."""
    return [c for c in df.columns if f"{c}_mark" in df.columns and f"{c}_ci_low" in df.columns]


def compared_table_problems(name: str, df: pd.DataFrame) -> list[str]:
    """Every way ``df`` (the CSV of compared table ``name``) breaks the module docstring's rules, one line each."""
    problems = [f"{name}.csv: no {c} column" for c in ("row_type", "n_runs", "n_scenes") if c not in df.columns]
    if problems:
        return problems + ([f"{name}.csv: without n_scenes a scene-level interval cannot be told from seed noise"]
                           if "n_scenes" not in df.columns else [])
    cols = _compared_columns(df)
    diffs, means = df[df["row_type"] == "difference"], df[df["row_type"] == "mean"]
    for i, row in diffs.iterrows():
        who = f"{name}.csv row {i + 2} ({_text(row.get('name') or row.get('row'))})"
        few = int(row["n_scenes"]) < stats.MIN_SCENES
        for c in cols:
            if pd.isna(row[c]):
                continue  # not compared (a context column) or null (the notes say why)
            mark, low, high = _text(row[f"{c}_mark"]), row[f"{c}_ci_low"], row[f"{c}_ci_high"]
            if few:
                if mark != stats.SEED_NOISE:
                    problems.append(f"{who}: {c} compares {int(row['n_scenes'])} scene(s) (fewer than {stats.MIN_SCENES}) "
                                    f"but is marked {mark or 'nothing'!r}, not {stats.SEED_NOISE!r}")
                continue
            if mark not in VERDICTS:
                problems.append(f"{who}: {c} has no verdict (mark {mark!r})")
                continue
            if pd.isna(low) or pd.isna(high):
                if int(row["n_runs"]) >= stats.MIN_PAIRS:
                    problems.append(f"{who}: {c} has no interval over {int(row['n_scenes'])} scenes")
                elif mark != "tied":
                    problems.append(f"{who}: {c} is {mark} without an interval")
                continue
            if low > high:
                problems.append(f"{who}: {c} has its interval's ends swapped")
            excludes = low > 0 or high < 0
            if excludes != (mark in ("better", "worse")):
                problems.append(f"{who}: {c} is {mark} but its interval [{low:.4g}, {high:.4g}] {'excludes' if excludes else 'includes'} 0")
    for i, row in means.iterrows():
        if int(row["n_scenes"]) >= stats.MIN_SCENES:
            continue
        marked = [c for c in cols if _text(row[f"{c}_mark"]) in ("best", "tied")]
        if marked:
            problems.append(f"{name}.csv row {i + 2}: a mean over {int(row['n_scenes'])} scene(s) is marked best or tied in {', '.join(marked)}")
    if "method" in df.columns and "vs" in df.columns:  # Tab. 1: a best row's differences must not be tied
        for c in cols:
            for _, row in means[means[f"{c}_mark"].map(_text) == "best"].iterrows():
                mine = diffs[diffs["method"] == row["method"]]
                if (mine[f"{c}_mark"].map(_text).isin(["tied", stats.SEED_NOISE])).any():
                    problems.append(f"{name}.csv: {row['method']} is marked best in {c} while a difference with it is not a verdict")
    return problems
