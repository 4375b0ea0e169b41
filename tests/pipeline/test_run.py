"""``inpaint360gs run`` (pipeline.run.Runner, paper Alg. 1): the stages in order, each skipped when
its signature (inputs, upstream signatures, settings) is unchanged and its output is there, each
rerun — with everything after it — when that changes.

The bookkeeping is tested with stages that only write their output file (fast and exact); one
real run on a tiny blobs scene (given model, 32x24 images, a few distillation steps) checks the
same through the CLI with the real stages.
"""

from __future__ import annotations

import dataclasses
import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from cli_harness import restore_threads  # noqa: F401  (the CLI run sets torch's thread count)
from scene_builder import blobs_model, write_png

from inpaint360gs.cli import main
from inpaint360gs.core.errors import CheckFailedError, InputError
from inpaint360gs.distill.config import DistillConfig
from inpaint360gs.gs.config import TrainConfig
from inpaint360gs.io.ply import write_ply
from inpaint360gs.io.scene import load_scene
from inpaint360gs.pipeline.check import CHECK_JSON, CHECK_PICTURE, Check, CheckLimits, CheckReport
from inpaint360gs.pipeline.run import CREATED_KEY, SECONDS_KEY, STAGES, RunConfig, Runner
from inpaint360gs.remove.config import RemovalConfig
from inpaint360gs.remove.select import Click
from inpaint360gs.associate.config import AssociationConfig

W, H = 32, 24
VIEW = "IMG_001.png"


class StubRunner(Runner):
    """Stages that write only the file the runner checks, and log that they ran."""

    def __init__(self, *a, log: list, fail: str | None = None, failing_checks: tuple[str, ...] = (), scored: list | None = None, **kw):
        super().__init__(*a, **kw)
        self.log, self.fail = log, fail
        self.failing_checks, self.scored = failing_checks, scored if scored is not None else []

    def _score(self, stage: str, signature: str) -> CheckReport:
        """A report whose one check fails after the stages in ``failing_checks``, written where the
        real one goes; ``scored`` logs each scoring (a reused report is not scored again)."""
        self.scored.append(stage)
        ok = stage not in self.failing_checks
        report = CheckReport(stage, [Check("selection", ok, "object" if ok else "backdrop", "object", "stub verdict")], self.accept and not ok,
                             signature=signature, limits=json.loads(json.dumps(dataclasses.asdict(self.cfg.check))))  # fmt: skip
        (self.layout.root / CHECK_PICTURE).write_bytes(b"picture")
        (self.layout.root / CHECK_JSON).write_text(json.dumps(report.to_json()))
        return report

    def _stage(self, name: str, path: Path) -> None:
        if name == self.fail:
            raise InputError(f"{name} failed (on purpose)")
        self.log.append(name)
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(name)

    def _train(self):
        self._stage("train", self.layout.model)

    def _segment(self):
        self._stage("segment", self.layout.segment / "segment.json")

    def _associate(self):
        self._stage("associate", self.layout.associate / "objects.json")

    def _distill(self):
        self._stage("distill", self.layout.distill / "classifier.json")  # a classifier of objects 1 and 2 (the runner reads their ids)
        (self.layout.distill / "classifier.json").write_text(json.dumps({"weight": [[0.0]] * 3, "bias": [0.0] * 3, "object_ids": [0, 1, 2]}))

    def _remove(self):
        self._stage("remove", self.layout.removed / "removal.json")

    def _inpaint(self):
        self._stage("inpaint", self.layout.inpainted / "inpaint.json")


def stub_run(tiny, out, cfg=None, until="inpaint", fail=None, **kw) -> tuple[list, list]:
    """(what each stage did, which stages ran) for one run."""
    root, model = tiny
    log: list = []
    kw = {"ids": [1], **kw}
    r = StubRunner(load_scene(root), out, cfg or RunConfig(), log=log, fail=fail, progress=False, **kw)
    return r.run(until), log


def test_up_to_date_stages_are_skipped_and_a_settings_change_reruns_from_that_stage(tiny_scene, tmp_path):
    out, model = tmp_path / "out", tiny_scene[1]
    cfg = RunConfig(distill=DistillConfig(iterations=5))
    done, ran = stub_run(tiny_scene, out, cfg, model=model)
    assert done == [("train", "given"), *((s, "ran") for s in STAGES[1:])]
    assert ran == list(STAGES[1:])
    record = json.loads((out / "run.json").read_text())
    assert set(record) == set(STAGES[1:]) | {SECONDS_KEY, CREATED_KEY} and set(record[CREATED_KEY]) == set(STAGES[1:])
    assert set(record[SECONDS_KEY]) == set(STAGES[1:]) and all(t >= 0 for t in record[SECONDS_KEY].values())  # wall time of each stage that ran

    done, ran = stub_run(tiny_scene, out, cfg, model=model)  # nothing changed
    assert ran == [] and done == [("train", "given"), *((s, "up to date") for s in STAGES[1:])]

    cases = [  # (the change, the stages that must run again)
        (lambda c: dataclasses.replace(c, distill=DistillConfig(iterations=6)), ["distill", "remove", "inpaint"]),
        (lambda c: dataclasses.replace(c, removal=RemovalConfig(threshold=0.8)), ["remove", "inpaint"]),
        (lambda c: dataclasses.replace(c, association=AssociationConfig(sigma=0.3)), ["associate", "distill", "remove", "inpaint"]),
        (lambda c: dataclasses.replace(c, segmenter_options={"backend": "torch"}), ["segment", "associate", "distill", "remove", "inpaint"]),
        (lambda c: dataclasses.replace(c, seed=1), ["segment", "associate", "distill", "remove", "inpaint"]),
    ]
    for change, want in cases:
        cfg = change(cfg)
        assert stub_run(tiny_scene, out, cfg, model=model)[1] == want
        assert stub_run(tiny_scene, out, cfg, model=model)[1] == []
    # another selection: only removal and what follows
    assert stub_run(tiny_scene, out, cfg, model=model, ids=[2])[1] == ["remove", "inpaint"]
    assert stub_run(tiny_scene, out, cfg, model=model, clicks=[Click(VIEW, 5, 5)])[1] == ["remove", "inpaint"]
    assert stub_run(tiny_scene, out, cfg, model=model, clicks=[Click(VIEW, 5, 5)])[1] == []


def test_a_failed_check_stops_the_run_until_accepted_and_is_not_scored_twice(tiny_scene, tmp_path):
    out, model = tmp_path / "out", tiny_scene[1]
    scored: list = []
    with pytest.raises(CheckFailedError, match="after remove: selection: stub verdict; rerun with --accept") as e:
        stub_run(tiny_scene, out, model=model, failing_checks=("remove",), scored=scored)
    assert e.value.path == out / CHECK_PICTURE  # the message names the picture
    assert scored == ["remove"] and not (out / "inpainted").exists()  # the long stage never started
    assert json.loads((out / CHECK_JSON).read_text())["failed"] == ["selection"]
    # the same outputs fail again, from the report already written (not scored again)
    with pytest.raises(CheckFailedError):
        stub_run(tiny_scene, out, model=model, failing_checks=("remove",), scored=scored)
    assert scored == ["remove"]
    # other limits: scored again
    cfg = RunConfig(check=CheckLimits(standing=0.05))
    with pytest.raises(CheckFailedError):
        stub_run(tiny_scene, out, cfg, model=model, failing_checks=("remove",), scored=scored)
    assert scored == ["remove", "remove"]
    # accepted: the run goes on, the report says it was accepted, the inpainting is checked too
    done, ran = stub_run(tiny_scene, out, cfg, model=model, failing_checks=("remove", "inpaint"), scored=scored, accept=True)
    assert ran == ["inpaint"] and done[-1] == ("inpaint", "ran") and scored[-2:] == ["remove", "inpaint"]
    report = json.loads((out / CHECK_JSON).read_text())
    assert report["stage"] == "inpaint" and not report["passed"] and report["accepted"]
    # the same, accepted again: nothing reruns or is scored; without accept it fails again
    assert stub_run(tiny_scene, out, cfg, model=model, failing_checks=("inpaint",), scored=scored, accept=True)[1] == []
    assert scored == ["remove", "remove", "inpaint"]
    with pytest.raises(CheckFailedError, match="after inpaint"):
        stub_run(tiny_scene, out, cfg, model=model, scored=scored)
    assert not json.loads((out / CHECK_JSON).read_text())["accepted"] and len(scored) == 3
    # a passing result after a change of the inpainting
    cfg = dataclasses.replace(cfg, inpaint=dataclasses.replace(cfg.inpaint, occluder_min_pixels=11))
    assert stub_run(tiny_scene, out, cfg, model=model, scored=scored)[1] == ["inpaint"]
    report = json.loads((out / CHECK_JSON).read_text())
    assert report["stage"] == "inpaint" and report["passed"] and not report["accepted"]
    with pytest.raises(InputError, match="accept"):
        stub_run(tiny_scene, out, model=model, accept="yes")


def test_training_settings_and_given_models(tiny_scene, tmp_path):
    out = tmp_path / "out"
    cfg = RunConfig(train=TrainConfig(iterations=10))
    assert stub_run(tiny_scene, out, cfg, until="segment")[1] == ["train", "segment"]
    assert stub_run(tiny_scene, out, cfg, until="segment")[1] == []
    cfg = dataclasses.replace(cfg, train=TrainConfig(iterations=11))
    assert stub_run(tiny_scene, out, cfg, until="segment")[1] == ["train", "segment"]
    # a given model: training is skipped; its content (not its name) decides
    given = tmp_path / "given.ply"
    given.write_bytes(tiny_scene[1].read_bytes())
    assert stub_run(tiny_scene, out, cfg, until="segment", model=given)[1] == ["segment"]
    assert stub_run(tiny_scene, out, cfg, until="segment", model=given)[1] == []
    model, _ = blobs_model(seed=1)
    write_ply(given, model)
    assert stub_run(tiny_scene, out, cfg, until="segment", model=given)[1] == ["segment"]


def test_until_stops_and_a_later_run_continues(tiny_scene, tmp_path):
    out, model = tmp_path / "out", tiny_scene[1]
    done, ran = stub_run(tiny_scene, out, model=model, until="associate")
    assert [s for s, _ in done] == ["train", "segment", "associate"] and ran == ["segment", "associate"]
    assert not (out / "distill").exists()
    assert stub_run(tiny_scene, out, model=model, until="remove")[1] == ["distill", "remove"]
    with pytest.raises(InputError, match="unknown stage 'render'"):
        stub_run(tiny_scene, out, model=model, until="render")


def test_a_lost_output_or_record_reruns_what_it_must(tiny_scene, tmp_path):
    out, model = tmp_path / "out", tiny_scene[1]
    stub_run(tiny_scene, out, model=model)
    (out / "associate" / "objects.json").unlink()
    # the lost stage runs again; its signature is unchanged, so what follows stays up to date
    assert stub_run(tiny_scene, out, model=model)[1] == ["associate"]
    # a record that cannot be read proves no folder the run's own: nothing is removed, the first named
    for bad in ("{not json", "[1, 2]"):
        (out / "run.json").write_text(bad)
        before = sorted(p.relative_to(out) for p in out.rglob("*"))
        with pytest.raises(InputError, match="segment/ was not written by this run"):
            stub_run(tiny_scene, out, model=model)
        assert sorted(p.relative_to(out) for p in out.rglob("*")) == before
    for stage in ("segment", "associate", "distill", "removed", "inpainted"):
        shutil.rmtree(out / stage)
    assert stub_run(tiny_scene, out, model=model)[1] == list(STAGES[1:])


def test_scene_content_decides_not_its_name(tiny_scene, tmp_path):
    root = shutil.copytree(tiny_scene[0], tmp_path / "scene")
    out, model = tmp_path / "out", tiny_scene[1]
    runner = lambda: StubRunner(load_scene(root), out, RunConfig(), log=[], ids=[1], model=model, progress=False)  # noqa: E731
    r = runner()
    r.run("distill")
    assert r.log == ["segment", "associate", "distill"]
    img = root / "images" / VIEW
    data = img.read_bytes()
    write_png(img, np.zeros((H, W, 3), np.uint8))  # another picture under the same name
    r = runner()
    r.run("distill")
    assert r.log == ["segment", "associate", "distill"]
    img.write_bytes(data)
    r = runner()
    r.run("distill")
    assert r.log == ["segment", "associate", "distill"]  # the record holds the last content only


def test_a_failed_stage_keeps_what_came_before(tiny_scene, tmp_path):
    out, model = tmp_path / "out", tiny_scene[1]
    with pytest.raises(InputError, match="distill failed"):
        stub_run(tiny_scene, out, model=model, fail="distill")
    assert set(json.loads((out / "run.json").read_text())) - {SECONDS_KEY, CREATED_KEY} == {"segment", "associate"}
    assert stub_run(tiny_scene, out, model=model)[1] == ["distill", "remove", "inpaint"]


def test_clicks_are_checked_before_any_stage(tiny_scene, tmp_path):
    root, model = tiny_scene
    scene = load_scene(root)
    for clicks, message in (
        ([Click("IMG_999.png", 3, 3)], "has no view"),
        ([Click("test_000.png", 3, 3)], "evaluation"),
        ([Click(VIEW, W, 0)], "outside the 32x24 image"),
    ):
        with pytest.raises(InputError, match=message):
            Runner(scene, tmp_path / "out", RunConfig(), model=model, clicks=clicks, progress=False)
    with pytest.raises(InputError, match="no object to remove"):
        Runner(scene, tmp_path / "out", RunConfig(), model=model, progress=False)
    assert not (tmp_path / "out").exists()


def test_clicks_default_to_scene_json(tiny_scene, tmp_path):
    root = shutil.copytree(tiny_scene[0], tmp_path / "scene")
    (root / "scene.json").write_text(json.dumps({"clicks": [{"object": 1, "view": VIEW, "x": 4, "y": 5}]}))
    r = Runner(load_scene(root), tmp_path / "out", RunConfig(), model=tiny_scene[1], progress=False)
    assert r.clicks == [Click(VIEW, 4, 5)]
    r = Runner(load_scene(root), tmp_path / "out", RunConfig(), model=tiny_scene[1], ids=[2], progress=False)
    assert r.clicks == [] and r.ids == [2]  # given ids replace scene.json's clicks
    (root / "scene.json").write_text(json.dumps({"clicks": [{"view": VIEW, "x": 400, "y": 5}]}))
    with pytest.raises(InputError, match="scene.json: click IMG_001.png:400,5 is outside"):
        Runner(load_scene(root), tmp_path / "out", RunConfig(), model=tiny_scene[1], progress=False)


def test_an_output_folder_that_is_not_a_run_is_refused(tiny_scene, tmp_path):
    out = tmp_path / "out"
    (out / "distill").mkdir(parents=True)  # named like a stage's folder, but not the run's: refused, kept
    (out / ".segment.123.abc.tmp").mkdir()  # a killed stage's temporary
    with pytest.raises(InputError, match="distill/ was not written by this run"):
        stub_run(tiny_scene, out, model=tiny_scene[1], until="segment")
    assert (out / "distill").is_dir()
    (out / "distill").rmdir()
    stub_run(tiny_scene, out, model=tiny_scene[1], until="segment")
    (out / "notes.txt").write_text("mine")
    with pytest.raises(InputError, match="holds 'notes.txt'"):
        stub_run(tiny_scene, out, model=tiny_scene[1])


# --- the real stages, through the CLI ------------------------------------------------------------------


def test_cli_run_with_the_real_stages(tiny_scene, tmp_path, capsys):
    """segment -> associate -> distill -> remove on the tiny_scene scene: a click on the background fails at
    the removal with the earlier stages kept; fixed, the run continues there; then nothing reruns
    (same bytes), and a distillation setting reruns distill and remove only."""
    root, model = tiny_scene
    out = tmp_path / "out"

    def argv(*sel: str, distill_iterations: int = 20) -> list[str]:
        return ["run", str(root), str(out), "--model", str(model), "--until", "remove", "--distill-iterations", str(distill_iterations),
                "--no-progress", "--threads", "2", *sel]  # fmt: skip

    assert main(argv("--click", f"{VIEW}:0,0")) == 2  # nothing rendered there
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "on empty space" in err[0]
    assert set(json.loads((out / "run.json").read_text())) - {SECONDS_KEY, CREATED_KEY} == {"segment", "associate", "distill"}
    assert not (out / "removed").exists()

    # 20 distillation steps on 32x24 photos: the field mixes the blobs, the removal takes most of
    # blob 2 with blob 1 and leaves part of both standing, and the run's check says so (exit 4, one
    # line naming the first failed check, the picture named)
    assert main(argv("--id", "1")) == 4
    cap = capsys.readouterr()
    out_lines = cap.out.splitlines()
    assert out_lines[0] == "remove: selecting and removing the object ..."  # each stage that runs is announced first
    assert out_lines[1:] == ["check: scoring the result after remove ..."]
    err = cap.err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("inpaint360gs run: check failed: after remove: over_removal: ")
    assert "--accept" in err[0] and str(out / "check.png") in err[0]
    report = json.loads((out / "check.json").read_text())
    assert report["stage"] == "remove" and report["failed"] == ["over_removal", "standing_removed"] and not report["accepted"]
    assert [c["name"] for c in report["checks"]][0] == "selection" and report["checks"][0]["passed"]  # the selection is blob 1
    rec = json.loads((out / "removed" / "removal.json").read_text())
    assert rec["objects"] == [1] and rec["removed_gaussians"] > 0  # the failed result is kept for inspection
    assert (out / "check.png").is_file()

    assert main(argv("--id", "1", "--accept")) == 0  # accepted: nothing reruns, the report says so
    lines = capsys.readouterr().out.splitlines()
    assert [" ".join(ln.split()) for ln in lines[:5]] == [
        "train given", "segment up to date", "associate up to date", "distill up to date", "remove up to date"]  # fmt: skip
    assert any(ln.startswith("check      FAILED (over_removal, standing_removed), accepted with --accept") for ln in lines)
    assert json.loads((out / "check.json").read_text())["accepted"]
    files = {p: p.read_bytes() for p in out.rglob("*") if p.is_file()}

    assert main(argv("--id", "1", "--accept")) == 0
    assert "ran" not in capsys.readouterr().out
    assert {p: p.read_bytes() for p in out.rglob("*") if p.is_file()} == files

    assert main(argv("--id", "1", "--accept", distill_iterations=21)) == 0
    lines = [ln for ln in capsys.readouterr().out.splitlines() if not ln.endswith(" ...")]
    assert [ln.split()[1] for ln in lines[1:5]] == ["up", "up", "ran", "ran"]
    assert json.loads((out / "distill" / "distill.json").read_text())["settings"]["iterations"] == 21
