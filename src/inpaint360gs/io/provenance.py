"""Provenance records: what every stage output was made from, and the check each stage makes on the
chain of its inputs before its work (docs/architecture.md, "Provenance chain").

A record sits under ``"provenance"`` in the JSON a stage writes (``core.layout.STAGE_RECORDS``)::

    {"stage": "associate",
     "identity": "<sha256 of the stage, the scene's content and --resize, the inputs, the settings>",
     "scene": {"name": "cone", "content_sha256": "<Scene.fingerprint()>", "resize": 1},
     "inputs": {"model": "<sha256 of the PLY>", "segment": "<identity of the segment output>"},
     "outputs": {"point_cloud.ply": "<sha256>"}}

``inputs`` names a file by its sha256 and another stage's output by that stage's identity, so a stage
checks the chain by comparing strings: an input made from another scene (content or ``--resize``) and
two inputs that do not belong together (segments made with another model, a removal made from
another distillation) are refused before any work, with one line naming both. ``outputs`` holds the
sha256 of the files a later stage reads by path (models), hashed once when they are written. The
identity depends only on what determines the output (no timings, no paths), so a rerun gives the
same one. Outputs written before records existed carry ``inputs.scene_content_sha256`` (segment,
distill); they are read as records without an identity and checked by what they hold.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass, field
from pathlib import Path

from inpaint360gs.core.errors import InputError
from inpaint360gs.core.files import parse_json, path_problem, sha256_file
from inpaint360gs.core.layout import RENDER_COLOR_DIR, STAGE_RECORDS

KEY = "provenance"


@dataclass(frozen=True)
class Record:
    """A stage output's provenance record and the JSON file it was read from."""

    path: Path
    data: dict = field(default_factory=dict)

    @property
    def stage(self) -> str | None:
        """The stage that wrote the record, or None."""
        return self.data.get("stage")

    @property
    def identity(self) -> str | None:
        """The record's identity hash, or None."""
        return self.data.get("identity")

    @property
    def scene(self) -> dict:
        """What the record says of its scene ({} when nothing)."""
        return self.data.get("scene") or {}

    @property
    def inputs(self) -> dict:
        """The identities of the inputs, by name ({} when none)."""
        return self.data.get("inputs") or {}

    @property
    def outputs(self) -> dict:
        """The outputs' hashes, by file ({} when none)."""
        return self.data.get("outputs") or {}

    @property
    def model(self) -> str | None:
        """sha256 of the model the output shows: the model a render or an evaluation was made from,
        or the stage's own PLY."""
        return self.inputs.get("model") if self.stage in ("render", "evaluate") else self.outputs.get("point_cloud.ply")


def short(digest: object) -> str:
    """The first 12 characters of a digest string, for messages; ``str()`` of anything else."""
    return digest[:12] if isinstance(digest, str) else str(digest)


def scene_name(root: str | Path) -> str:
    """A scene's name: its folder's name (the resolved one for ``.`` and the like)."""
    p = Path(root)
    if p.name:
        return p.name
    try:
        return p.resolve().name
    except (OSError, RuntimeError):
        return str(p)


def scene_entry(scene) -> dict:
    """What a record says about the scene (an :class:`~inpaint360gs.io.scene.Scene`)."""
    return {"name": scene_name(scene.root), "content_sha256": scene.fingerprint(), "resize": scene.resize}


def make(stage: str, scene, inputs: dict[str, str | None], settings: object = None) -> dict:
    """The record of a ``stage`` output made from ``scene`` and ``inputs`` (name -> identity or sha256;
    None entries are left out) with ``settings`` (any JSON-able value; part of the identity only)."""
    entry = scene_entry(scene) if scene is not None else None
    ins = {k: v for k, v in sorted(inputs.items()) if v is not None}
    # every file the stage read through the scene (images_<R>/, masks), not only the resize-independent content
    what = [stage, None if entry is None else [scene.read_fingerprint(), entry["resize"]], ins, settings]
    identity = hashlib.sha256(json.dumps(what, sort_keys=True, default=str).encode()).hexdigest()
    return {"stage": stage, "identity": identity, "scene": entry, "inputs": ins}


def add_outputs(record: dict, folder: str | Path, *names: str) -> None:
    """Record the sha256 of ``folder/name`` for each of ``names`` in ``record``'s provenance (when it has
    one): the files a later stage will read by path."""
    prov = record.get(KEY)
    if isinstance(prov, dict):
        prov["outputs"] = {n: sha256_file(Path(folder) / n) for n in names}


def read(path: str | Path, stage: str | None = None) -> Record | None:
    """The record in the stage JSON ``path``; None when the file is absent or records nothing (an output
    of unknown origin, accepted as it is). A JSON that cannot be read, or a malformed record, is an
    :class:`InputError` naming the file."""
    path = Path(path)
    if not path.exists():
        return None
    problem = path_problem(path)
    if problem is not None:
        raise InputError(problem, path)
    data = parse_json(path)
    if not isinstance(data, dict):
        return None  # e.g. an association's objects.json written as a bare list of ids
    prov = data.get(KEY)
    if prov is not None:
        ok = isinstance(prov, dict) and isinstance(prov.get("identity"), str) and isinstance(prov.get("inputs", {}), dict)
        ok = ok and isinstance(prov.get("scene") or {}, dict) and isinstance(prov.get("outputs", {}), dict)
        if not ok:
            raise InputError(f"malformed {KEY} record (expected stage, identity, scene, inputs)", path)
        return Record(path, prov)
    legacy = data.get("inputs")
    if isinstance(legacy, dict) and isinstance(legacy.get("scene_content_sha256"), str):
        scene = {"name": scene_name(legacy.get("scene", "")), "content_sha256": legacy["scene_content_sha256"], "resize": legacy.get("resize")}
        inputs = {"model": legacy["model_sha256"]} if isinstance(legacy.get("model_sha256"), str) else {}
        return Record(path, {"stage": stage or data.get("stage"), "identity": None, "scene": scene, "inputs": inputs})
    return None


def of_stage(folder: str | Path, stage: str) -> Record | None:
    """The record of ``stage``'s output folder ``folder``."""
    return read(Path(folder) / STAGE_RECORDS[stage], stage)


def of_file(path: str | Path) -> Record | None:
    """The record of the stage that wrote the file ``path`` (a model): the stage JSON beside it that
    lists it among its outputs with the file's current sha256; None when there is none (a model of
    unknown origin, or one replaced since the stage wrote it)."""
    path = Path(path)
    for stage, name in STAGE_RECORDS.items():
        try:
            rec = read(path.parent / name, stage)
        except (InputError, OSError):
            continue  # an unreadable neighbour says nothing about this file
        if rec is not None and path.name in rec.outputs:
            return rec if rec.outputs[path.name] == sha256_file(path) else None
    return None


def of_renders(folder: str | Path) -> Record | None:
    """The record of the stage that wrote a folder of renders: ``render``'s output (or its ``color/``),
    or an inpainting's ``renders/test/``."""
    d = Path(folder)
    candidates = [(d / STAGE_RECORDS["render"], "render")]
    if d.name == RENDER_COLOR_DIR:
        candidates.append((d.parent / STAGE_RECORDS["render"], "render"))
    if d.parent.name == "renders":
        candidates.append((d.parent.parent / STAGE_RECORDS["inpaint"], "inpaint"))
    for path, stage in candidates:
        if path.is_file():
            return read(path, stage)
    return None


def check_scene(rec: Record | None, scene, hint: str, where: str | Path | None = None, *, same_resize: bool = True) -> None:
    """An input whose record is ``rec`` must have been made from ``scene`` (same content and, with
    ``same_resize``, the same ``--resize``: what per-view images and masks need; a model is not tied
    to one); else an :class:`InputError` naming the input (``where``, default the record's file) and
    the scene, ending with ``hint`` (what to do)."""
    if rec is None or not isinstance(rec.scene.get("content_sha256"), str):
        return
    s = rec.scene
    where = rec.path if where is None else where
    recorded = "" if Path(where) == rec.path else f"recorded in {rec.path}"
    if same_resize and s.get("resize") is not None and s["resize"] != scene.resize:
        note = f" ({recorded})" if recorded else ""
        raise InputError(f"made at --resize {s['resize']}{note}, but this stage runs at --resize {scene.resize}: pass --resize {s['resize']}, or {hint}", where)
    if s["content_sha256"] != scene.fingerprint():
        note = f"; {recorded}" if recorded else ""
        raise InputError(
            f"made from scene {s.get('name') or '?'} (content {short(s['content_sha256'])}{note}), but {scene.root} has content "
            f"{short(scene.fingerprint())}: another scene's files, or the scene changed since; {hint}",
            where,
        )


_PROSE = {"segment": "segmentation", "associate": "association", "distill": "distillation"}  # input names in messages


def check_link(rec: Record | None, name: str, expected: str | None, given: str | Path, hint: str) -> None:
    """The input whose record is ``rec`` must have been made from ``given`` (identity or sha256
    ``expected``) as its input ``name``; else an :class:`InputError` naming both."""
    if rec is None or expected is None:
        return
    got = rec.inputs.get(name)
    if got is not None and got != expected:
        what = _PROSE.get(name, name)
        raise InputError(f"made from another {what} than {given} (recorded {short(got)}, given {short(expected)}): {hint}", rec.path)


def check_model(path: str | Path, scene, hint: str = "give the model trained on this scene") -> str:
    """sha256 of the model file ``path``, after checking that the stage that wrote it (if it recorded
    one) made it from ``scene`` (at any ``--resize``)."""
    check_scene(of_file(path), scene, hint, where=path, same_resize=False)
    return sha256_file(path)
