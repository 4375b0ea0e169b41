"""``inpaint360gs run`` never leaves a stage folder that does not follow from the current settings
(docs/architecture.md, "Provenance chain"): a changed stage makes every later one stale, and a stale
folder is removed before the stages run, with ``--until`` too; a 3DGS folder the run trains into is
the trainer's to resume or replace, and one holding the given model is kept."""

from __future__ import annotations

import dataclasses
import json
import shutil

import pytest

from test_run import StubRunner, stub_run

from cli_harness import restore_threads, run_cli  # noqa: F401
from inpaint360gs.distill.config import DistillConfig
from inpaint360gs.gs.config import TrainConfig
from inpaint360gs.io.scene import load_scene
from inpaint360gs.core.errors import InputError
from inpaint360gs.pipeline.run import CREATED_KEY, STAGES, RunConfig
from reliability.chains import INPAINT

FOLDERS = {"train": "3dgs", "segment": "segment", "associate": "associate", "distill": "distill", "remove": "removed", "inpaint": "inpainted"}


def present(out) -> list[str]:
    return [s for s in STAGES if (out / FOLDERS[s]).exists()]


def recorded(out) -> list[str]:
    return [s for s in STAGES if s in json.loads((out / "run.json").read_text())]


def test_until_removes_the_stages_a_change_made_stale(tiny_scene, tmp_path):
    out, model = tmp_path / "out", tiny_scene[1]
    cfg = RunConfig(distill=DistillConfig(iterations=5))
    assert stub_run(tiny_scene, out, cfg, model=model)[1] == list(STAGES[1:])
    cfg = dataclasses.replace(cfg, distill=DistillConfig(iterations=6))
    assert stub_run(tiny_scene, out, cfg, model=model, until="remove")[1] == ["distill", "remove"]
    assert present(out) == recorded(out) == ["segment", "associate", "distill", "remove"]  # the old inpainting is gone
    assert stub_run(tiny_scene, out, cfg, model=model)[1] == ["inpaint"]
    cfg = dataclasses.replace(cfg, seed=3)  # from segmentation on
    assert stub_run(tiny_scene, out, cfg, model=model, until="segment")[1] == ["segment"]
    assert present(out) == recorded(out) == ["segment"]
    # an unchanged later stage beyond --until stays: it still follows from the settings
    assert stub_run(tiny_scene, out, cfg, model=model)[1] == ["associate", "distill", "remove", "inpaint"]
    assert stub_run(tiny_scene, out, cfg, model=model, until="associate")[1] == []
    assert present(out) == recorded(out) == list(STAGES[1:])


def test_a_folder_the_record_does_not_know_is_refused_not_removed(tiny_scene, tmp_path):
    """A stage folder that run.json's manifest does not list (the record was lost, or someone put it
    there) is not presented as current, and not removed either: clean-up removes only what the run
    created. The run stops before anything is removed, naming the folder; a stage killed half-way
    is in the manifest (written before the stage starts), so its folder is the run's own."""
    out, model = tmp_path / "out", tiny_scene[1]
    stub_run(tiny_scene, out, model=model)
    (out / "run.json").unlink()
    with pytest.raises(InputError, match="segment/ was not written by this run"):
        stub_run(tiny_scene, out, model=model, until="associate")
    assert present(out) == list(STAGES[1:])
    # stopped after the stage wrote its folder, before the record said so: the manifest lists it
    shutil.rmtree(out)

    class Stopped(StubRunner):
        def _distill(self):
            super()._distill()
            raise KeyboardInterrupt  # the record is not written after this

    with pytest.raises(KeyboardInterrupt):
        Stopped(load_scene(tiny_scene[0]), out, RunConfig(), log=[], ids=[1], model=model, progress=False).run()
    record = json.loads((out / "run.json").read_text())
    assert "distill" in record[CREATED_KEY] and "distill" not in record and (out / "distill").is_dir()
    assert stub_run(tiny_scene, out, model=model, until="associate")[1] == []
    assert present(out) == ["segment", "associate"]
    # a stage refused before it wrote anything leaves the record as it was
    before = (out / "run.json").read_text()
    with pytest.raises(InputError, match="on purpose"):
        stub_run(tiny_scene, out, model=model, fail="distill")
    assert (out / "run.json").read_text() == before


def test_the_3dgs_folder_is_the_trainers_or_holds_the_given_model(tiny_scene, tmp_path):
    out = tmp_path / "out"
    cfg = RunConfig(train=TrainConfig(iterations=10))
    stub_run(tiny_scene, out, cfg, until="segment")
    assert present(out) == ["train", "segment"]
    # a changed training setting: the trainer resumes or replaces its own folder (not removed first)
    r = StubRunner(load_scene(tiny_scene[0]), out, dataclasses.replace(cfg, train=TrainConfig(iterations=11)), log=[], ids=[1], progress=False)
    assert r.remove_stale(r.signatures()) == ["segment"]
    # the run's own model given back as --model: its folder is an input and stays
    own = out / "3dgs" / "point_cloud.ply"
    assert stub_run(tiny_scene, out, cfg, until="segment", model=own)[1] == ["segment"]
    assert (out / "3dgs").is_dir()
    # another given model: the trained folder no longer follows from the settings
    assert stub_run(tiny_scene, out, cfg, until="segment", model=tiny_scene[1])[1] == ["segment"]
    assert present(out) == ["segment"]


def test_the_cli_run_with_changed_distillation_and_until_remove(chains, tmp_path, capsys):
    """The case that once kept the old ``inpainted/`` and its hash in run.json."""
    ch = chains["cone"]
    base = ["run", str(ch.scene), str(tmp_path / "out"), "--model", str(ch.model), "--id", "1", *INPAINT, "--no-progress", "--threads", "2", "--accept"]
    code, _, err = run_cli("inpaint360gs", [*base, "--distill-iterations", "20"], capsys)
    assert code == 0, err
    first = json.loads((tmp_path / "out" / "run.json").read_text())
    code, stdout, err = run_cli("inpaint360gs", [*base, "--distill-iterations", "21", "--until", "remove"], capsys)
    assert code == 0, err
    assert not (tmp_path / "out" / "inpainted").exists()
    now = json.loads((tmp_path / "out" / "run.json").read_text())
    assert "inpaint" not in now and now["segment"] == first["segment"] and now["distill"] != first["distill"]
