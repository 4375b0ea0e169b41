"""One self-describing record per (scene, method, segmenter) run: what the paper's tables are made of.

``inpaint360gs table record`` writes one; ``inpaint360gs table paper`` (:mod:`.paper`) reads many.
A record holds

- ``labels``: ``scene``, ``method``, ``segmenter`` (required), ``kind`` (``method``, ``baseline`` or
  ``ablation``; default ``method``), ``seed`` (the seed of every stage after 3DGS, a non-negative
  integer; one record per scene, method, segmenter and seed) and any other ``key=value`` (``name``:
  the row's display name; ``ablation``: the letter of paper Tab. 3);
- ``metrics``: the evaluation means of ``inpaint360gs evaluate`` (full, ``masked_*``, ``roi_*``; paper
  Sec. 4 "Metrics") and its scene metrics (``fid``, ``fd_vgg16``, ``kid_vgg16``, ``unseen_share``: the
  ground-truth unseen masks' coverage of the test views, ``amcr``: paper supp. Eq. 1 on the run's own
  removal masks over the training views, ``silhouette_test``: the removed silhouette at the test
  cameras, ``roi_depth_off``: the share of the unseen region the run's model leaves empty or puts off
  the true surface), and the removal's ground-truth scores of ``inpaint360gs score-removal``
  (``residual``, ``collateral``, ``gt_footprint_share``; docs/architecture.md, "Ground-truth removal
  scores"), each a finite number or null; ``null_reasons`` says why each null is null;
- ``skip_reason``: set (and every metric null) for a scene without ground truth, which has no evaluation;
- ``stages``: per stage, wall seconds (mean over the repeats of a Snakemake ``benchmark:`` file),
  max RSS in MB (max over the repeats; null where Snakemake wrote ``NA``), CPU seconds, repeats;
- ``model``: the model files and their total size, ``storage_mb`` (10^6 bytes; paper Tab. 2 "Storage");
- ``weights``: the weights files the evaluation used (path and sha256), for the tables' provenance;
- ``sources``: path and sha256 of every file the record was made from, and the folders they name.

Every value is checked when a record is written and again when it is read (docs/architecture.md,
"Reliability"): a bad input is one :class:`~inpaint360gs.core.errors.InputError` naming the file.
Older records and evaluations are read with what their numbers were: format 1 (before
``unseen_share``): its ``amcr`` was the unseen masks' coverage, read as ``unseen_share``; format 2
(before ``silhouette_test``): its ``amcr`` was the silhouette at the test cameras, read as
``silhouette_test``; in both ``amcr`` (training views) and the removal scores are null with the reason.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

from inpaint360gs.core.errors import InputError
from inpaint360gs.core.files import check_readable, sha256_file
from inpaint360gs.io import provenance

FORMAT = "inpaint360gs-table-record/3"
FORMAT_2 = "inpaint360gs-table-record/2"  # read: its ``amcr`` was the silhouette at the test cameras (``silhouette_test``)
FORMAT_1 = "inpaint360gs-table-record/1"  # read: its ``amcr`` was the unseen masks' coverage (``unseen_share``)
KINDS = ("method", "baseline", "ablation", "sweep")  # sweep: the full method at another L (virtual_views label)
REQUIRED_LABELS = ("scene", "method", "segmenter")

# evaluation means (``mean`` of the evaluation JSON) and scene metrics (``scene_metrics``)
MEAN_METRICS = (
    "psnr", "ssim", "lpips", "lpips_alex",
    "masked_psnr", "masked_ssim", "masked_lpips", "masked_lpips_alex",
    "roi_psnr", "roi_ssim", "roi_lpips", "roi_lpips_alex",
)
SCENE_METRICS = ("fid", "fd_vgg16", "kid_vgg16", "unseen_share", "amcr", "silhouette_test", "roi_depth_off")
# the removal's ground-truth scores (``inpaint360gs score-removal``)
REMOVAL_METRICS = ("residual", "collateral", "gt_footprint_share")
# why ``amcr`` is null in what was written before it was computed on the removal masks
OLD_AMCR_REASON = "not recorded: this {} is from before AMCR was computed on the removal masks (its 'amcr' was the unseen share)"
# ... and before it was computed over the training views (supp. Eq. 1)
OLD_SILHOUETTE_REASON = ("not recorded: this {} is from before AMCR was computed over the training views (its 'amcr' was the "
                         "removed silhouette at the test cameras, now silhouette_test)")
NO_REMOVAL_SCORES = "no removal scores given (table record --removal-scores SCORES.json, written by inpaint360gs score-removal)"
METRICS = MEAN_METRICS + SCENE_METRICS + REMOVAL_METRICS

_NAME = re.compile(r"^[A-Za-z_][A-Za-z0-9_.-]*$")
_SEED = re.compile(r"^[0-9]+$")




def _no_constant(name: str):
    raise ValueError(f"non-finite value {name}")


def read_json(path: str | Path, what: str) -> object:
    """Parse a JSON file; a missing, unreadable, invalid file or a NaN/Infinity anywhere is an InputError."""
    p = Path(path)
    check_readable(p, what, missing=f"{what} not found")
    try:
        text = p.read_text()
    except UnicodeDecodeError:
        raise InputError(f"not a text file (expected {what})", p) from None
    try:
        return json.loads(text, parse_constant=_no_constant)
    except json.JSONDecodeError as e:
        raise InputError(f"not valid JSON ({e.msg} at line {e.lineno})", p) from None
    except ValueError as e:  # NaN / Infinity
        raise InputError(f"{e} (expected {what} with finite numbers)", p) from None


def _number(v, where: str, field: str, *, nullable: bool = True, nonneg: bool = False) -> float | None:
    if v is None and nullable:
        return None
    if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v):
        raise InputError(f"{field} must be a finite number{' or null' if nullable else ''}, got {v!r}", where)
    if nonneg and v < 0:
        raise InputError(f"{field} must be >= 0, got {v!r}", where)
    return float(v)


# --- labels ------------------------------------------------------------------------------------


def parse_labels(items: list[str]) -> dict[str, str]:
    """``["scene=cone", "method=full", ...]`` -> labels, checked (``--label`` in the error)."""
    labels: dict[str, str] = {}
    for item in items or []:
        key, sep, value = item.partition("=")
        key, value = key.strip(), value.strip()
        if not sep or not _NAME.match(key):
            raise InputError(f"expected KEY=VALUE with KEY a name, got {item!r}", setting="labels")
        if not value or "\n" in value or "\r" in value:
            raise InputError(f"label {key!r} needs a one-line, non-empty value, got {value!r}", setting="labels")
        if key in labels:
            raise InputError(f"label {key!r} given twice ({labels[key]!r} and {value!r})", setting="labels")
        labels[key] = value
    labels.setdefault("kind", "method")
    check_labels(labels)
    return labels


def check_labels(labels: object, where: str | Path | None = None) -> dict[str, str]:
    """``labels`` after checking it is a dict of non-empty strings with the required keys, a known kind and an integer
    seed; else :class:`InputError` naming ``where`` (a record file), or the ``labels`` setting."""
    if not isinstance(labels, dict):
        raise InputError("labels must be a JSON object", where, setting="labels")
    for k in REQUIRED_LABELS:
        if k not in labels:
            raise InputError(f"label {k!r} missing (every record needs {', '.join(REQUIRED_LABELS)})", where, setting="labels")
    for k, v in labels.items():
        if not isinstance(v, str) or not v:
            raise InputError(f"label {k!r} must be a non-empty string, got {v!r}", where, setting="labels")
    if labels.get("kind") not in KINDS:
        raise InputError(f"label kind must be one of {', '.join(KINDS)}, got {labels.get('kind')!r}", where, setting="labels")
    if "seed" in labels and not _SEED.match(labels["seed"]):
        raise InputError(f"label seed must be a non-negative integer, got {labels['seed']!r}", where, setting="labels")
    if "ablation" in labels and labels["ablation"] not in "abcde":
        raise InputError(f"label ablation must be a letter of paper Tab. 3 (a-e), got {labels['ablation']!r}", where, setting="labels")
    return labels


# --- inputs of a record ------------------------------------------------------------------------


def read_evaluation(path: str | Path) -> dict:
    """The parts of an ``inpaint360gs evaluate`` JSON a record keeps: metrics (missing ones null with a
    reason), their null reasons, the number of views and the weights files used."""
    data = read_json(path, "an evaluation JSON (inpaint360gs evaluate)")
    where = str(path)
    if not isinstance(data, dict) or not isinstance(data.get("mean"), dict):
        raise InputError("not an evaluation JSON: no 'mean' object (written by inpaint360gs evaluate)", where)
    mean, scene = data["mean"], data.get("scene_metrics", {})
    if not isinstance(scene, dict):
        raise InputError("'scene_metrics' must be a JSON object", where)
    old: dict[str, str] = {}  # what an older evaluation's numbers were (module docstring)
    if "unseen_share" not in scene and "amcr" in scene:  # written before the unseen share and AMCR were told apart
        scene, old["amcr"] = {**scene, "unseen_share": scene["amcr"], "amcr": None}, OLD_AMCR_REASON.format("evaluation")
    elif "silhouette_test" not in scene and "amcr" in scene:  # AMCR was the silhouette at the test cameras
        scene, old["amcr"] = {**scene, "silhouette_test": scene["amcr"], "amcr": None}, OLD_SILHOUETTE_REASON.format("evaluation")
    if "psnr" not in mean:
        raise InputError("not an evaluation JSON: 'mean' has no 'psnr'", where)
    given_reasons = data.get("null_reasons") if isinstance(data.get("null_reasons"), dict) else {}
    metrics, reasons = {}, {}
    for group, keys, src in (("mean", MEAN_METRICS, mean), ("scene_metrics", SCENE_METRICS, scene)):
        known = given_reasons.get(group) if isinstance(given_reasons.get(group), dict) else {}
        for k in keys:
            if k not in src:
                metrics[k], reasons[k] = None, f"not in the evaluation ({group}.{k} missing: not computed)"
                continue
            metrics[k] = _number(src[k], where, f"{group}.{k}")
            if metrics[k] is None:
                reasons[k] = old.get(k) or str(known.get(k) or "null in the evaluation, no reason given")
    weights = {}
    if not isinstance(data.get("weights") or {}, dict):
        raise InputError("'weights' must be a JSON object", where)
    for name, info in (data.get("weights") or {}).items():
        if isinstance(info, dict) and isinstance(info.get("sha256"), str):
            weights[name] = {"path": str(info.get("path", "")), "sha256": info["sha256"]}
        elif info is not None:
            raise InputError(f"weights.{name} must be an object with path and sha256 or null", where)
        else:
            weights[name] = None
    num_views = data.get("num_views")
    if num_views is not None and (isinstance(num_views, bool) or not isinstance(num_views, int) or num_views < 0):
        raise InputError(f"num_views must be a non-negative integer, got {num_views!r}", where)
    renders = data.get("renders_dir")
    return {"metrics": metrics, "null_reasons": reasons, "num_views": num_views, "weights": weights,
            "renders_dir": renders if isinstance(renders, str) else None}


def read_removal_scores(path: str | Path) -> dict:
    """The parts of an ``inpaint360gs score-removal`` JSON a record keeps: :data:`REMOVAL_METRICS` and
    ``amcr`` (missing or null ones with a reason), the removal folder and the scene's name."""
    data = read_json(path, "a removal scores JSON (inpaint360gs score-removal)")
    where = str(path)
    if not isinstance(data, dict) or not isinstance(data.get("scores"), dict):
        raise InputError("not a removal scores JSON: no 'scores' object (written by inpaint360gs score-removal)", where)
    known = data.get("null_reasons") if isinstance(data.get("null_reasons"), dict) else {}
    metrics, reasons = {}, {}
    for k in (*REMOVAL_METRICS, "amcr"):
        if k not in data["scores"]:
            raise InputError(f"not a removal scores JSON: 'scores' has no {k!r}", where)
        metrics[k] = _number(data["scores"][k], where, f"scores.{k}", nonneg=True)
        if metrics[k] is None:
            reasons[k] = str(known.get(k) or "null in the removal scores, no reason given")
    rec = provenance.read(path, "score-removal")
    removal = data.get("removal")
    return {"metrics": metrics, "null_reasons": reasons, "removal": removal if isinstance(removal, str) else None,
            "scene": rec.scene.get("name") if rec is not None else None}


def read_benchmark(path: str | Path) -> dict:
    """A Snakemake ``benchmark:`` TSV (one row per repeat): mean wall seconds, max RSS (MB), CPU seconds."""
    p = Path(path)
    check_readable(p, "a Snakemake benchmark TSV", missing="benchmark file not found")
    try:
        lines = [ln for ln in p.read_text().splitlines() if ln.strip()]
    except UnicodeDecodeError:
        raise InputError("not a text file (expected a Snakemake benchmark TSV)", p) from None
    if not lines:
        raise InputError("empty benchmark file (expected a header and one row per repeat)", p)
    header = lines[0].split("\t")
    if "s" not in header or "max_rss" not in header:
        raise InputError(f"not a Snakemake benchmark TSV: header needs columns 's' and 'max_rss', got {header[:4]}", p)
    rows = [ln.split("\t") for ln in lines[1:]]
    if not rows:
        raise InputError("benchmark file has a header but no rows", p)

    def column(name: str, required: bool) -> list[float | None]:
        if name not in header:
            return []
        i, out = header.index(name), []
        for n, row in enumerate(rows, 2):
            if len(row) != len(header):
                raise InputError(f"line {n} has {len(row)} fields, the header {len(header)}", p)
            text = row[i].strip()
            if text == "NA" and not required:
                out.append(None)
                continue
            try:
                v = float(text)
            except ValueError:
                raise InputError(f"line {n}: column {name!r} must be a number{'' if required else ' or NA'}, got {text!r}", p) from None
            if not math.isfinite(v) or v < 0:
                raise InputError(f"line {n}: column {name!r} must be a finite number >= 0, got {text!r}", p)
            out.append(v)
        return out

    secs = column("s", required=True)
    rss = [v for v in column("max_rss", required=False) if v is not None]
    cpu = column("cpu_time", required=False)
    cpu_known = [v for v in cpu if v is not None]
    return {
        "seconds": sum(secs) / len(secs),
        "seconds_per_repeat": secs,
        "max_rss_mb": max(rss) if rss else None,
        "cpu_seconds": sum(cpu_known) / len(cpu_known) if cpu_known and len(cpu_known) == len(cpu) else None,
        "repeats": len(secs),
    }


def parse_stage(item: str) -> tuple[str, Path]:
    """Split a ``NAME=BENCH.tsv`` argument into (name, path); :class:`InputError` when malformed."""
    name, sep, path = item.partition("=")
    if not sep or not _NAME.match(name.strip()) or not path:
        raise InputError(f"expected NAME=BENCH.tsv, got {item!r}", setting="stages")
    return name.strip(), Path(path)


def read_models(paths: list[str | Path]) -> dict:
    """Size of each model PLY and in all (bytes, MB); :class:`InputError` for a missing or non-PLY file."""
    files, total = [], 0
    for path in paths:
        p = Path(path)
        check_readable(p, "a model PLY file", missing="model file not found")
        with open(p, "rb") as f:
            magic = f.read(4)
        size = p.stat().st_size
        if magic[:3] != b"ply":
            raise InputError("not a PLY file (no 'ply' header)", p)
        files.append({"path": str(p), "bytes": size})
        total += size
    return {"files": files, "bytes": total, "storage_mb": total / 1e6}


def check_evaluation_of(evaluation: str | Path, labels: dict[str, str], models: list[dict]) -> None:
    """The evaluation must be of the labelled scene and, when the record names its model files, of
    renders of one of them (its provenance record, docs/architecture.md, "Provenance chain");
    an evaluation without a record is taken as it is."""
    rec = provenance.read(evaluation, "evaluate")
    if rec is None:
        return
    name = rec.scene.get("name")
    if name and name != labels["scene"]:
        raise InputError(f"an evaluation of scene {name!r}, but the record is labelled scene={labels['scene']}: "
                         f"give the evaluation of {labels['scene']!r} or correct the label", evaluation)  # fmt: skip
    shas = {m["sha256"] for m in models}
    if rec.model and shas and rec.model not in shas:
        given = ", ".join(m["path"] for m in models)
        raise InputError(f"the evaluated renders show another model (sha256 {provenance.short(rec.model)}) than --model {given}: "
                         "give the evaluation of this run's renders, or its model", evaluation)  # fmt: skip


def _check_scores_of(path: str | Path, scores: dict, labels: dict[str, str], amcr: float | None) -> None:
    """Removal scores of another scene, or of another removal than the evaluation's, are refused."""
    if scores["scene"] and scores["scene"] != labels["scene"]:
        raise InputError(f"removal scores of scene {scores['scene']!r}, but the record is labelled scene={labels['scene']}: "
                         f"give the scores of {labels['scene']!r}'s removal", path)  # fmt: skip
    theirs = scores["metrics"]["amcr"]
    if amcr is not None and theirs is not None and not math.isclose(amcr, theirs, rel_tol=1e-9, abs_tol=1e-9):
        raise InputError(f"removal scores with AMCR {theirs:.6g} %, the evaluation's removal {amcr:.6g} %: "
                         "scores of another removal than the one evaluated", path)  # fmt: skip


def make_record(
    labels: dict[str, str],
    *,
    evaluation: str | Path | None = None,
    removal_scores: str | Path | None = None,
    stages: list[tuple[str, Path]] = (),
    models: list[str | Path] = (),
    skip_reason: str | None = None,
) -> dict:
    """Build a record (see the module docstring); every input is read and checked here. The removal
    scores must be of the labelled scene and, where both hold AMCR, of the evaluation's removal."""
    check_labels(labels)
    if evaluation is None and not skip_reason:
        raise InputError("without an evaluation the record needs a skip reason (why this run has no metrics, e.g. no ground truth)", setting="skip_reason")
    if evaluation is not None and skip_reason:
        raise InputError("a skip reason is for runs without an evaluation; this one has an evaluation", setting="skip_reason")
    if skip_reason is not None and ("\n" in skip_reason or not skip_reason.strip()):
        raise InputError("must be one non-empty line", setting="skip_reason")
    sources: dict = {"eval": None, "removal_scores": None, "stages": {}, "models": []}
    if evaluation is not None:
        ev = read_evaluation(evaluation)
        sources["eval"] = {"path": str(evaluation), "sha256": sha256_file(evaluation), "renders_dir": ev["renders_dir"]}
        ev["metrics"].update(dict.fromkeys(REMOVAL_METRICS))
        ev["null_reasons"].update(dict.fromkeys(REMOVAL_METRICS, NO_REMOVAL_SCORES))
    else:
        ev = {"metrics": dict.fromkeys(METRICS), "null_reasons": dict.fromkeys(METRICS, skip_reason), "num_views": None, "weights": {}}
    if removal_scores is not None and evaluation is not None:
        rs = read_removal_scores(removal_scores)
        _check_scores_of(removal_scores, rs, labels, ev["metrics"].get("amcr"))
        sources["removal_scores"] = {"path": str(removal_scores), "sha256": sha256_file(removal_scores), "removal": rs["removal"]}
        for k in REMOVAL_METRICS:
            ev["metrics"][k] = rs["metrics"][k]
            ev["null_reasons"].pop(k, None)
            if rs["metrics"][k] is None:
                ev["null_reasons"][k] = rs["null_reasons"][k]
        if ev["metrics"]["amcr"] is None and rs["metrics"]["amcr"] is not None:  # an evaluation without --removal
            ev["metrics"]["amcr"] = rs["metrics"]["amcr"]
            ev["null_reasons"].pop("amcr", None)
    bench = {}
    for name, path in stages:
        if name in bench:
            raise InputError(f"stage {name!r} given twice", setting="stages")
        bench[name] = read_benchmark(path)
        sources["stages"][name] = {"path": str(path), "sha256": sha256_file(path)}
    model = read_models(list(models)) if models else None
    if model:
        sources["models"] = [{"path": f["path"], "sha256": sha256_file(f["path"])} for f in model["files"]]
    if evaluation is not None:
        check_evaluation_of(evaluation, labels, sources["models"])
    return {
        "format": FORMAT,
        "labels": dict(labels),
        "metrics": ev["metrics"],
        "null_reasons": ev["null_reasons"],
        "skip_reason": skip_reason.strip() if skip_reason else None,
        "num_views": ev["num_views"],
        "stages": bench,
        "model": model,
        "weights": ev["weights"],
        "sources": sources,
    }


# --- reading records back ----------------------------------------------------------------------


def check_record(data: object, where: str) -> dict:
    """Validate a record read from ``where``; returns it (with ``_path`` set)."""
    if not isinstance(data, dict):
        raise InputError(f"expected a record (JSON object), found a JSON {type(data).__name__}", where)
    if data.get("format") not in (FORMAT, FORMAT_2, FORMAT_1):
        raise InputError(f"not a table record (format {data.get('format')!r}, expected {FORMAT!r}; written by inpaint360gs table record)", where)
    check_labels(data.get("labels"), where)
    metrics = data.get("metrics")
    if not isinstance(metrics, dict):
        raise InputError("'metrics' must be a JSON object", where)
    reasons = data.get("null_reasons")
    if data["format"] == FORMAT_1 and "unseen_share" not in metrics:
        metrics["unseen_share"], metrics["amcr"], metrics["roi_depth_off"] = metrics.get("amcr"), None, None
        if isinstance(reasons, dict):
            if "amcr" in reasons:
                reasons["unseen_share"] = reasons.pop("amcr")
            reasons["amcr"] = data.get("skip_reason") or OLD_AMCR_REASON.format("record")
            reasons["roi_depth_off"] = data.get("skip_reason") or "not recorded: a record of format 1"
        metrics["silhouette_test"] = None
        if isinstance(reasons, dict):
            reasons["silhouette_test"] = data.get("skip_reason") or "not recorded: a record of format 1"
    elif data["format"] == FORMAT_2 and "silhouette_test" not in metrics:
        metrics["silhouette_test"], metrics["amcr"] = metrics.get("amcr"), None
        if isinstance(reasons, dict):
            if "amcr" in reasons:
                reasons["silhouette_test"] = reasons.pop("amcr")
            reasons["amcr"] = data.get("skip_reason") or OLD_SILHOUETTE_REASON.format("record")
    if data["format"] in (FORMAT_1, FORMAT_2):
        for k in REMOVAL_METRICS:
            metrics.setdefault(k, None)
            if isinstance(reasons, dict):
                reasons.setdefault(k, data.get("skip_reason") or f"not recorded: a record of format {data['format'][-1]}")
    for k in METRICS:
        if k not in metrics:
            raise InputError(f"metric {k!r} missing", where)
        _number(metrics[k], where, f"metrics.{k}")
    skip = data.get("skip_reason")
    if skip is not None and not isinstance(skip, str):
        raise InputError("'skip_reason' must be a string or null", where)
    if skip is None and all(metrics[k] is None for k in METRICS):
        raise InputError("every metric is null but no skip_reason says why", where)
    if not isinstance(data.get("null_reasons", {}), dict):
        raise InputError("'null_reasons' must be a JSON object", where)
    stages = data.get("stages", {})
    if not isinstance(stages, dict):
        raise InputError("'stages' must be a JSON object", where)
    for name, st in stages.items():
        if not isinstance(st, dict):
            raise InputError(f"stage {name!r} must be a JSON object", where)
        _number(st.get("seconds"), where, f"stages.{name}.seconds", nullable=False, nonneg=True)
        _number(st.get("max_rss_mb"), where, f"stages.{name}.max_rss_mb", nonneg=True)
    model = data.get("model")
    if model is not None:
        if not isinstance(model, dict):
            raise InputError("'model' must be a JSON object or null", where)
        _number(model.get("storage_mb"), where, "model.storage_mb", nullable=False, nonneg=True)
    weights = data.get("weights", {})
    if not isinstance(weights, dict) or any(w is not None and not (isinstance(w, dict) and isinstance(w.get("sha256"), str)) for w in weights.values()):
        raise InputError("'weights' must map names to {path, sha256} or null", where)
    data["_path"] = where
    return data


def load_records(paths: list[str | Path]) -> list[dict]:
    """Read and check records; two records of the same (scene, method, segmenter, seed) are refused."""
    if not paths:
        raise InputError("no record files given")
    out, seen = [], {}
    for p in paths:
        rec = check_record(read_json(p, "a table record (inpaint360gs table record)"), str(p))
        lab = rec["labels"]
        key = (lab["scene"], lab["method"], lab["segmenter"], lab.get("seed", ""))
        if key in seen:
            seed = f", seed {key[3]}" if key[3] else ""
            raise InputError(f"scene {key[0]!r}, method {key[1]!r}, segmenter {key[2]!r}{seed} appears twice (also in {seen[key]})", p)
        seen[key] = str(p)
        out.append(rec)
    return out
