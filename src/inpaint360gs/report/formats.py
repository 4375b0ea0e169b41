"""Render a :class:`.table_model.Table` as CSV (full precision, every statistic a column), Markdown
(title, table, legend, notes, provenance line) or a LaTeX booktabs ``table`` environment.
"""

from __future__ import annotations

import pandas as pd

from inpaint360gs.report import stats
from inpaint360gs.report.provenance import provenance_line
from inpaint360gs.report.stats import HIGHER, NONE
from inpaint360gs.report.table_model import MISSING, NOT_RUN, SUFFIXES, Column, Table


def _fmt(v: float | None, fmt: str) -> str:
    return MISSING if v is None else format(v, fmt)


def _cell(row: dict, col: Column, bold, escape) -> str:
    """A cell's text: ``mean ± std`` (bold when best, ``(tied)`` when tied for first), or for a Δ
    row ``+diff [low, high] verdict``; an empty cell where a Δ row does not compare the column."""
    if col.key in row.get("_not_run", ()):
        return escape(NOT_RUN)
    v = row.get(col.key)
    if row.get("row_type") == "difference" and col.stats:
        if v is None:
            return "" if col.direction == NONE else escape(MISSING)
        text = format(v, "+" + col.fmt)
        low, high = row.get(f"{col.key}_ci_low"), row.get(f"{col.key}_ci_high")
        if low is not None and high is not None:
            text += f" [{format(low, col.fmt)}, {format(high, col.fmt)}]"
        mark = row.get(f"{col.key}_mark")
        return escape(f"{text} {mark}" if mark else text)
    text = _fmt(v, col.fmt)
    std = row.get(f"{col.key}_std")
    if v is not None and std is not None:
        text += f" ± {format(std, col.fmt)}"
    mark = row.get(f"{col.key}_mark")
    if mark == "best":
        return bold(escape(text))
    return escape(f"{text} (tied)" if mark == "tied" else text)


def _cells(table: Table, bold, escape) -> tuple[list[str], list[list[str]]]:
    labels = [(k, t) for k, t in table.labels if k not in table.csv_only]
    head = [escape(t) for _, t in labels] + [c.title for c in table.columns]
    if table.note_column:
        head.append(escape("note"))
    body = []
    for row in table.rows:
        cells = [escape(str(row.get(k) or "")) for k, _ in labels]
        cells += [_cell(row, c, bold, escape) for c in table.columns]
        if table.note_column:
            cells.append(escape(str(row.get(table.note_column) or "")))
        body.append(cells)
    return head, body


def to_csv(table: Table) -> str:
    """``table`` as CSV text: label columns, each metric column with its statistics, the note column."""
    cols = [k for k, _ in table.labels]
    for c in table.columns:
        cols.append(c.key)
        if c.stats:
            cols += [f"{c.key}_{s}" for s in SUFFIXES]
    if table.note_column:
        cols.append(table.note_column)
    df = pd.DataFrame([{k: row.get(k) for k in cols} for row in table.rows], columns=cols)
    return df.to_csv(index=False, float_format="%.10g")


def _arrow(direction: int, tex: bool) -> str:
    if direction == NONE:
        return ""
    if tex:
        return r" $\uparrow$" if direction == HIGHER else r" $\downarrow$"
    return " ↑" if direction == HIGHER else " ↓"


def _legend(table: Table, bold: str) -> str:
    text = ""
    if table.compared:
        text = ("Value ± standard deviation over seeds of the average over scenes (no ± with one seed); "
                f"Δ rows: mean paired difference [{stats.CONFIDENCE:.0%} bootstrap interval resampling scenes, each with all its seeds] "
                f"and better / worse (the interval excludes 0) or tied (it includes 0); \"{stats.SEED_NOISE}\" where fewer than "
                f"{stats.MIN_SCENES} scenes are compared (the interval then resamples runs: no verdict). ↑ higher is better, ↓ lower is "
                f"better; {bold}: better than every other compared row with a scene-level interval excluding 0; (tied): tied for first. ")
    text += f"{MISSING} = no value (see the notes)"
    return text + (f", {NOT_RUN} = stage not run by this method." if any(r.get("_not_run") for r in table.rows) else ".")


def to_markdown(table: Table, footer: str | None = None) -> str:
    """Title, table, legend, notes and ``footer`` (default: the provenance line)."""
    cols = [Column(c.key, c.title + _arrow(c.direction, False), c.direction, c.fmt, c.stats) for c in table.columns]
    t = Table(**{**table.__dict__, "columns": cols})
    head, body = _cells(t, "**{}**".format, lambda s: s.replace("|", "\\|"))
    text = pd.DataFrame(body, columns=head).to_markdown(index=False, disable_numparse=True) if body else "(no rows)"
    notes = "".join(f"- {n}\n" for n in table.notes)
    return (f"# {table.title}\n\n{text}\n\n{_legend(table, '**bold**')}\n\n" + (f"Notes:\n\n{notes}\n" if notes else "")
            + (footer if footer is not None else f"Provenance: {provenance_line()}; inputs and versions in provenance.json.") + "\n")


_TEX_SPECIAL = {"\\": r"\textbackslash{}", "&": r"\&", "%": r"\%", "$": r"\$", "#": r"\#", "_": r"\_", "{": r"\{", "}": r"\}",
                "~": r"\textasciitilde{}", "^": r"\textasciicircum{}", "–": "--", "—": "---", "↑": r"$\uparrow$", "↓": r"$\downarrow$",
                "±": r"$\pm$", "Δ": r"$\Delta$", "−": r"$-$", "×": r"$\times$"}


def tex_escape(s: str) -> str:
    """``s`` with LaTeX's special characters escaped."""
    return "".join(_TEX_SPECIAL.get(ch, ch) for ch in s)


def to_latex(table: Table) -> str:
    """A booktabs ``table`` environment (needs ``\\usepackage{booktabs}``); notes in the caption."""
    cols = [Column(c.key, tex_escape(c.title) + _arrow(c.direction, True), c.direction, c.fmt, c.stats) for c in table.columns]
    t = Table(**{**table.__dict__, "columns": cols})
    head, body = _cells(t, r"\textbf{{{}}}".format, tex_escape)
    n_labels = len([k for k, _ in table.labels if k not in table.csv_only])
    spec = "l" * n_labels + "r" * len(table.columns) + ("l" if table.note_column else "")
    lines = [
        f"% {table.title} -- written by inpaint360gs table paper; needs \\usepackage{{booktabs}}",
        "\\begin{table}[t]", "\\centering", "\\footnotesize", f"\\begin{{tabular}}{{{spec}}}", "\\toprule",
        " & ".join(head) + r" \\", "\\midrule",
    ]
    prev = None
    for row, cells in zip(table.rows, body):
        if table.rule_by and prev is not None and row.get(table.rule_by) != prev:
            lines.append("\\midrule")
        prev = row.get(table.rule_by) if table.rule_by else None
        lines.append(" & ".join(cells) + r" \\")
    lines += ["\\bottomrule", "\\end{tabular}"]
    caption = " ".join([f"\\textbf{{{tex_escape(table.title)}.}}", tex_escape(_legend(table, "bold")), *(tex_escape(n) for n in table.notes)])
    lines += [f"\\caption{{{caption}}}", f"\\label{{tab:{table.name.replace('_', '-')}}}", "\\end{table}", ""]
    return "\n".join(lines)
