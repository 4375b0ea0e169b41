"""The paper's tables from per-run records (:mod:`.records`): ``inpaint360gs table paper``.

Written into one folder, each table as ``.csv`` (numbers at full precision), ``.md`` and ``.tex``
(booktabs; the best / second / third value of each column marked as the paper marks them, with the
metric's direction: higher is better for PSNR and SSIM, lower for LPIPS, FID, FD, KID, AMCR, minutes
and megabytes):

- ``per_scene``: every metric of every (scene, method, segmenter) (paper supp. "Per-Scene Breakdown");
  marks among the methods and baselines of each scene;
- ``table1_average``: methods and baselines, PSNR / SSIM / LPIPS full, ``masked_*`` and ``roi_*``, and
  FID, or the labelled substitute ``fd_vgg16`` where FID is null, averaged over scenes (paper Tab. 1);
- ``table3_ablation``: the ablations a)-e) against the full method, same metrics (paper Tab. 3);
- ``table2_runtime``: per method, minutes per stage and in total, model storage in MB, peak RSS,
  averaged over scenes (paper Tab. 2); ``table2_runtime_detail``: every scene's stages and their
  average per method (paper supp. "Detailed Runtime");
- ``provenance.json``: git commit, the workflow config, package versions, machine, seeds, weights
  files (basename and sha256) and the input records.

Averages are taken only over the scenes every compared row has (a row with more scenes keeps them
in ``per_scene`` and the note under the table names what was left out); records without metrics
(scenes without ground truth) are listed in ``per_scene`` with their reason and left out of every
average, which the notes say. Every table is built before the first file is written, and each
file is written atomically (docs/architecture.md, "Reliability").
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import importlib.metadata
import json
import os
import platform
from dataclasses import dataclass, field
from pathlib import Path

import pandas as pd

from inpaint360gs.core.errors import InputError
from inpaint360gs.core.files import check_readable
from inpaint360gs.io.atomic import atomic_path, write_text
from inpaint360gs.report.records import METRICS, load_records, sha256_file
from inpaint360gs.report.tables import git_commit, provenance_line

HIGHER, LOWER, NONE = 1, -1, 0

# metric -> (title, direction, format) in the paper's column order (Tab. 1, supp. per-scene table)
METRIC_COLUMNS: dict[str, tuple[str, int, str]] = {
    "psnr": ("PSNR", HIGHER, ".2f"),
    "masked_psnr": ("masked PSNR", HIGHER, ".2f"),
    "roi_psnr": ("ROI PSNR", HIGHER, ".2f"),
    "ssim": ("SSIM", HIGHER, ".4f"),
    "masked_ssim": ("masked SSIM", HIGHER, ".4f"),
    "roi_ssim": ("ROI SSIM", HIGHER, ".4f"),
    "lpips": ("LPIPS", LOWER, ".4f"),
    "masked_lpips": ("masked LPIPS", LOWER, ".4f"),
    "roi_lpips": ("ROI LPIPS", LOWER, ".4f"),
    "lpips_alex": ("LPIPS-Alex", LOWER, ".4f"),
    "masked_lpips_alex": ("masked LPIPS-Alex", LOWER, ".4f"),
    "roi_lpips_alex": ("ROI LPIPS-Alex", LOWER, ".4f"),
    "fid": ("FID", LOWER, ".2f"),
    "fd_vgg16": ("FD-VGG16", LOWER, ".2f"),
    "kid_vgg16": ("KID-VGG16", LOWER, ".4g"),
    "amcr": ("AMCR (%)", LOWER, ".2f"),
}
assert set(METRIC_COLUMNS) == set(METRICS)
# the averaged columns of Tabs. 1 and 3; the last one is FID or its substitute
AVERAGE_METRICS = ("psnr", "masked_psnr", "roi_psnr", "ssim", "masked_ssim", "roi_ssim", "lpips", "masked_lpips", "roi_lpips")

# paper Tab. 3: letter -> (name, method ids recognised without an ``ablation=`` label)
ABLATIONS: dict[str, tuple[str, tuple[str, ...]]] = {
    "a": ("w/o object association", ("wo_association",)),
    "b": ("w/o depth-guided initialisation", ("wo_depth_init",)),
    "c": ("w/o virtual views", ("wo_virtual_views",)),
    "d": ("w/o recursive conditioning", ("wo_conditioning",)),
    "e": ("w/o hybrid supervision", ("wo_hybrid",)),
}

# stages in pipeline order; others follow alphabetically. The total leaves out evaluation, which is
# not part of a method's cost (paper Tab. 2 counts training and inpainting).
STAGE_ORDER = ("train", "segment", "associate", "distill", "remove", "inpaint", "render", "evaluate")
NOT_IN_TOTAL = ("evaluate",)
KIND_ORDER = {"baseline": 0, "method": 1, "ablation": 2, "sweep": 3}

MARKS_MD = ("**{}**", "<ins>{}</ins>", "_{}_")
MARKS_TEX = (r"\textbf{{{}}}", r"\underline{{{}}}", r"\textit{{{}}}")
MISSING = "–"  # a value that is null (the notes say why)
NOT_RUN = "—"  # a stage the method does not have


@dataclass
class Column:
    key: str
    title: str
    direction: int = NONE
    fmt: str = ".4g"


@dataclass
class Table:
    name: str
    title: str
    labels: list[tuple[str, str]]  # (key, title) of the text columns
    columns: list[Column]  # numeric columns
    rows: list[dict] = field(default_factory=list)  # label values, numbers (None = missing), "_not_run": set of keys
    notes: list[str] = field(default_factory=list)
    rank_by: tuple[str, ...] = ()  # rows ranked within groups of equal values of these labels
    rank_rows: tuple[str, ...] | None = None  # kinds of rows that are ranked (None: all)
    rule_by: str | None = None  # a rule between rows where this label changes (.tex)
    csv_only: tuple[str, ...] = ()  # label keys shown only in the CSV
    note_column: str | None = None  # a text column shown last
    marked: bool = True  # best / second / third marks (False: a breakdown without comparisons)


def _fmt(v: float | None, fmt: str) -> str:
    return MISSING if v is None else format(v, fmt)


def ranks(table: Table) -> dict[tuple[int, str], int]:
    """(row index, column key) -> 1, 2 or 3 for the best, second and third value of each ranked
    column, within each group of ``rank_by``. Values equal as printed share a rank (dense ranking);
    a column whose values in a group are all equal as printed gets no marks there."""
    out: dict[tuple[int, str], int] = {}
    if not table.marked:
        return out
    groups: dict[tuple, list[int]] = {}
    for i, row in enumerate(table.rows):
        if table.rank_rows is None or row.get("kind") in table.rank_rows:
            groups.setdefault(tuple(row.get(k) for k in table.rank_by), []).append(i)
    for idx in groups.values():
        for col in table.columns:
            if col.direction == NONE:
                continue
            vals = {i: float(_fmt(table.rows[i][col.key], col.fmt)) for i in idx if table.rows[i].get(col.key) is not None}
            if len(set(vals.values())) < 2:  # one value, or all equal: nothing to tell apart
                continue
            distinct = sorted(set(vals.values()), reverse=col.direction == HIGHER)
            for i, v in vals.items():
                r = distinct.index(v) + 1
                if r <= 3:
                    out[(i, col.key)] = r
    return out


def _cells(table: Table, marks: tuple[str, str, str], escape) -> tuple[list[str], list[list[str]]]:
    rk = ranks(table)
    labels = [(k, t) for k, t in table.labels if k not in table.csv_only]
    head = [escape(t) for _, t in labels] + [c.title for c in table.columns]
    if table.note_column:
        head.append(escape("note"))
    body = []
    for i, row in enumerate(table.rows):
        cells = [escape(str(row.get(k, ""))) for k, _ in labels]
        for c in table.columns:
            if c.key in row.get("_not_run", ()):
                cells.append(NOT_RUN)
                continue
            text = _fmt(row.get(c.key), c.fmt)
            r = rk.get((i, c.key))
            cells.append(marks[r - 1].format(text) if r else text)
        if table.note_column:
            cells.append(escape(str(row.get(table.note_column) or "")))
        body.append(cells)
    return head, body


def to_csv(table: Table) -> str:
    cols = [k for k, _ in table.labels] + [c.key for c in table.columns] + ([table.note_column] if table.note_column else [])
    df = pd.DataFrame([{k: row.get(k) for k in cols} for row in table.rows], columns=cols)
    return df.to_csv(index=False, float_format="%.10g")


def _arrow(direction: int, tex: bool) -> str:
    if direction == NONE:
        return ""
    if tex:
        return r" $\uparrow$" if direction == HIGHER else r" $\downarrow$"
    return " ↑" if direction == HIGHER else " ↓"


def to_markdown(table: Table, footer: str | None = None) -> str:
    """Title, table, legend, notes and ``footer`` (default: the provenance line)."""
    cols = [Column(c.key, c.title + _arrow(c.direction, False), c.direction, c.fmt) for c in table.columns]
    t = Table(**{**table.__dict__, "columns": cols})
    head, body = _cells(t, MARKS_MD, lambda s: s.replace("|", "\\|"))
    if body:
        text = pd.DataFrame(body, columns=head).to_markdown(index=False, disable_numparse=True)
    else:
        text = "(no rows)"
    legend = "Per column (↑ higher is better, ↓ lower is better): **best**, <ins>second</ins>, _third_; " if table.marked else ""
    legend += f"{MISSING} = no value (see the notes)" + (f", {NOT_RUN} = stage not run by this method." if any(r.get("_not_run") for r in table.rows) else ".")
    notes = "".join(f"- {n}\n" for n in table.notes)
    return (f"# {table.title}\n\n{text}\n\n{legend}\n\n" + (f"Notes:\n\n{notes}\n" if notes else "")
            + (footer if footer is not None else f"Provenance: {provenance_line()}; inputs and versions in provenance.json.") + "\n")


_TEX_SPECIAL = {"\\": r"\textbackslash{}", "&": r"\&", "%": r"\%", "$": r"\$", "#": r"\#", "_": r"\_", "{": r"\{", "}": r"\}",
                "~": r"\textasciitilde{}", "^": r"\textasciicircum{}", "–": "--", "—": "---", "↑": r"$\uparrow$", "↓": r"$\downarrow$"}


def tex_escape(s: str) -> str:
    return "".join(_TEX_SPECIAL.get(ch, ch) for ch in s)


def to_latex(table: Table) -> str:
    """A booktabs ``table`` environment (needs ``\\usepackage{booktabs}``); notes in the caption."""
    cols = [Column(c.key, tex_escape(c.title) + _arrow(c.direction, True), c.direction, c.fmt) for c in table.columns]
    t = Table(**{**table.__dict__, "columns": cols})
    head, body = _cells(t, MARKS_TEX, tex_escape)
    body = [[tex_escape(x) if x in (MISSING, NOT_RUN) else x for x in row] for row in body]
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
    legend = (r"Per column: \textbf{best}, \underline{second}, \textit{third}; " if table.marked else "") + "-- = no value."
    caption = " ".join([f"\\textbf{{{tex_escape(table.title)}.}}", legend, *(tex_escape(n) for n in table.notes)])
    lines += [f"\\caption{{{caption}}}", f"\\label{{tab:{table.name.replace('_', '-')}}}", "\\end{table}", ""]
    return "\n".join(lines)


# --- grouping and averages ---------------------------------------------------------------------


def _key(rec: dict) -> tuple[str, str]:
    return rec["labels"]["method"], rec["labels"]["segmenter"]


def _name(rec: dict) -> str:
    return rec["labels"].get("name") or rec["labels"]["method"]


def _who(key: tuple[str, str]) -> str:
    return f"{key[0]}/{key[1]}"


def _groups(records: list[dict], kinds: tuple[str, ...]) -> dict[tuple[str, str], list[dict]]:
    """Records of ``kinds`` by (method, segmenter), baselines first, then in input order."""
    order = sorted((r for r in records if r["labels"]["kind"] in kinds), key=lambda r: KIND_ORDER[r["labels"]["kind"]])
    out: dict[tuple[str, str], list[dict]] = {}
    for r in order:
        out.setdefault(_key(r), []).append(r)
    return out


def _common_scenes(groups: dict[tuple[str, str], list[dict]], what: str, notes: list[str]) -> set[str]:
    """Scenes every group has; a note names each scene left out and the groups that lack it."""
    sets = {g: {r["labels"]["scene"] for r in recs} for g, recs in groups.items()}
    if not sets:
        return set()
    common = set.intersection(*sets.values())
    for s in sorted(set.union(*sets.values()) - common):
        have = [_who(g) for g, scenes in sets.items() if s in scenes]
        lacking = [_who(g) for g, scenes in sets.items() if s not in scenes]
        notes.append(f"Scene {s} is left out of every average: {', '.join(have)} {'has' if len(have) == 1 else 'have'} {what} there, "
                     f"{', '.join(lacking)} not (averages are over the same scenes for every row).")
    if not common:
        notes.append(f"No scene has {what} for every row: nothing is averaged.")
    return common


def _mean_row(key, recs: list[dict], metrics: tuple[str, ...], notes: list[str]) -> dict:
    row = {}
    for m in metrics:
        vals = [(r["labels"]["scene"], r["metrics"][m], r.get("null_reasons", {}).get(m)) for r in recs]
        nulls = [(s, why) for s, v, why in vals if v is None]
        if not recs:
            row[m] = None
        elif nulls:
            row[m] = None
            s, why = nulls[0]
            notes.append(f"{METRIC_COLUMNS[m][0]} of {_who(key)} is not averaged: null in scene {s}"
                         + (f" ({why})" if why else "") + (f" and {len(nulls) - 1} more" if len(nulls) > 1 else "") + ".")
        else:
            row[m] = sum(v for _, v, _ in vals) / len(vals)
    return row


def _without_metrics(records: list[dict], kinds: tuple[str, ...], notes: list[str]) -> list[dict]:
    """Records of ``kinds`` that have metrics; a note for each one left out for having none."""
    keep = []
    for r in records:
        if r["labels"]["kind"] not in kinds:
            continue
        if r.get("skip_reason"):
            notes.append(f"Scene {r['labels']['scene']} of {_who(_key(r))} has no metrics ({r['skip_reason']}); "
                         "it is listed in per_scene and left out of this average.")
        else:
            keep.append(r)
    return keep


def _fid_column(recs: list[dict], notes: list[str]) -> str:
    """``fid`` when every averaged record has it, else its substitute ``fd_vgg16`` (with a note)."""
    missing = [r for r in recs if r["metrics"]["fid"] is None]
    if not recs or not missing:
        return "fid"
    why = missing[0].get("null_reasons", {}).get("fid") or "no reason recorded"
    notes.append(f"FID is null in {len(missing)} of {len(recs)} averaged runs ({why}); the last column is its substitute "
                 "FD-VGG16 (Fréchet distance on VGG16 features), not comparable with the paper's FID values.")
    return "fd_vgg16"


def _metric_column(m: str, substitute: bool = False) -> Column:
    title, direction, fmt = METRIC_COLUMNS[m]
    return Column(m, title + (" (FID substitute)" if substitute else ""), direction, fmt)


def _average_table(name: str, title: str, records: list[dict], kinds: tuple[str, ...], notes: list[str]) -> tuple[Table, dict]:
    recs = _without_metrics(records, kinds, notes)
    groups = _groups(recs, kinds)
    common = _common_scenes(groups, "metrics", notes)
    used = {g: [r for r in rs if r["labels"]["scene"] in common] for g, rs in groups.items()}
    fid = _fid_column([r for rs in used.values() for r in rs], notes)
    metrics = (*AVERAGE_METRICS, fid)
    table = Table(
        name, title,
        labels=[("method", "Method"), ("name", "Method"), ("segmenter", "Segmenter"), ("kind", "Kind")],
        columns=[Column("n_scenes", "scenes"), *(_metric_column(m, m == "fd_vgg16") for m in metrics)],
        notes=notes, csv_only=("method",),
    )
    for g, rs in used.items():
        first = groups[g][0]
        row = {"method": g[0], "name": _name(first), "segmenter": g[1], "kind": first["labels"]["kind"], "n_scenes": len(rs)}
        row.update(_mean_row(g, rs, metrics, notes))
        table.rows.append(row)
    if common:
        notes.insert(0, f"Averaged over {len(common)} scene(s): {', '.join(sorted(common))}.")
    return table, groups


def per_scene_table(records: list[dict]) -> Table:
    notes: list[str] = []
    table = Table(
        "per_scene", "Per-scene results of every method, baseline and ablation",
        labels=[("scene", "Scene"), ("method", "Method"), ("name", "Method"), ("segmenter", "Segmenter"), ("kind", "Kind")],
        columns=[_metric_column(m) for m in METRIC_COLUMNS],
        notes=notes, rank_by=("scene",), rank_rows=("method", "baseline"), rule_by="scene", csv_only=("method",),
        note_column="note",
    )
    order = sorted(range(len(records)), key=lambda i: (records[i]["labels"]["scene"], KIND_ORDER[records[i]["labels"]["kind"]], i))
    reasons: dict[tuple[str, str], list[str]] = {}
    for i in order:
        r = records[i]
        lab = r["labels"]
        row = {"scene": lab["scene"], "method": lab["method"], "name": _name(r), "segmenter": lab["segmenter"], "kind": lab["kind"],
               "note": r.get("skip_reason") or ""}
        row.update({m: r["metrics"][m] for m in METRIC_COLUMNS})
        table.rows.append(row)
        if not r.get("skip_reason"):
            for m in METRIC_COLUMNS:
                if r["metrics"][m] is None:
                    reasons.setdefault((m, r.get("null_reasons", {}).get(m) or "no reason recorded"), []).append(f"{lab['scene']} {_who(_key(r))}")
    skipped = [r for r in records if r.get("skip_reason")]
    if skipped:
        notes.append(f"{len(skipped)} run(s) have no metrics (reason in the note column) and are left out of every average.")
    for (m, why), where in reasons.items():
        notes.append(f"{METRIC_COLUMNS[m][0]} is null in {len(where)} run(s) ({why}): {', '.join(where[:3])}{', ...' if len(where) > 3 else '.'}")
    notes.append("Marks compare the methods and baselines of each scene; ablation rows are not marked.")
    return table


def table1(records: list[dict]) -> Table:
    table, _ = _average_table("table1_average", "Average over scenes of the methods and baselines (paper Tab. 1)",
                              records, ("baseline", "method"), [])
    return table


def _ablation_letter(rec: dict) -> str | None:
    lab = rec["labels"]
    if lab.get("ablation"):
        return lab["ablation"]
    for letter, (_, ids) in ABLATIONS.items():
        if lab["method"] in ids or lab["method"] == letter:
            return letter
    return None


def table3(records: list[dict]) -> Table:
    notes: list[str] = []
    if not any(r["labels"]["kind"] == "ablation" for r in records):
        notes.append("No ablation records (label kind=ablation) were given.")
    table, groups = _average_table("table3_ablation", "Ablation against the full method (paper Tab. 3)", records, ("ablation", "method"), notes)
    table.rank_by, table.rule_by = ("segmenter",), "segmenter"
    table.labels = [("method", "Method"), ("row", "Row"), ("segmenter", "Segmenter"), ("kind", "Kind")]
    table.csv_only = ("method", "kind")
    by_key = {(row["method"], row["segmenter"]): row for row in table.rows}
    for key, row in by_key.items():
        first = groups[key][0]
        if row["kind"] == "ablation":
            letter = _ablation_letter(first)
            name = first["labels"].get("name") or (ABLATIONS[letter][0] if letter else first["labels"]["method"])
            row["row"] = f"{letter}) {name}" if letter else name
            row["_order"] = (0, "abcde".index(letter) if letter else 5)
        else:
            row["row"] = f"Ours ({_name(first)})"
            row["_order"] = (1, 0)
    table.rows.sort(key=lambda row: (row["segmenter"], row["_order"]))
    return table


def _stages(records: list[dict]) -> list[str]:
    names = {s for r in records for s in r.get("stages", {})}
    return [s for s in STAGE_ORDER if s in names] + sorted(names - set(STAGE_ORDER))


def _runtime_row(key, recs: list[dict], stages: list[str], has_stage: dict[str, bool], notes: list[str] | None) -> dict:
    row: dict = {"_not_run": set()}
    total, total_ok = 0.0, bool(recs)
    for s in stages:
        got = [r["stages"][s]["seconds"] / 60 for r in recs if s in r["stages"]]
        if not has_stage[s]:
            row[f"{s}_min"] = None
            row["_not_run"].add(f"{s}_min")
            continue
        if recs and len(got) == len(recs):
            row[f"{s}_min"] = sum(got) / len(got)
            if s not in NOT_IN_TOTAL:
                total += row[f"{s}_min"]
        else:
            row[f"{s}_min"] = None
            if s not in NOT_IN_TOTAL:
                total_ok = False
            if notes is not None and recs:
                lacking = [r["labels"]["scene"] for r in recs if s not in r["stages"]]
                notes.append(f"Stage {s} of {_who(key)} is not averaged: no benchmark for scene(s) {', '.join(lacking)}.")
    row["total_min"] = total if total_ok else None
    storage = [r["model"]["storage_mb"] for r in recs if r.get("model")]
    row["storage_mb"] = sum(storage) / len(storage) if recs and len(storage) == len(recs) else None
    if notes is not None and recs and len(storage) != len(recs):
        notes.append(f"Storage of {_who(key)} is not averaged: no model files recorded for "
                     f"{', '.join(r['labels']['scene'] for r in recs if not r.get('model'))}.")
    rss = [st["max_rss_mb"] for r in recs for st in r["stages"].values() if st.get("max_rss_mb") is not None]
    row["peak_rss_mb"] = max(rss) if rss else None
    return row


def _runtime_columns(stages: list[str]) -> list[Column]:
    return [*(Column(f"{s}_min", f"{s} (min)", LOWER, ".2f") for s in stages), Column("total_min", "total (min)", LOWER, ".2f"),
            Column("storage_mb", "storage (MB)", LOWER, ".1f"), Column("peak_rss_mb", "peak RSS (MB)", LOWER, ".0f")]


def _runtime_setup(records: list[dict], notes: list[str]):
    kinds = ("baseline", "method")
    without: dict[tuple[str, str], list[str]] = {}
    for r in records:
        if r["labels"]["kind"] in kinds and not r.get("stages"):
            without.setdefault(_key(r), []).append(r["labels"]["scene"])
    for g, scenes in without.items():
        notes.append(f"{_who(g)} has no stage benchmarks for scene(s) {', '.join(sorted(scenes))}; left out.")
    recs = [r for r in records if r["labels"]["kind"] in kinds and r.get("stages")]
    groups = _groups(recs, kinds)
    common = _common_scenes(groups, "stage benchmarks", notes)
    stages = _stages(recs)
    return groups, common, stages


def _runtime_notes(stages: list[str]) -> list[str]:
    counted = [s for s in stages if s not in NOT_IN_TOTAL]
    return [f"Minutes are Snakemake benchmark wall times (mean over repeats); total = {' + '.join(counted) or 'nothing'}"
            f"{' (evaluation is not part of a method' + chr(39) + 's cost)' if any(s in NOT_IN_TOTAL for s in stages) else ''}.",
            "Storage = size of the model PLY files in MB (10^6 bytes); peak RSS = largest max RSS of any stage (MB)."]


def table2(records: list[dict]) -> Table:
    notes: list[str] = []
    groups, common, stages = _runtime_setup(records, notes)
    table = Table("table2_runtime", "Runtime and model size per method, averaged over scenes (paper Tab. 2)",
                  labels=[("method", "Method"), ("name", "Method"), ("segmenter", "Segmenter"), ("kind", "Kind")],
                  columns=[Column("n_scenes", "scenes"), *_runtime_columns(stages)], notes=notes, csv_only=("method",))
    for g, rs in groups.items():
        used = [r for r in rs if r["labels"]["scene"] in common]
        has = {s: any(s in r["stages"] for r in rs) for s in stages}
        row = {"method": g[0], "name": _name(rs[0]), "segmenter": g[1], "kind": rs[0]["labels"]["kind"], "n_scenes": len(used)}
        row.update(_runtime_row(g, used, stages, has, notes))
        table.rows.append(row)
    if common:
        notes.insert(0, f"Averaged over {len(common)} scene(s): {', '.join(sorted(common))}.")
    notes.extend(_runtime_notes(stages))
    return table


def table2_detail(records: list[dict]) -> Table:
    notes: list[str] = []
    groups, common, stages = _runtime_setup(records, notes)
    table = Table("table2_runtime_detail", "Runtime of every stage per scene and its average per method (paper supp. Detailed Runtime)",
                  labels=[("method", "Method"), ("name", "Method"), ("segmenter", "Segmenter"), ("scene", "Scene")],
                  columns=_runtime_columns(stages), notes=notes, csv_only=("method",), rule_by="method", note_column="note",
                  marked=False)
    for g, rs in groups.items():
        has = {s: any(s in r["stages"] for r in rs) for s in stages}
        base = {"method": g[0], "name": _name(rs[0]), "segmenter": g[1]}
        for r in sorted(rs, key=lambda r: r["labels"]["scene"]):
            row = {**base, "scene": r["labels"]["scene"], "note": "" if r["labels"]["scene"] in common else "not in the average"}
            row.update(_runtime_row(g, [r], stages, has, None))
            table.rows.append(row)
        used = [r for r in rs if r["labels"]["scene"] in common]
        row = {**base, "scene": "average", "note": f"over {len(used)} scene(s)"}
        row.update(_runtime_row(g, used, stages, has, notes))
        table.rows.append(row)
    notes.extend(_runtime_notes(stages))
    return table


# --- provenance --------------------------------------------------------------------------------

PACKAGES = ("inpaint360gs", "torch", "numpy", "pandas", "snakemake", "pycolmap", "onnxruntime")


def _versions() -> dict[str, str | None]:
    out = {}
    for p in PACKAGES:
        try:
            out[p] = importlib.metadata.version(p)
        except importlib.metadata.PackageNotFoundError:
            out[p] = None
    return out


def _machine() -> dict:
    try:
        ram = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (AttributeError, ValueError, OSError):
        ram = None
    return {
        "platform": platform.platform(),
        "machine": platform.machine(),
        "processor": platform.processor() or None,
        "python": platform.python_version(),
        "cpu_count": os.cpu_count(),
        "usable_cpus": len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else None,
        "ram_bytes": ram,
    }


def read_config(path: str | Path | None) -> dict | None:
    if path is None:
        return None
    import yaml

    p = Path(path)
    check_readable(p, "a config YAML file", missing="config file not found")
    try:
        text = p.read_text()
    except UnicodeDecodeError:
        raise InputError("not a text file (expected a config YAML file)", p) from None
    try:
        parsed = yaml.safe_load(text)
    except yaml.YAMLError as e:
        raise InputError(f"not valid YAML ({str(e).splitlines()[0]})", p) from None
    return {"path": str(p), "sha256": hashlib.sha256(text.encode()).hexdigest(), "content": text, "parsed": parsed}


def provenance(records: list[dict], config: dict | None, seeds: list[int] | None, outputs: list[str]) -> dict:
    weights: dict[tuple[str, str], dict] = {}
    for r in records:
        for name, info in (r.get("weights") or {}).items():
            if info is None:
                continue
            k = (Path(info.get("path", "")).name, info["sha256"])
            weights.setdefault(k, {"name": name, "file": k[0], "sha256": k[1], "records": 0})["records"] += 1
    seeds_source = "--seeds" if seeds else None
    if not seeds and config and isinstance(config.get("parsed"), dict) and "seed" in config["parsed"]:
        seeds, seeds_source = [config["parsed"]["seed"]], "config seed"
    return {
        "created": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "git_commit": git_commit(),
        "config": None if config is None else {k: config[k] for k in ("path", "sha256", "content")},
        "seeds": seeds or None,
        "seeds_source": seeds_source,
        "packages": _versions(),
        "machine": _machine(),
        "weights": sorted(weights.values(), key=lambda w: (w["name"], w["file"])),
        "records": [{"path": r["_path"], "sha256": sha256_file(r["_path"]), "labels": r["labels"]} for r in records],
        "outputs": outputs,
    }


TABLES = (("per_scene", per_scene_table), ("table1_average", table1), ("table3_ablation", table3),
          ("table2_runtime", table2), ("table2_runtime_detail", table2_detail))


def output_names() -> list[str]:
    return [f"{name}.{ext}" for name, _ in TABLES for ext in ("csv", "md", "tex")] + ["provenance.json"]


def views_sweep(records: list[dict]) -> Table | None:
    """The full method at several numbers of virtual views L (records of kind ``sweep`` with a
    ``virtual_views`` label, plus the full method's own L when the ``method`` records carry one),
    averaged over the scenes every L has: the supplementary's FID-vs-L study."""
    recs = [r for r in records if r["labels"]["kind"] == "sweep" or (r["labels"]["kind"] == "method" and "virtual_views" in r["labels"])]
    if not any(r["labels"]["kind"] == "sweep" for r in recs):
        return None
    for r in recs:
        v = r["labels"].get("virtual_views", "")
        if not str(v).isdigit():
            raise InputError(f"a sweep record needs a virtual_views label (a positive integer), got {v!r}", r.get("_path", "record"))
    notes: list[str] = []
    table, _ = _average_table("views_sweep", "Number of virtual views L (supplementary)", [{**r, "labels": {**r["labels"], "kind": "sweep"}} for r in recs], ("sweep",), notes)
    views = {r["labels"]["method"]: int(r["labels"]["virtual_views"]) for r in recs}
    table.labels.insert(0, ("virtual_views", "L"))
    for row in table.rows:
        row["virtual_views"] = str(views[row["method"]])
    table.rows.sort(key=lambda row: int(row["virtual_views"]))
    table.marked = False
    return table


def sweep_plot(table: Table) -> bytes:
    """PNG: FD-VGG16 (and FID when present) against L, from :func:`views_sweep`'s table."""
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    xs = [int(r["virtual_views"]) for r in table.rows]
    fig, ax = plt.subplots(figsize=(4.5, 3.2), dpi=120)
    for key, title in (("fid", "FID"), ("fd_vgg16", "FD-VGG16 (FID substitute)")):
        ys = [r.get(key) for r in table.rows]
        if any(y is not None for y in ys):
            ax.plot(xs, [float("nan") if y is None else y for y in ys], marker="o", label=title)
    ax.set_xlabel("virtual views L")
    ax.set_ylabel("distance (lower is better)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    buf = io.BytesIO()
    fig.savefig(buf, format="png", metadata={"Software": None})
    plt.close(fig)
    return buf.getvalue()


def paper_tables(record_paths: list[str | Path], out_dir: str | Path, *, config: str | Path | None = None,
                 seeds: list[int] | None = None) -> dict[str, Table]:
    """Read the records, build every table and write them into ``out_dir`` (see the module docstring).

    Everything is read, checked and rendered before the first file is written."""
    records = load_records(list(record_paths))
    cfg = read_config(config)
    tables = {name: build(records) for name, build in TABLES}
    files: dict[str, str] = {}
    footer = f"Provenance: {provenance_line()}; inputs and versions in provenance.json."
    for name, t in tables.items():
        files[f"{name}.csv"] = to_csv(t)
        files[f"{name}.md"] = to_markdown(t, footer)
        files[f"{name}.tex"] = to_latex(t)
    blobs: dict[str, bytes] = {}
    sweep = views_sweep(records)
    if sweep is not None:
        tables["views_sweep"] = sweep
        files["views_sweep.csv"] = to_csv(sweep)
        files["views_sweep.md"] = to_markdown(sweep, footer)
        files["views_sweep.tex"] = to_latex(sweep)
        blobs["views_sweep.png"] = sweep_plot(sweep)
    files["provenance.json"] = json.dumps(provenance(records, cfg, seeds, list(files)), indent=1, allow_nan=False, default=str) + "\n"
    out = Path(out_dir)
    for fname, text in files.items():
        write_text(out / fname, text)
    for fname, data in blobs.items():
        with atomic_path(out / fname) as tmp:
            tmp.write_bytes(data)
    return tables
