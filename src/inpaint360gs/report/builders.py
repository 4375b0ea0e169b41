"""Build the paper's tables from records (:mod:`.records`) as :class:`.table_model.Table` s: the
supp. per-scene table, Tab. 1 (methods and baselines), Tab. 3 (ablations), Tab. 2 and its per-scene
detail (runtime), and the supplementary's sweep over the number of virtual views.

What the columns, marks and Δ rows mean is in :mod:`.paper`; the statistics are :mod:`.stats`.
Nothing here writes a file.
"""

from __future__ import annotations

from inpaint360gs.core.errors import InputError
from inpaint360gs.metrics.removal import LIMIT_TEXT, limits_exceeded
from inpaint360gs.report import stats
from inpaint360gs.report.records import METRICS
from inpaint360gs.report.stats import HIGHER, LOWER, NONE, Run
from inpaint360gs.report.table_model import Bootstrap, Column, Table

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
    "roi_depth_off": ("ROI depth off (%)", LOWER, ".2f"),  # the fill's geometry (report/geometry.py)
    # properties of the run's removal and of the scene: more or less of either is neither better nor worse
    "amcr": ("AMCR (%)", NONE, ".2f"),
    "gt_footprint_share": ("true footprint (%)", NONE, ".2f"),
    "residual": ("residual (%)", NONE, ".2f"),
    "collateral": ("collateral (%)", NONE, ".2f"),
    "silhouette_test": ("removed silhouette, test views (%)", NONE, ".2f"),
    "unseen_share": ("unseen share (%)", NONE, ".2f"),
}
assert set(METRIC_COLUMNS) == set(METRICS)
# the compared columns of Tabs. 1 and 3 (then FID or its substitute), and the context columns. ROI PSNR
# is not averaged: per view it is masked PSNR minus 10 log10(image pixels / mask pixels), a constant of
# the scene's ground-truth mask, so every difference between rows is masked PSNR's (per_scene keeps it).
AVERAGE_METRICS = ("psnr", "masked_psnr", "ssim", "masked_ssim", "roi_ssim", "lpips", "masked_lpips", "roi_lpips")
GEOMETRY_METRICS = ("roi_depth_off",)  # compared after FID: the fill's surface against the true one
CONTEXT_METRICS = ("amcr", "gt_footprint_share", "residual", "collateral", "silhouette_test", "unseen_share")
ROI_PSNR_NOTE = ("ROI PSNR is not averaged: per view it is masked PSNR minus 10 log10(image pixels / unseen-mask pixels), a constant "
                 "of the scene's ground-truth mask, so it carries no information masked PSNR does not (per_scene lists it).")

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


# --- runs, groups and common runs ------------------------------------------------------------


def _run(rec: dict) -> Run:
    return rec["labels"]["scene"], rec["labels"].get("seed", "")


def _run_text(run: Run) -> str:
    return run[0] if not run[1] else f"{run[0]} (seed {run[1]})"


def _key(rec: dict) -> tuple[str, str]:
    return rec["labels"]["method"], rec["labels"]["segmenter"]


def _name(rec: dict) -> str:
    return rec["labels"].get("name") or rec["labels"]["method"]


def _who(key: tuple[str, str]) -> str:
    return f"{key[0]}/{key[1]}"


def _seed_order(seed: str) -> tuple[int, str]:
    return (int(seed), seed) if seed.isdigit() else (-1, seed)


def _describe(runs) -> str:
    """``9 scenes (a, b, ...) x seeds 0, 1, 2`` (or the runs one by one when not every scene has every seed)."""
    runs = sorted(runs, key=lambda r: (r[0], _seed_order(r[1])))
    scenes = sorted({r[0] for r in runs})
    seeds = sorted({r[1] for r in runs}, key=_seed_order)
    if len(runs) != len(scenes) * len(seeds):
        return f"{len(runs)} run(s): " + ", ".join(_run_text(r) for r in runs)
    text = f"{len(scenes)} scene(s) ({', '.join(scenes)})"
    return text + (f" × seed(s) {', '.join(seeds)}" if seeds != [""] else "")


def _groups(records: list[dict], kinds: tuple[str, ...]) -> dict[tuple[str, str], dict[Run, dict]]:
    """Records of ``kinds`` by (method, segmenter) and run, baselines first, then in input order."""
    order = sorted((r for r in records if r["labels"]["kind"] in kinds), key=lambda r: KIND_ORDER[r["labels"]["kind"]])
    out: dict[tuple[str, str], dict[Run, dict]] = {}
    for r in order:
        out.setdefault(_key(r), {})[_run(r)] = r
    return out


def _common_runs(groups: dict[tuple[str, str], dict[Run, dict]], what: str, notes: list[str]) -> set[Run]:
    """Runs every group has; a note names each run left out and the groups that lack it."""
    sets = {g: set(recs) for g, recs in groups.items()}
    if not sets:
        return set()
    common = set.intersection(*sets.values())
    for run in sorted(set.union(*sets.values()) - common, key=lambda r: (r[0], _seed_order(r[1]))):
        have = [_who(g) for g, runs in sets.items() if run in runs]
        lacking = [_who(g) for g, runs in sets.items() if run not in runs]
        notes.append(f"{'Scene' if not run[1] else 'Run'} {_run_text(run)} is left out of every average: {', '.join(have)} "
                     f"{'has' if len(have) == 1 else 'have'} {what} there, {', '.join(lacking)} not (averages are over the same runs for every row).")
    if not common:
        notes.append(f"No run has {what} for every row: nothing is averaged.")
    return common


def _without_metrics(records: list[dict], kinds: tuple[str, ...], notes: list[str]) -> list[dict]:
    """Records of ``kinds`` that have metrics; a note for each one left out for having none."""
    keep = []
    for r in records:
        if r["labels"]["kind"] not in kinds:
            continue
        if r.get("skip_reason"):
            notes.append(f"Scene {_run_text(_run(r))} of {_who(_key(r))} has no metrics ({r['skip_reason']}); "
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
    notes.append(f"FID is null in {len(missing)} of {len(recs)} averaged runs ({why}); the FID column is its substitute "
                 "FD-VGG16 (Fréchet distance on VGG16 features), not comparable with the paper's FID values.")
    return "fd_vgg16"


def _metric_column(m: str, substitute: bool = False) -> Column:
    title, direction, fmt = METRIC_COLUMNS[m]
    return Column(m, title + (" (FID substitute)" if substitute else ""), direction, fmt, stats=True)


# --- rows with statistics --------------------------------------------------------------------


def _values(recs: dict[Run, dict], runs: set[Run], metric: str) -> dict[Run, float | None]:
    """``metric`` of each run, in sorted run order: sums over it do not depend on the set's hash order."""
    return {r: recs[r]["metrics"][metric] for r in sorted(runs)}


def _mean_row(key, recs: dict[Run, dict], runs: set[Run], metrics: tuple[str, ...], notes: list[str]) -> dict:
    """Mean and seed spread of each metric over ``runs``; a note for a metric null in some run."""
    row: dict = {"row_type": "mean", "n_runs": len(runs), "n_scenes": len({r[0] for r in runs})}
    for m in metrics:
        vals = _values(recs, runs, m)
        nulls = sorted(r for r, v in vals.items() if v is None)
        if not runs:
            row[m] = None
        elif nulls:
            row[m] = None
            why = recs[nulls[0]].get("null_reasons", {}).get(m)
            notes.append(f"{METRIC_COLUMNS[m][0]} of {_who(key)} is not averaged: null in {_run_text(nulls[0])}"
                         + (f" ({why})" if why else "") + (f" and {len(nulls) - 1} more" if len(nulls) > 1 else "") + ".")
        else:
            row[m] = sum(vals.values()) / len(vals)
            row[f"{m}_std"] = stats.seed_spread(vals)
    return row


def _mark_first_places(rows: dict[tuple[str, str], dict], recs: dict[tuple[str, str], dict[Run, dict]], runs: set[Run],
                       metrics: tuple[str, ...], boot: Bootstrap) -> None:
    """``<metric>_mark`` = best / tied on the mean rows ``rows`` (compared on ``runs``)."""
    for m in metrics:
        direction = METRIC_COLUMNS[m][1]
        if direction == NONE:
            continue
        vals = {g: _values(recs[g], runs, m) for g in rows if rows[g].get(m) is not None}
        place = stats.first_place(vals, direction, **boot.kw())
        if place is None:
            continue
        if place.best is not None:
            rows[place.best][f"{m}_mark"] = "best"
        for g in place.tied:
            rows[g][f"{m}_mark"] = "tied"


def _difference_row(a: dict[Run, dict], b: dict[Run, dict], runs: set[Run], metrics: tuple[str, ...], boot: Bootstrap) -> dict:
    """``a - b`` per compared metric over ``runs``: mean, interval, verdict (for ``a``; :data:`.stats.SEED_NOISE`
    over fewer than :data:`.stats.MIN_SCENES` scenes)."""
    row: dict = {"row_type": "difference", "n_runs": len(runs), "n_scenes": len({r[0] for r in runs})}
    for m in metrics:
        direction = METRIC_COLUMNS[m][1]
        iv = stats.paired_difference(_values(a, runs, m), _values(b, runs, m), **boot.kw()) if direction != NONE else None
        if iv is None:
            row[m] = None
            continue
        row[m], row[f"{m}_ci_low"], row[f"{m}_ci_high"] = iv.mean, iv.low, iv.high
        row[f"{m}_mark"] = iv.verdict(direction)  # tied without an interval (one pair)
    return row


BOOTSTRAP_TEXT = ("intervals resample scenes: the paired differences are formed per run (one scene at one seed) and the scenes are "
                  "drawn with replacement, each with all its seeds (they share its 3DGS model and move together)")


def _stats_notes(runs: set[Run], boot: Bootstrap) -> list[str]:
    seeds = {r[1] for r in runs}
    spread = ("± = standard deviation over the seeds of the average over scenes (what changing only the seeds of every stage "
              "after 3DGS does to the number; 3DGS itself is trained once per scene)") if len(seeds) > 1 else "one seed per scene: no ± (no seed spread)"
    return [f"{spread}. Δ = mean of the paired differences over the runs; in brackets its {boot.confidence:.0%} bootstrap interval. "
            f"The {BOOTSTRAP_TEXT} ({boot.resamples} resamples, RNG seed {boot.seed}; percentiles at the level expanded for the number of "
            f"scenes, report/stats.py). A verdict needs at least {stats.MIN_SCENES} scenes: with fewer, the interval resamples the runs, "
            f"measures the seeds' noise on those scenes only, is marked \"{stats.SEED_NOISE}\" and makes no row bold or tied "
            f"(none below {stats.MIN_PAIRS} runs)."]


def removal_failures(records: list[dict]) -> list[dict]:
    """Every run whose removal breaks a limit (:data:`inpaint360gs.metrics.removal.LIMITS`): scene,
    seed, method, segmenter, the limit, the value, the maximum and the record, in scene, seed, limit, method order."""
    out = []
    for r in records:
        for limit, value, most in limits_exceeded(r["metrics"]):
            out.append({"scene": r["labels"]["scene"], "seed": r["labels"].get("seed", ""), "method": r["labels"]["method"],
                        "segmenter": r["labels"]["segmenter"], "limit": limit, "value": value, "max": most, "record": r})
    return sorted(out, key=lambda f: (f["scene"], _seed_order(f["seed"]), f["limit"], f["method"]))


def _failure_notes(records: list[dict]) -> list[str]:
    """Under Tab. 1: each run above a removal limit by name (the runs of one removal that share the value in one line)."""
    lines: dict[tuple, list[str]] = {}
    for f in removal_failures(records):
        unit = "×" if f["limit"] == "amcr_ratio" else " %"
        key = (f["scene"], f["seed"], f["segmenter"], f["limit"], f"{f['value']:.2f}{unit}", f"{f['max']:g}{unit}")
        lines.setdefault(key, []).append(f["method"])
    notes = [f"Removal limits (docs/architecture.md, \"Ground-truth removal scores\"): {'; '.join(LIMIT_TEXT.values())}; AMCR "
             "(paper supp. Eq. 1) and the true footprint share are over the training views. "
             + ("Runs above a limit stay in the averages and are listed here by name:" if lines else "No run is above a limit.")]
    for (scene, seed, seg, limit, value, most), methods in lines.items():
        notes.append(f"ABOVE LIMIT: {_run_text((scene, seed))} [{seg}]: {limit} {value} > {most}; method(s) {', '.join(methods)}.")
    missing = [r for r in records if not r.get("skip_reason") and any(r["metrics"].get(k) is None for k in ("residual", "collateral", "amcr"))]
    if missing:
        first = missing[0]
        why = next(first.get("null_reasons", {}).get(k) for k in ("residual", "collateral", "amcr") if first["metrics"].get(k) is None)
        notes.append(f"{len(missing)} run(s) lack a removal score (AMCR, residual or collateral): the limits are not checked there "
                     f"(first: {_run_text(_run(first))} {_who(_key(first))}: {why}).")
    return notes


def _segmenters(groups) -> list[str]:
    return list(dict.fromkeys(g[1] for g in groups))


def table1(records: list[dict], boot: Bootstrap = Bootstrap()) -> Table:
    """Paper Tab. 1 from run records: metrics averaged over the runs common to every method, with bootstrap intervals
    ``boot``."""
    notes: list[str] = []
    kinds = ("baseline", "method")
    recs = _without_metrics(records, kinds, notes)
    groups = _groups(recs, kinds)
    common = _common_runs(groups, "metrics", notes)
    fid = _fid_column([g[r] for g in groups.values() for r in common], notes)
    compared = (*AVERAGE_METRICS, fid, *GEOMETRY_METRICS)
    metrics = (*compared, *CONTEXT_METRICS)
    table = Table(
        "table1_average", "Average over runs of the methods and baselines (paper Tab. 1)",
        labels=[("method", "Method"), ("name", "Method"), ("segmenter", "Segmenter"), ("kind", "Kind"), ("row_type", "Row"), ("vs", "vs")],
        columns=[Column("n_runs", "runs", fmt="d"), Column("n_scenes", "scenes", fmt="d"), *(_metric_column(m, m == "fd_vgg16") for m in metrics)],
        notes=notes, csv_only=("method", "row_type", "vs"), compared=True,
    )
    rows = {}
    for g, recs_g in groups.items():
        first = next(iter(recs_g.values()))
        rows[g] = {"method": g[0], "name": _name(first), "segmenter": g[1], "kind": first["labels"]["kind"], "vs": ""}
        rows[g].update(_mean_row(g, recs_g, common, metrics, notes))
    _mark_first_places(rows, groups, common, compared, boot)
    table.rows += list(rows.values())
    baselines = [g for g in groups if rows[g]["kind"] == "baseline"]
    for a in (g for g in groups if rows[g]["kind"] == "method"):
        # against the baselines run with the method's segmenter, or every baseline when none was (e.g. external records)
        for b in [g for g in baselines if g[1] == a[1]] or baselines:
            row = {"method": a[0], "name": f"Δ {rows[a]['name']} − {rows[b]['name']}", "segmenter": a[1], "kind": "difference", "vs": b[0]}
            row.update(_difference_row(groups[a], groups[b], common, compared, boot))
            table.rows.append(row)
    if common:
        notes.insert(0, f"Averaged over {len(common)} run(s): {_describe(common)}.")
        notes[1:1] = [*_stats_notes(common, boot), ROI_PSNR_NOTE]
    notes.append(CONTEXT_NOTE)
    notes.extend(_failure_notes(records))
    return table


CONTEXT_NOTE = ("Not compared, they describe the removal and the task: AMCR (paper supp. Eq. 1) = percentage of the training views' "
                "pixels the run's own removal leaves to fill (mean over the views); true footprint = the removal targets' true share of "
                "the same views; residual = share of the targets' true pixels that still show the object after the removal; collateral = "
                "share of the pixels outside the grown true footprint that the removal changed; removed silhouette, test views = the "
                "removal's mask rule at the test cameras (the object's whole silhouette there, most of which other views saw); unseen "
                "share = percentage under the ground-truth unseen masks of the test views (the same for every method).")


def _ablation_letter(rec: dict) -> str | None:
    lab = rec["labels"]
    if lab.get("ablation"):
        return lab["ablation"]
    for letter, (_, ids) in ABLATIONS.items():
        if lab["method"] in ids or lab["method"] == letter:
            return letter
    return None


def _ablation_name(rec: dict) -> str:
    letter = _ablation_letter(rec)
    name = rec["labels"].get("name") or (ABLATIONS[letter][0] if letter else rec["labels"]["method"])
    return f"{letter}) {name}" if letter else name


def _verdicts(row: dict, metrics: tuple[str, ...]) -> str:
    """What the Δ row of an ablation says, in words: on which metrics the switched-off run is worse or better."""
    if any(row.get(f"{m}_mark") == stats.SEED_NOISE for m in metrics):
        return (f"{stats.SEED_NOISE}: {row['n_scenes']} scene(s), fewer than the {stats.MIN_SCENES} a verdict needs; the intervals "
                "resample its runs")
    by: dict[str, list[str]] = {"worse": [], "better": [], "tied": []}
    for m in metrics:
        mark = row.get(f"{m}_mark")
        by[mark if mark in by else "tied"].append(METRIC_COLUMNS[m][0])
    parts = [f"{w} on {', '.join(by[w])}" for w in ("worse", "better") if by[w]]
    if by["tied"]:
        parts.append(f"no measurable effect on {'the other ' if parts else ''}{len(by['tied'])} compared metric(s)"
                     + (f" ({', '.join(by['tied'])})" if not parts else ""))
    return "; ".join(parts)


def table3(records: list[dict], boot: Bootstrap = Bootstrap()) -> Table:
    """The ablations against the full method, each on the runs it has; ablations with the same runs
    share a block (and the full method's row of it)."""
    notes: list[str] = []
    if not any(r["labels"]["kind"] == "ablation" for r in records):
        notes.append("No ablation records (label kind=ablation) were given.")
    recs = _without_metrics(records, ("method", "ablation"), notes)
    groups = _groups(recs, ("method", "ablation"))
    fid = _fid_column([r for g in groups.values() for r in g.values()], notes)
    compared = (*AVERAGE_METRICS, fid, *GEOMETRY_METRICS)
    metrics = (*compared, "amcr", "residual", "collateral")
    table = Table(
        "table3_ablation", "Ablations against the full method (paper Tab. 3)",
        labels=[("block", "Block"), ("method", "Method"), ("row", "Row"), ("segmenter", "Segmenter"), ("kind", "Kind"), ("row_type", "Row type"),
                ("runs", "Runs")],
        columns=[Column("n_runs", "runs", fmt="d"), Column("n_scenes", "scenes", fmt="d"), *(_metric_column(m, m == "fd_vgg16") for m in metrics)],
        notes=notes, csv_only=("method", "kind", "row_type"), rule_by="block", compared=True,
    )
    summaries, block = [], 0
    for seg in _segmenters(groups):
        ours = [g for g in groups if g[1] == seg and next(iter(groups[g].values()))["labels"]["kind"] == "method"]
        ablations = sorted((g for g in groups if g[1] == seg and g not in ours),
                           key=lambda g: (_ablation_letter(next(iter(groups[g].values()))) or "z", g[0]))
        if not ablations:
            continue
        if not ours:
            notes.append(f"No full-method record for segmenter {seg}: its ablations are not compared.")
            continue
        if len(ours) > 1:
            notes.append(f"Several method rows for segmenter {seg}; the ablations are compared with {_who(ours[0])}.")
        o = ours[0]
        blocks: dict[frozenset, list] = {}
        for g in ablations:
            runs = frozenset(groups[g]) & frozenset(groups[o])
            for run in sorted(set(groups[g]) - runs):
                notes.append(f"{_who(g)} at {_run_text(run)} is left out: {_who(o)} has no metrics there.")
            if runs:
                blocks.setdefault(runs, []).append(g)
        for runs, members in blocks.items():
            block += 1
            runs = set(runs)
            rows = {}
            first_o = next(iter(groups[o].values()))
            rows[o] = {"block": str(block), "method": o[0], "row": f"Ours ({_name(first_o)})", "segmenter": seg, "kind": "method", "runs": _describe(runs)}
            rows[o].update(_mean_row(o, groups[o], runs, metrics, notes))
            for g in members:
                first = next(iter(groups[g].values()))
                rows[g] = {"block": str(block), "method": g[0], "row": _ablation_name(first), "segmenter": seg, "kind": "ablation", "runs": ""}
                rows[g].update(_mean_row(g, groups[g], runs, metrics, notes))
            _mark_first_places(rows, groups, runs, compared, boot)
            table.rows += list(rows.values())
            for g in members:
                letter = _ablation_letter(next(iter(groups[g].values())))
                label = f"{letter})" if letter else rows[g]["row"]
                row = {"block": str(block), "method": g[0], "row": f"Δ {label} − Ours", "segmenter": seg, "kind": "difference", "runs": ""}
                row.update(_difference_row(groups[g], groups[o], runs, compared, boot))
                table.rows.append(row)
                summaries.append(f"{rows[g]['row']} ({seg}; {_describe(runs)}): {_verdicts(row, compared)}.")
    if table.rows:
        notes[0:0] = _stats_notes({r for g in groups.values() for r in g}, boot) + [
            "Each block compares the full method with the ablations on the runs they share; in a Δ row worse / better means the "
            "method with that switch off is worse / better than with it.", ROI_PSNR_NOTE]
    notes += summaries
    return table


def per_scene_table(records: list[dict]) -> Table:
    """Every run's metrics, one row per (scene, method, seed)."""
    notes: list[str] = []
    table = Table(
        "per_scene", "Per-scene results of every run (scene, method, seed)",
        labels=[("scene", "Scene"), ("method", "Method"), ("name", "Method"), ("segmenter", "Segmenter"), ("kind", "Kind"), ("seed", "Seed")],
        columns=[Column(m, *METRIC_COLUMNS[m]) for m in METRIC_COLUMNS],
        notes=notes, rule_by="scene", csv_only=("method",), note_column="note",
    )
    first: dict[tuple[str, str], int] = {}
    for i, r in enumerate(records):
        first.setdefault(_key(r), i)
    order = sorted(range(len(records)), key=lambda i: (records[i]["labels"]["scene"], KIND_ORDER[records[i]["labels"]["kind"]],
                                                       first[_key(records[i])], _seed_order(records[i]["labels"].get("seed", "")), i))
    reasons: dict[tuple[str, str], list[str]] = {}
    above: dict[int, list[str]] = {}
    for f in removal_failures(records):
        unit = "×" if f["limit"] == "amcr_ratio" else " %"
        above.setdefault(id(f["record"]), []).append(f"above limit: {f['limit']} {f['value']:.2f}{unit} > {f['max']:g}{unit}")
    for i in order:
        r = records[i]
        lab = r["labels"]
        row = {"scene": lab["scene"], "method": lab["method"], "name": _name(r), "segmenter": lab["segmenter"], "kind": lab["kind"],
               "seed": lab.get("seed", ""), "note": "; ".join([r.get("skip_reason") or "", *above.get(id(r), [])]).strip("; ")}
        row.update({m: r["metrics"][m] for m in METRIC_COLUMNS})
        table.rows.append(row)
        if not r.get("skip_reason"):
            for m in METRIC_COLUMNS:
                if r["metrics"][m] is None:
                    reasons.setdefault((m, r.get("null_reasons", {}).get(m) or "no reason recorded"), []).append(f"{_run_text(_run(r))} {_who(_key(r))}")
    skipped = [r for r in records if r.get("skip_reason")]
    if skipped:
        notes.append(f"{len(skipped)} run(s) have no metrics (reason in the note column) and are left out of every average.")
    for (m, why), where in reasons.items():
        notes.append(f"{METRIC_COLUMNS[m][0]} is null in {len(where)} run(s) ({why}): {', '.join(where[:3])}{', ...' if len(where) > 3 else '.'}")
    if above:
        notes.append(f"{len(above)} run(s) are above a removal limit ({'; '.join(LIMIT_TEXT.values())}): the note column says which.")
    notes.append("One row per run, nothing marked: a single run carries no interval (the averages and their intervals are in table1_average "
                 "and table3_ablation). " + CONTEXT_NOTE)
    return table


# --- runtime ---------------------------------------------------------------------------------


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
                lacking = [_run_text(_run(r)) for r in recs if s not in r["stages"]]
                notes.append(f"Stage {s} of {_who(key)} is not averaged: no benchmark for {', '.join(lacking)}.")
    row["total_min"] = total if total_ok else None
    storage = [r["model"]["storage_mb"] for r in recs if r.get("model")]
    row["storage_mb"] = sum(storage) / len(storage) if recs and len(storage) == len(recs) else None
    if notes is not None and recs and len(storage) != len(recs):
        notes.append(f"Storage of {_who(key)} is not averaged: no model files recorded for "
                     f"{', '.join(_run_text(_run(r)) for r in recs if not r.get('model'))}.")
    rss = [st["max_rss_mb"] for r in recs for st in r["stages"].values() if st.get("max_rss_mb") is not None]
    row["peak_rss_mb"] = max(rss) if rss else None
    return row


def _runtime_columns(stages: list[str]) -> list[Column]:
    return [*(Column(f"{s}_min", f"{s} (min)", NONE, ".2f") for s in stages), Column("total_min", "total (min)", NONE, ".2f"),
            Column("storage_mb", "storage (MB)", NONE, ".1f"), Column("peak_rss_mb", "peak RSS (MB)", NONE, ".0f")]


def _runtime_setup(records: list[dict], notes: list[str]):
    kinds = ("baseline", "method")
    without: dict[tuple[str, str], list[str]] = {}
    for r in records:
        if r["labels"]["kind"] in kinds and not r.get("stages"):
            without.setdefault(_key(r), []).append(_run_text(_run(r)))
    for g, runs in without.items():
        notes.append(f"{_who(g)} has no stage benchmarks for {'scene(s) ' if all('(' not in x for x in runs) else ''}{', '.join(sorted(runs))}; left out.")
    recs = [r for r in records if r["labels"]["kind"] in kinds and r.get("stages")]
    groups = _groups(recs, kinds)
    common = _common_runs(groups, "stage benchmarks", notes)
    stages = _stages(recs)
    return groups, common, stages


def _runtime_notes(stages: list[str]) -> list[str]:
    counted = [s for s in stages if s not in NOT_IN_TOTAL]
    return [f"Minutes are Snakemake benchmark wall times (mean over repeats); total = {' + '.join(counted) or 'nothing'}"
            f"{' (evaluation is not part of a method' + chr(39) + 's cost)' if any(s in NOT_IN_TOTAL for s in stages) else ''}.",
            "A stage shared by several runs (3DGS: one per scene for every seed) counts in each of them.",
            "Storage = size of the model PLY files in MB (10^6 bytes); peak RSS = largest max RSS of any stage (MB).",
            "No marks: one timing per run, on a shared machine."]


def table2(records: list[dict]) -> Table:
    """Paper Tab. 2 from run records: runtime and model size per method, averaged over runs."""
    notes: list[str] = []
    groups, common, stages = _runtime_setup(records, notes)
    table = Table("table2_runtime", "Runtime and model size per method, averaged over runs (paper Tab. 2)",
                  labels=[("method", "Method"), ("name", "Method"), ("segmenter", "Segmenter"), ("kind", "Kind")],
                  columns=[Column("n_runs", "runs", fmt="d"), *_runtime_columns(stages)], notes=notes, csv_only=("method",))
    for g, rs in groups.items():
        used = [rs[r] for r in sorted(common) if r in rs]
        first = next(iter(rs.values()))
        has = {s: any(s in r["stages"] for r in rs.values()) for s in stages}
        row = {"method": g[0], "name": _name(first), "segmenter": g[1], "kind": first["labels"]["kind"], "n_runs": len(used)}
        row.update(_runtime_row(g, used, stages, has, notes))
        table.rows.append(row)
    if common:
        notes.insert(0, f"Averaged over {len(common)} run(s): {_describe(common)}.")
    notes.extend(_runtime_notes(stages))
    return table


def table2_detail(records: list[dict]) -> Table:
    """Runtime of every stage per scene (mean over seeds) and its average per method."""
    notes: list[str] = []
    groups, common, stages = _runtime_setup(records, notes)
    table = Table("table2_runtime_detail", "Runtime of every stage per scene (mean over its seeds) and its average per method (paper supp. Detailed Runtime)",
                  labels=[("method", "Method"), ("name", "Method"), ("segmenter", "Segmenter"), ("scene", "Scene")],
                  columns=[Column("n_runs", "runs", fmt="d"), *_runtime_columns(stages)], notes=notes, csv_only=("method",), rule_by="method",
                  note_column="note")
    for g, rs in groups.items():
        first = next(iter(rs.values()))
        has = {s: any(s in r["stages"] for r in rs.values()) for s in stages}
        base = {"method": g[0], "name": _name(first), "segmenter": g[1]}
        for scene in sorted({run[0] for run in rs}):
            runs = [run for run in rs if run[0] == scene]
            left = [run for run in runs if run not in common]
            note = "" if not left else "not in the average" if len(left) == len(runs) else f"{len(left)} of {len(runs)} run(s) not in the average"
            row = {**base, "scene": scene, "n_runs": len(runs), "note": note}
            row.update(_runtime_row(g, [rs[run] for run in runs], stages, has, None))
            table.rows.append(row)
        used = [rs[r] for r in sorted(common) if r in rs]
        row = {**base, "scene": "average", "n_runs": len(used), "note": f"over {len(used)} run(s)"}
        row.update(_runtime_row(g, used, stages, has, notes))
        table.rows.append(row)
    notes.extend(_runtime_notes(stages))
    return table


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
    recs = _without_metrics([{**r, "labels": {**r["labels"], "kind": "sweep"}} for r in recs], ("sweep",), notes)
    groups = _groups(recs, ("sweep",))
    common = _common_runs(groups, "metrics", notes)
    fid = _fid_column([g[r] for g in groups.values() for r in common], notes)
    metrics = (*AVERAGE_METRICS, fid)
    table = Table("views_sweep", "Number of virtual views L (supplementary)",
                  labels=[("virtual_views", "L"), ("method", "Method"), ("name", "Method"), ("segmenter", "Segmenter")],
                  columns=[Column("n_runs", "runs", fmt="d"), *(_metric_column(m, m == "fd_vgg16") for m in metrics)], notes=notes,
                  csv_only=("method",))
    for g, rs in groups.items():
        first = next(iter(rs.values()))
        row = {"virtual_views": str(int(first["labels"]["virtual_views"])), "method": g[0], "name": _name(first), "segmenter": g[1]}
        row.update(_mean_row(g, rs, common, metrics, notes))
        table.rows.append(row)
    table.rows.sort(key=lambda row: int(row["virtual_views"]))
    if common:
        notes.insert(0, f"Averaged over {len(common)} run(s): {_describe(common)}; ± = standard deviation over seeds of the average over scenes. "
                        "Not compared (no intervals, no marks).")
    return table
