"""The runs above a removal limit, kept where a reader can open them: ``inpaint360gs table paper
--keep-failed DIR`` (the workflow's ``keep_failed`` setting; docs/architecture.md, "Ground-truth
removal scores").

For every run :func:`.builders.removal_failures` lists, ``DIR/<scene>/seed<k>/<segmenter>/<method>/``
gets a copy of the method's test renders (``renders/``, the folder its evaluation scored) and of its
removal's masks at the training views (``removal_masks/``, what the removal left to fill), and
``DIR/failed.json`` lists each run with the limits it breaks, its values and the folders copied from.
A run whose record names no such folder (a record made by hand) is listed with the folder null.
The folder is written whole (atomically), also when no run fails (then ``failed.json`` lists none).
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from inpaint360gs.io.atomic import atomic_dir
from inpaint360gs.report.builders import removal_failures


def _source(rec: dict, kind: str) -> Path | None:
    """The folder a record's sources name: ``renders`` (the evaluated renders) or ``masks`` (the removal's)."""
    src = rec.get("sources") or {}
    if kind == "renders":
        where = (src.get("eval") or {}).get("renders_dir")
        return Path(where) if where else None
    where = (src.get("removal_scores") or {}).get("removal")
    return Path(where) / "masks" if where else None


def keep_failed(records: list[dict], out_dir: str | Path) -> list[dict]:
    """Copy what :func:`.builders.removal_failures` lists into ``out_dir`` (module docstring); returns
    the entries of ``failed.json``."""
    runs: dict[tuple, dict] = {}
    for f in removal_failures(records):
        key = (f["scene"], f["seed"], f["segmenter"], f["method"])
        entry = runs.setdefault(key, {"scene": f["scene"], "seed": f["seed"], "segmenter": f["segmenter"], "method": f["method"],
                                      "above": [], "copied_from": {k: None for k in ("renders", "removal_masks")}, "_record": f["record"]})
        entry["above"].append({"limit": f["limit"], "value": f["value"], "max": f["max"]})
    with atomic_dir(out_dir, overwrite=True) as tmp:
        for (scene, seed, seg, method), entry in runs.items():
            rec = entry.pop("_record")
            dest = tmp / scene / f"seed{seed}" / seg / method
            for name, kind in (("renders", "renders"), ("removal_masks", "masks")):
                src = _source(rec, kind)
                if src is not None and src.is_dir():
                    shutil.copytree(src, dest / name, copy_function=shutil.copyfile)
                    entry["copied_from"][name] = str(src)
            entry["folder"] = str(Path(scene) / f"seed{seed}" / seg / method)
        (tmp / "failed.json").write_text(json.dumps({"runs": list(runs.values())}, indent=1, allow_nan=False) + "\n")
    return list(runs.values())
