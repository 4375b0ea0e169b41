"""``inpaint360gs run``: the whole method on one scene folder, one sub-folder per stage
(``core.layout.RunLayout``; paper Alg. 1): train → segment → associate → distill → remove → inpaint.

Each stage is skipped when it is up to date: ``OUT/run.json`` records, per stage, a signature of
what determines its output (the signatures of the stages it reads, the scene's content hash, a
given model's hash, the stage's settings); a stage whose signature is unchanged and whose output is
there is not run again, and a changed stage reruns every stage after it. Stages write their
folders atomically, so an interrupted run resumes at the stage it was in (3DGS training resumes
from its checkpoint).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import os
import time
from pathlib import Path

from inpaint360gs.core.errors import CheckFailedError, InputError
from inpaint360gs.core.files import check_apart, parse_json, sha256_file
from inpaint360gs.core.layout import SCENE_JSON, RunLayout
from inpaint360gs.io.arguments import bool_argument, path_argument, scene_argument
from inpaint360gs.io.atomic import remove_tree, write_text
from inpaint360gs.io.lock import LOCK_NAME, folder_lock
from inpaint360gs.io.scene import Scene
from inpaint360gs.pipeline.check import CHECK_JSON, CHECK_PICTURE, CHECKED_STAGES, CheckReport, check_run, load_check, write_report
from inpaint360gs.pipeline.config import RunConfig
from inpaint360gs.remove.select import Click, check_clicks, check_selection, clicks_from_json
from inpaint360gs.segment.base import get_segmenter

STAGES = ("train", "segment", "associate", "distill", "remove", "inpaint")
RUN_JSON = "run.json"
SECONDS_KEY = "seconds"  # run.json: wall seconds of each stage when it last ran
CREATED_KEY = "created"  # run.json: the manifest, stage -> [device, inode] of the folder the run wrote (null while it runs)
STAGE_WORK = {  # what a stage does, said before it starts (some work silently for a minute)
    "train": "training 3DGS", "segment": "raw 2D masks of the training views", "associate": "Key Object Management across views",
    "distill": "object-ID distillation", "remove": "selecting and removing the object", "inpaint": "virtual views, 2D and 3D inpainting",
}  # fmt: skip


def check_run_folder(out: Path) -> None:
    """:class:`InputError` unless ``out`` is absent, empty or a run's folder: what it holds must be
    the stages' folders, ``run.json``, the run's lock and their temporaries (a stage replaces its
    folder as a whole)."""
    if not out.is_dir():
        return
    layout = RunLayout(out)
    names = {p.name for p in (layout.gs, layout.segment, layout.associate, layout.distill, layout.removed, layout.inpainted)} | {RUN_JSON, LOCK_NAME, CHECK_JSON, CHECK_PICTURE}
    bases = {n.split(".")[0] for n in names}
    for p in sorted(out.iterdir()):
        if p.name not in names and not (p.name.startswith(".") and p.name[1:].split(".")[0] in bases):
            raise InputError(f"output folder holds {p.name!r}, which no stage of a run writes: choose another output (or an empty folder)", out)


def _signature(*parts) -> str:
    return hashlib.sha256(json.dumps(parts, sort_keys=True, default=str).encode()).hexdigest()


def _settings(obj) -> object:
    return dataclasses.asdict(obj) if dataclasses.is_dataclass(obj) else obj


def check_run_arguments(out: object, cfg: object, *, model: object = None, clicks: object = None, ids: object = None, progress: object = True, accept: object = False) -> None:
    """The types and ranges of a run's arguments but the scene, before any work (:class:`Runner`,
    :func:`inpaint360gs.remove_object`): :class:`InputError` naming the argument."""
    path_argument(out, "out")
    if not isinstance(cfg, RunConfig):
        raise InputError(f"expected a RunConfig (a preset, inpaint360gs.get_preset), got {type(cfg).__name__}", setting="preset")
    if model is not None:
        path_argument(model, "model")
    check_selection(clicks, ids)
    bool_argument(progress, "progress")
    bool_argument(accept, "accept")


def no_clicks_reason(scene: Scene) -> str:
    """Why the scene gives no click to select an object by (for the error asking for --click or --id)."""
    if not (scene.root / SCENE_JSON).is_file():
        return f"the scene has no {SCENE_JSON} to take clicks from"
    return f"{SCENE_JSON} names no clicks"


def scene_clicks(scene: Scene) -> list[Click]:
    """The clicks ``scene.json`` names (``clicks``: view, x, y), as a user would give them."""
    return clicks_from_json(scene.info.get("clicks", []), scene.root / SCENE_JSON)


class Runner:
    """One run of the method on ``scene`` into ``out`` (see the module docstring).

    Args:
        scene: The scene to work on.
        out: The run's folder: absent, empty, or an earlier run's.
        cfg: Every stage's settings.
        model: A trained 3DGS PLY of the scene; the train stage is then skipped.
        clicks: Clicks on the object to remove; default: ``scene.json``'s (unless ``ids`` are given).
        ids: Object ids to remove besides the clicked ones.
        progress: Show progress bars.
        announce: Print what each stage does before it starts.
        accept: Finish with the result even when it fails the run's own check (it is still recorded
            as failed in ``check.json``).
        on_stage: Called as ``on_stage(stage, what, seconds)`` when a stage starts (``what`` is
            ``"running"``, ``seconds`` None) and when it is done (``"ran"`` with its wall seconds,
            ``"up to date"`` or ``"given"``): the viewer's per-stage progress.

    Raises:
        InputError: Any argument of the wrong type or out of range (naming it), a setting out of range
            (:meth:`RunConfig.validate`), the model file is missing, there is no object to remove, a
            click lies outside its view, ``out`` overlaps the scene or the model, or ``out`` holds
            something no stage writes. All before any work.
    """

    def __init__(self, scene: Scene, out: str | Path, cfg: RunConfig, *, model: str | Path | None = None, clicks: list[Click] | None = None, ids: list[int] | None = None, progress: bool = True,
                 announce: bool = False, accept: bool = False, on_stage=None):
        scene_argument(scene)
        check_run_arguments(out, cfg, model=model, clicks=clicks, ids=ids, progress=progress, accept=accept)
        cfg.validate()
        self.scene = scene
        self.layout = RunLayout(Path(out))
        self.cfg = cfg
        self.model_path = Path(model) if model is not None else None
        if self.model_path is not None and not self.model_path.is_file():
            raise InputError("model file not found", self.model_path)
        check_apart({"OUT": out}, {"SCENE": scene.root, "MODEL": model}, replaced=False)  # the stages replace their sub-folders only
        self.ids = list(ids or [])
        self.clicks = list(clicks) if clicks else ([] if self.ids else scene_clicks(scene))
        if not self.clicks and not self.ids:
            raise InputError(f"no object to remove: give --click VIEW:X,Y or --id N ({no_clicks_reason(scene)})", scene.root)
        # views and pixels now; what lies under them once the field exists
        check_clicks(scene, self.clicks, None if clicks else scene.root / "scene.json")
        check_run_folder(self.layout.root)
        self.progress = progress
        self.announce = announce  # say on stdout what each stage does before it starts
        self.accept = accept
        self.on_stage = on_stage if on_stage is not None else (lambda stage, what, seconds: None)
        self.check: CheckReport | None = None  # the last check of the result (after remove / inpaint)
        self.record_path = self.layout.root / RUN_JSON
        self.record = self._read_record()
        self.fingerprint = scene.read_fingerprint()  # every file the stages read through the scene, images_<R>/ too
        self.segmenter = get_segmenter(cfg.segmenter, **cfg.segmenter_options)
        self.segmenter_files = self.segmenter.input_digests(scene)  # the oracle's gt/, SAM's ONNX files

    def _read_record(self) -> dict:
        if not self.record_path.is_file():
            return {}
        try:
            data = parse_json(self.record_path)
        except InputError:
            return {}  # an unreadable record: everything reruns (and no folder counts as the run's own)
        return data if isinstance(data, dict) else {}

    def _save(self) -> None:
        write_text(self.record_path, json.dumps(self.record, indent=1) + "\n")

    @property
    def model_file(self) -> Path:
        """The 3DGS PLY the later stages read: the given model, else the one trained into the run."""
        return self.model_path if self.model_path is not None else self.layout.model

    # --- signatures: what determines each stage's output ------------------------------------------
    def signatures(self) -> dict[str, str]:
        """Each stage's signature (hex SHA-256 of what determines its output), by stage name."""
        c = self.cfg
        sig = {}
        model_id = ("given", sha256_file(self.model_path)) if self.model_path is not None else ("trained", _settings(c.train))
        sig["train"] = _signature("train", self.fingerprint, model_id)
        sig["segment"] = _signature("segment", sig["train"], c.segmenter, c.segmenter_options, c.seed, self.segmenter_files)
        sig["associate"] = _signature("associate", sig["segment"], _settings(c.association))
        sig["distill"] = _signature("distill", sig["associate"], _settings(c.distill))
        sig["remove"] = _signature("remove", sig["distill"], [str(k) for k in self.clicks], self.ids, _settings(c.removal))
        sig["inpaint"] = _signature("inpaint", sig["remove"], _settings(c.inpaint))
        return sig

    def _outputs(self, stage: str) -> Path:
        lay = self.layout
        return {
            "train": self.model_file, "segment": lay.segment / "segment.json", "associate": lay.associate / "objects.json",
            "distill": lay.distill / "classifier.json", "remove": lay.removed / "removal.json", "inpaint": lay.inpainted / "inpaint.json",
        }[stage]  # fmt: skip

    def up_to_date(self, stage: str, sig: str) -> bool:
        """Whether ``stage`` was recorded with signature ``sig`` and its main output file exists."""
        return self.record.get(stage) == sig and self._outputs(stage).is_file()

    def _folder(self, stage: str) -> Path:
        lay = self.layout
        return {"train": lay.gs, "segment": lay.segment, "associate": lay.associate, "distill": lay.distill, "remove": lay.removed, "inpaint": lay.inpainted}[stage]

    def _own(self, stage: str) -> None:
        """:class:`InputError` unless ``stage``'s folder is one this run wrote: listed in run.json's
        manifest (or, in a record older than the manifest, with a signature), a real folder (not a
        link), the same one it wrote. Clean-up removes nothing else (docs/architecture.md, "Reliability")."""
        folder, created = self._folder(stage), self.record.get(CREATED_KEY)
        created = created if isinstance(created, dict) else {}
        if folder.is_symlink() or not folder.is_dir():
            raise InputError(f"{folder.name} is {'a symbolic link' if folder.is_symlink() else 'not a folder'}, not a folder this run wrote; a run removes only "
                             "what it created: remove it yourself, or choose another output", folder)  # fmt: skip
        if stage not in created and (CREATED_KEY in self.record or stage not in self.record):
            raise InputError(f"{folder.name}/ was not written by this run ({RUN_JSON} does not list it) and no longer follows from the settings; "
                             "a run removes only what it created: remove it yourself, or choose another output", folder)  # fmt: skip
        st = os.stat(folder)
        if isinstance(created.get(stage), list) and created[stage] != [st.st_dev, st.st_ino]:
            raise InputError(f"{folder.name}/ was replaced since this run wrote it; a run removes only what it created: remove it yourself, or choose another output", folder)

    def remove_stale(self, sigs: dict[str, str]) -> list[str]:
        """Remove every stage folder that does not follow from the current settings (its recorded
        signature differs, or it is not recorded), so that OUT never holds a stale result; returns
        the stages removed. Kept: a 3DGS folder this run will train into (its checkpoint resumes a
        matching run, and the trainer discards one that does not match) and one holding ``--model``.
        Every folder to remove is checked to be the run's own first (:meth:`_own`): a refusal
        removes nothing."""
        stale = []
        for stage in STAGES:
            folder = self._folder(stage)
            if not os.path.lexists(folder) or self.up_to_date(stage, sigs[stage]):
                continue
            if stage == "train" and not folder.is_symlink() and (self.model_path is None or self.model_path.resolve().is_relative_to(folder.resolve())):
                continue
            self._own(stage)
            stale.append(stage)
        if any(stage in CHECKED_STAGES for stage in stale):  # the report described what goes now
            for name in (CHECK_JSON, CHECK_PICTURE):
                (self.layout.root / name).unlink(missing_ok=True)
        for stage in stale:
            remove_tree(self._folder(stage))
            self.record.pop(stage, None)
            self.record.get(CREATED_KEY, {}).pop(stage, None)
            self._save()
        return stale

    def check_targets(self, sigs: dict[str, str]) -> None:
        """The ids to remove, checked against the distillation when it is up to date (its object ids),
        before anything is removed: a mistyped ``--id`` into a finished run deletes nothing."""
        if not self.ids or not self.up_to_date("distill", sigs["distill"]):
            return
        from inpaint360gs.distill.field import read_classifier

        known = set(read_classifier(self.layout.distill / "classifier.json")[1]) - {0}
        for oid in self.ids:
            if oid not in known:
                raise InputError(f"unknown object id {oid} (the field knows {sorted(known)})", setting="ids")

    # --- the stages -------------------------------------------------------------------------------
    def run(self, until: str = "inpaint") -> list[tuple[str, str]]:
        """Run the stages up to ``until`` (one of :data:`STAGES`), skipping those up to date.

        After ``remove`` and ``inpaint`` the result is checked (:mod:`.check`: ``check.json``,
        ``check.png``); a failed check stops the run unless it was made with ``accept``.

        Returns: (stage, "ran" | "up to date" | "given") pairs, in order.
        Raises: :class:`InputError` for an unknown ``until``, :class:`CheckFailedError` when the
        result fails its check (its outputs are kept), and whatever a stage raises (the stages
        before it stay recorded)."""
        if not isinstance(until, str) or until not in STAGES:
            raise InputError(f"unknown stage {until!r} (one of {', '.join(STAGES)})", setting="until")
        sigs = self.signatures()
        self.check_targets(sigs)
        with folder_lock(self.layout.root):  # one run per OUT at a time (io/lock.py)
            self.record = self._read_record()  # as the previous holder left it
            self.remove_stale(sigs)
            done = []
            stages = STAGES[: STAGES.index(until) + 1]
            for stage in stages:
                if stage == "train" and self.model_path is not None:
                    done.append((stage, "given"))
                    self.on_stage(stage, "given", None)
                    continue
                if self.up_to_date(stage, sigs[stage]):
                    done.append((stage, "up to date"))
                    self.on_stage(stage, "up to date", None)
                    # a result that failed its check fails again, until accepted; a later checked stage
                    # that is up to date too holds the whole check (check.json keeps the last one)
                    later = [s for s in stages[stages.index(stage) + 1 :] if s in CHECKED_STAGES]
                    if stage in CHECKED_STAGES and not any(self.up_to_date(s, sigs[s]) for s in later):
                        self._check(stage, sigs[stage])
                    continue
                before = json.dumps(self.record) if self.record_path.is_file() else None
                self.record.pop(stage, None)
                created = self.record.setdefault(CREATED_KEY, {})
                created.setdefault(stage, None)  # in the manifest before it writes: a run killed half-way still owns its folder
                self._save()
                if self.announce:
                    print(f"{stage}: {STAGE_WORK[stage]} ...", flush=True)
                self.on_stage(stage, "running", None)
                t0 = time.perf_counter()
                try:
                    getattr(self, f"_{stage}")()
                except BaseException:
                    if not os.path.lexists(self._folder(stage)):  # refused before writing: OUT as it was
                        self.record = {} if before is None else json.loads(before)
                        self.record_path.unlink() if before is None else self._save()
                    raise
                st = os.stat(self._folder(stage))
                created[stage] = [st.st_dev, st.st_ino]
                self.record[stage] = sigs[stage]
                self.record.setdefault(SECONDS_KEY, {})[stage] = round(time.perf_counter() - t0, 1)
                self._save()
                done.append((stage, "ran"))
                self.on_stage(stage, "ran", self.record[SECONDS_KEY][stage])
                if stage in CHECKED_STAGES:
                    self._check(stage, sigs[stage])
        return done

    def _check(self, stage: str, signature: str) -> None:
        """Check the result after ``stage`` (:mod:`.check`; the report of an earlier run of the same
        outputs and limits is reused); raise when it fails and is not accepted."""
        self.check = load_check(self.layout, stage, signature, self.cfg.check)
        if self.check is None:
            if self.announce:
                print(f"check: scoring the result after {stage} ...", flush=True)
            self.check = self._score(stage, signature)
        elif self.check.accepted != (self.accept and not self.check.passed):  # a reused report, accepted now (or no longer)
            self.check.accepted = self.accept and not self.check.passed
            write_report(self.layout, self.check)
        failed = self.check.failed
        if failed and not self.accept:
            more = f" (and {len(failed) - 1} more check(s), see {CHECK_JSON})" if len(failed) > 1 else ""
            raise CheckFailedError(f"after {stage}: {failed[0].line()}{more}; rerun with --accept to keep this result", self.layout.root / CHECK_PICTURE)

    def _score(self, stage: str, signature: str) -> CheckReport:
        """Score the outputs after ``stage``, writing ``check.json`` and ``check.png``."""
        return check_run(self.scene, self.layout, self.model_file, stage, limits=self.cfg.check, signature=signature, accept=self.accept)

    def _train(self) -> None:
        from inpaint360gs.gs.trainer import train_stage

        train_stage(self.scene, self.layout.gs, self.cfg.train, resume=True, overwrite=True, progress=self.progress)

    def _model(self):
        from inpaint360gs.io.ply import read_ply

        return read_ply(self.model_file)

    def _segment(self) -> None:
        from inpaint360gs.segment.stage import segment_stage

        segment_stage(self.scene, self._model(), self.layout.segment, self.segmenter, model_path=self.model_file, overwrite=True, progress=self.progress)

    def _associate(self) -> None:
        from inpaint360gs.associate.stage import associate_stage

        associate_stage(self.scene, self._model(), self.layout.segment, self.layout.associate, self.cfg.association, overwrite=True, progress=self.progress,
                        model_path=self.model_file, meta={"scene": str(self.scene.root), "model": str(self.model_file)})  # fmt: skip

    def _distill(self) -> None:
        from inpaint360gs.distill.stage import distill_stage

        lay = self.layout
        distill_stage(self.scene, self.model_file, lay.associate / "object_mask", lay.associate / "objects.json", lay.distill, self.cfg.distill, overwrite=True, progress=self.progress)

    def _field(self):
        from inpaint360gs.distill.field import IdentityField

        return IdentityField.load(self.layout.distill)

    def _remove(self) -> None:
        from inpaint360gs.remove.stage import remove_stage

        remove_stage(self.scene, self._field(), self.layout.removed, self.cfg.removal, clicks=self.clicks, ids=self.ids,
                     backend=self.cfg.backend, overwrite=True, progress=self.progress, meta={"scene": str(self.scene.root)})  # fmt: skip

    def _inpaint(self) -> None:
        from inpaint360gs.inpaint.stage import inpaint_stage

        inpaint_stage(self.scene, self._field(), self.layout.removed, self.layout.inpainted, self.cfg.inpaint, overwrite=True, progress=self.progress)
