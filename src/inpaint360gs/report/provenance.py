"""Where a table comes from: the git commit (:func:`git_commit`), the one-line provenance under every
Markdown table, and ``provenance.json`` of the paper's tables (commit, config, package versions,
machine, seeds, bootstrap settings, weights files, input records).
"""

from __future__ import annotations

import datetime as _dt
import hashlib
import importlib.metadata
import os
import platform
import subprocess
from pathlib import Path

from inpaint360gs.core.errors import InputError
from inpaint360gs.core.files import check_readable
from inpaint360gs.report import stats
from inpaint360gs.report.records import sha256_file
from inpaint360gs.report.table_model import Bootstrap


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
    """One line naming the git commit, the UTC time and the machine."""
    now = _dt.datetime.now(_dt.timezone.utc).strftime("%Y-%m-%d %H:%M UTC")
    return f"commit {git_commit()}, {now}, {platform.machine()} {platform.processor() or ''}".strip()


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
    """A config YAML's path, sha256, text and parsed content (None for no path); :class:`InputError` when unreadable or
    not YAML."""
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


def provenance(records: list[dict], config: dict | None, seeds: list[int] | None, outputs: list[str], boot: Bootstrap = Bootstrap()) -> dict:
    """What ``provenance.json`` holds: weights files used, seeds and their source, the config, the outputs, the
    bootstrap settings."""
    weights: dict[tuple[str, str], dict] = {}
    for r in records:
        for name, info in (r.get("weights") or {}).items():
            if info is None:
                continue
            k = (Path(info.get("path", "")).name, info["sha256"])
            weights.setdefault(k, {"name": name, "file": k[0], "sha256": k[1], "records": 0})["records"] += 1
    seeds_source = "given" if seeds else None
    labelled = sorted({int(r["labels"]["seed"]) for r in records if "seed" in r["labels"]})
    if not seeds and labelled:
        seeds, seeds_source = labelled, "record seed labels"
    if not seeds and config and isinstance(config.get("parsed"), dict) and "seed" in config["parsed"]:
        seeds, seeds_source = [config["parsed"]["seed"]], "config seed"
    return {
        "created": _dt.datetime.now(_dt.timezone.utc).isoformat(timespec="seconds"),
        "git_commit": git_commit(),
        "config": None if config is None else {k: config[k] for k in ("path", "sha256", "content")},
        "seeds": seeds or None,
        "seeds_source": seeds_source,
        "bootstrap": {"method": "cluster bootstrap, percentile at the level expanded for the number of scenes (report/stats.py, "
                                "scipy.stats.bootstrap): paired differences formed per (scene, seed) run; intervals resample scenes, "
                                "each with all its seeds",
                      "resampling_unit": "scene", "min_scenes": stats.MIN_SCENES,
                      "below_min_scenes": f"the interval resamples runs and the verdict is '{stats.SEED_NOISE}'",
                      "min_pairs": stats.MIN_PAIRS, **boot.kw()},
        "packages": _versions(),
        "machine": _machine(),
        "weights": sorted(weights.values(), key=lambda w: (w["name"], w["file"])),
        "records": [{"path": r["_path"], "sha256": sha256_file(r["_path"]), "labels": r["labels"]} for r in records],
        "outputs": outputs,
    }
