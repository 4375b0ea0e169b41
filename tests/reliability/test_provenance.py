"""The provenance chain (docs/architecture.md, "Provenance chain"): every stage output records what it
was made from, and every stage refuses, before any work and with one line naming both, an input made
from another scene or one that does not belong with its other inputs; ``table record`` refuses an
evaluation of another scene or of another model. Inputs: the ``cone`` and ``toys`` chains of
``conftest.py`` (same cameras and image size, other objects), which the harness hashes before and after
every case."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
import torch

from cli_harness import Case, check, ids_unique, restore_threads, run_cli  # noqa: F401
from reliability.chains import DISTILL, INPAINT, QUIET, stage_commands
from inpaint360gs.core.files import sha256_file
from inpaint360gs.core.layout import STAGE_RECORDS
from inpaint360gs.io import provenance

T = "inpaint360gs"
LABELS = ["--label", "method=full", "--label", "segmenter=geometric"]


def chains(c):
    c.fx("chains_root")  # watched: no case may change either chain
    got = c.request.getfixturevalue("chains")
    return got["cone"], got["toys"]


def mixed(build, named):
    """A case: ``build(cone, toys, c)`` gives the command line; its error must contain every one of
    ``named(cone, toys, c)`` (the mismatched inputs)."""

    def make(c):
        cone, toys = chains(c)
        return build(cone, toys, c), tuple(str(x) for x in named(cone, toys, c))

    return make


def stray_model(c, ch) -> Path:
    """The chain's model with one value changed, of unknown origin (no stage recorded it)."""
    from inpaint360gs.io.ply import read_ply, write_ply

    g = read_ply(ch.model)
    g.means[0, 0] += 1e-3
    write_ply(c.tmp / "stray" / "point_cloud.ply", g)
    return c.tmp / "stray" / "point_cloud.ply"


def other_distillation(c, ch) -> Path:
    """A second distillation of the same scene (another seed): a removal made from the first one does not belong to it."""
    from inpaint360gs.cli import main

    out = c.tmp / "distill_seed1"
    assert main(["distill", str(ch.scene), str(ch.model), str(ch.associate), str(out), *DISTILL, "--seed", "1", "--no-progress", *QUIET]) == 0
    return out


def out(c) -> str:
    return c.path("out")


RJ, DJ, SJ, OJ = STAGE_RECORDS["remove"], STAGE_RECORDS["distill"], STAGE_RECORDS["segment"], STAGE_RECORDS["associate"]

CASES = [
    # a model made from another scene (its folder's record says so), wherever a model is read
    Case("segment-model-of-another-scene", T, mixed(lambda a, b, c: ["segment", str(a.scene), str(b.model), out(c), "--no-progress"],
                                                    lambda a, b, c: (b.model, "made from scene toys", a.scene))),
    Case("associate-model-of-another-scene", T, mixed(lambda a, b, c: ["associate", str(a.scene), str(b.model), str(a.segment), out(c)],
                                                      lambda a, b, c: (b.model, "scene toys", a.scene))),
    Case("distill-model-of-another-scene", T, mixed(lambda a, b, c: ["distill", str(a.scene), str(b.model), str(a.associate), out(c), *DISTILL],
                                                    lambda a, b, c: (b.model, "scene toys", a.scene))),
    Case("render-model-of-another-scene", T, mixed(lambda a, b, c: ["render", str(b.model), str(a.scene), out(c), "--no-progress"],
                                                   lambda a, b, c: (b.model, "scene toys", a.scene))),
    Case("render-removed-model-of-another-scene", T, mixed(lambda a, b, c: ["render", str(b.removed / "point_cloud.ply"), str(a.scene), out(c)],
                                                           lambda a, b, c: (b.removed / "point_cloud.ply", b.removed / RJ, a.scene))),
    Case("render-distilled-model-of-another-scene", T, mixed(lambda a, b, c: ["render", str(b.distill / "point_cloud.ply"), str(a.scene), out(c)],
                                                             lambda a, b, c: (b.distill / "point_cloud.ply", a.scene))),
    Case("render-inpainted-model-of-another-scene", T, mixed(lambda a, b, c: ["render", str(b.inpainted / "point_cloud.ply"), str(a.scene), out(c), "--split", "all"],
                                                             lambda a, b, c: (b.inpainted / "point_cloud.ply", a.scene))),
    Case("run-model-of-another-scene", T, mixed(lambda a, b, c: ["run", str(a.scene), out(c), "--model", str(b.model), "--id", "1", "--until", "segment", "--no-progress"],
                                                lambda a, b, c: (b.model, "scene toys"))),
    # a stage output made from another scene
    Case("associate-segments-of-another-scene", T, mixed(lambda a, b, c: ["associate", str(a.scene), str(a.model), str(b.segment), out(c)],
                                                         lambda a, b, c: (b.segment / SJ, a.scene))),
    Case("distill-association-of-another-scene", T, mixed(lambda a, b, c: ["distill", str(a.scene), str(a.model), str(b.associate), out(c), *DISTILL],
                                                          lambda a, b, c: (b.associate / OJ, a.scene))),
    Case("remove-distillation-of-another-scene", T, mixed(lambda a, b, c: ["remove", str(a.scene), str(b.distill), out(c), "--id", "1"],
                                                          lambda a, b, c: (b.distill / DJ, a.scene))),
    Case("inpaint-distillation-of-another-scene", T, mixed(lambda a, b, c: ["inpaint", str(a.scene), str(b.distill), str(a.removed), out(c), *INPAINT],
                                                           lambda a, b, c: (b.distill / DJ, a.scene))),
    Case("inpaint-scene-of-another-run", T, mixed(lambda a, b, c: ["inpaint", str(b.scene), str(a.distill), str(a.removed), out(c), *INPAINT],
                                                  lambda a, b, c: (a.distill / DJ, b.scene))),
    Case("inpaint-removal-of-another-scene", T, mixed(lambda a, b, c: ["inpaint", str(a.scene), str(a.distill), str(b.removed), out(c), *INPAINT],
                                                      lambda a, b, c: (b.removed / RJ, a.scene))),
    Case("evaluate-renders-of-another-scene", T, mixed(lambda a, b, c: ["evaluate", str(b.removed_renders), str(a.scene), c.path("m.json"), "--nets", "vgg"],
                                                       lambda a, b, c: (b.removed_renders / "render.json", a.scene))),
    Case("evaluate-color-renders-of-another-scene", T, mixed(lambda a, b, c: ["evaluate", str(b.removed_renders / "color"), str(a.scene), c.path("m.json"), "--nets", "vgg"],
                                                             lambda a, b, c: (b.removed_renders / "render.json", a.scene))),
    Case("evaluate-inpainted-renders-of-another-scene", T, mixed(lambda a, b, c: ["evaluate", str(b.inpainted / "renders" / "test"), str(a.scene), c.path("m.json"), "--nets", "vgg"],
                                                                 lambda a, b, c: (b.inpainted / "inpaint.json", a.scene))),
    # inputs of the same scene that do not belong together
    Case("associate-segments-made-with-another-model", T, mixed(lambda a, b, c: ["associate", str(a.scene), str(stray_model(c, a)), str(a.segment), out(c)],
                                                                lambda a, b, c: (a.segment / SJ, c.tmp / "stray" / "point_cloud.ply", "another model"))),
    Case("distill-association-made-with-another-model", T, mixed(lambda a, b, c: ["distill", str(a.scene), str(stray_model(c, a)), str(a.associate), out(c), *DISTILL],
                                                                 lambda a, b, c: (a.associate / OJ, c.tmp / "stray" / "point_cloud.ply", "another model"))),
    Case("inpaint-removal-of-another-distillation", T, mixed(lambda a, b, c: ["inpaint", str(a.scene), str(other_distillation(c, a)), str(a.removed), out(c), *INPAINT],
                                                             lambda a, b, c: (a.removed / RJ, c.tmp / "distill_seed1", "another distillation"))),
    # the same scene at another --resize than its per-view outputs
    Case("associate-segments-at-another-resize", T, mixed(lambda a, b, c: ["associate", str(a.scene), str(a.model), str(a.segment), out(c), "--resize", "2"],
                                                          lambda a, b, c: (a.segment / SJ, "--resize 1", "--resize 2"))),
    Case("distill-association-at-another-resize", T, mixed(lambda a, b, c: ["distill", str(a.scene), str(a.model), str(a.associate), out(c), *DISTILL, "--resize", "2"],
                                                           lambda a, b, c: (a.associate / OJ, "--resize 1"))),
    Case("remove-distillation-at-another-resize", T, mixed(lambda a, b, c: ["remove", str(a.scene), str(a.distill), out(c), "--id", "1", "--resize", "2"],
                                                           lambda a, b, c: (a.distill / DJ, "--resize 1"))),
    Case("inpaint-removal-at-another-resize", T, mixed(lambda a, b, c: ["inpaint", str(a.scene), str(a.distill), str(a.removed), out(c), *INPAINT, "--resize", "2"],
                                                       lambda a, b, c: ("--resize 1",))),
    Case("evaluate-renders-at-another-resize", T, mixed(lambda a, b, c: ["evaluate", str(a.removed_renders), str(a.scene), c.path("m.json"), "--nets", "vgg", "--resize", "2"],
                                                        lambda a, b, c: (a.removed_renders / "render.json", "--resize 1"))),
    # a record of one scene or model with the evaluation of another
    Case("record-evaluation-of-another-scene", T, mixed(lambda a, b, c: ["table", "record", c.path("r.json"), "--label", "scene=toys", *LABELS, "--eval", str(a.eval)],
                                                        lambda a, b, c: (a.eval, "scene 'cone'", "scene=toys"))),
    Case("record-model-of-another-scene", T, mixed(lambda a, b, c: ["table", "record", c.path("r.json"), "--label", "scene=cone", *LABELS, "--eval", str(a.eval),
                                                                    "--model", str(b.inpainted / "point_cloud.ply")],
                                                   lambda a, b, c: (a.eval, b.inpainted / "point_cloud.ply"))),
    Case("record-model-of-another-method", T, mixed(lambda a, b, c: ["table", "record", c.path("r.json"), "--label", "scene=cone", *LABELS, "--eval", str(a.eval),
                                                                     "--model", str(a.removed / "point_cloud.ply")],
                                                    lambda a, b, c: (a.eval, a.removed / "point_cloud.ply", "another model"))),
]  # fmt: skip


@pytest.mark.parametrize("case", ids_unique(CASES))
def test_mismatched_input_is_refused(case, tmp_path, request, capsys):
    check(case, tmp_path, request, capsys)


# --- what the records hold, and that matching inputs go through -------------------------------------


def test_every_stage_output_records_its_chain(chains):
    """Each record names the scene's content and the identities of what it was made from: the links
    of the chain are the upstream records' identities and the models' sha256."""
    ch = chains["cone"]
    rec = {s: provenance.of_stage(getattr(ch, d), s) for s, d in
           (("segment", "segment"), ("associate", "associate"), ("distill", "distill"), ("remove", "removed"), ("inpaint", "inpainted"), ("render", "removed_renders"))}
    train = provenance.of_file(ch.model)
    ev = provenance.read(ch.eval, "evaluate")
    scene = {r.scene["content_sha256"] for r in [*rec.values(), train, ev]}
    assert len(scene) == 1 and all(r.scene["name"] == "cone" and r.scene["resize"] == 1 for r in [*rec.values(), ev])
    model = sha256_file(ch.model)
    assert train.outputs == {"point_cloud.ply": model}
    assert rec["segment"].inputs == {"model": model}
    assert rec["associate"].inputs == {"model": model, "segment": rec["segment"].identity}
    assert rec["distill"].inputs == {"model": model, "associate": rec["associate"].identity}
    assert rec["remove"].inputs == {"distill": rec["distill"].identity}
    assert rec["inpaint"].inputs == {"distill": rec["distill"].identity, "removal": rec["remove"].identity}
    assert rec["render"].inputs == {"model": sha256_file(ch.removed / "point_cloud.ply")}
    for r, folder in ((rec["distill"], ch.distill), (rec["remove"], ch.removed), (rec["inpaint"], ch.inpainted)):
        assert r.outputs == {"point_cloud.ply": sha256_file(folder / "point_cloud.ply")}
    assert ev.inputs == {"renders": rec["inpaint"].identity, "model": sha256_file(ch.inpainted / "point_cloud.ply")}
    assert len({r.identity for r in rec.values()}) == len(rec)
    assert json.loads(ch.record.read_text())["labels"]["scene"] == "cone"


def test_a_rerun_reproduces_the_identity_and_the_bytes(chains, tmp_path, capsys):
    """The identity depends on what determines the output only: the same distillation made again into
    another folder has the same identity and the same PLY."""
    ch = chains["cone"]
    argv = stage_commands(ch, tmp_path)["distill"]
    argv[3] = str(ch.associate)
    code, _, err = run_cli(T, argv, capsys)
    assert code == 0, err
    again, first = provenance.of_stage(tmp_path / "distill", "distill"), provenance.of_stage(ch.distill, "distill")
    assert again.identity == first.identity
    assert (tmp_path / "distill" / "point_cloud.ply").read_bytes() == (ch.distill / "point_cloud.ply").read_bytes()


def test_a_copy_of_the_scene_and_its_outputs_is_accepted(chains, tmp_path, capsys):
    """Identity is by content, not by path: the scene and the removal copied elsewhere still inpaint."""
    ch = chains["cone"]
    scene = shutil.copytree(ch.scene, tmp_path / "elsewhere" / "cone")
    removed = shutil.copytree(ch.removed, tmp_path / "removed")
    code, _, err = run_cli(T, ["inpaint", str(scene), str(ch.distill), str(removed), str(tmp_path / "out"), *INPAINT, "--no-progress", *QUIET], capsys)
    assert code == 0, err


def test_a_model_changed_since_its_stage_wrote_it_has_no_record(chains, tmp_path):
    """``outputs`` holds the sha256 the stage wrote: a file replaced since is of unknown origin."""
    from inpaint360gs.io.ply import read_ply, write_ply

    ch = chains["toys"]
    run = shutil.copytree(ch.run / "3dgs", tmp_path / "3dgs")
    assert provenance.of_file(run / "point_cloud.ply").scene["name"] == "toys"
    g = read_ply(run / "point_cloud.ply")
    write_ply(run / "point_cloud.ply", g.map(lambda t: t + 0 * torch.ones_like(t)).subset(torch.arange(len(g)) > 0))
    assert provenance.of_file(run / "point_cloud.ply") is None


def test_record_accepts_its_own_evaluation_and_model(chains, tmp_path, capsys):
    ch = chains["toys"]
    argv = ["table", "record", str(tmp_path / "r.json"), "--label", "scene=toys", *LABELS, "--eval", str(ch.eval),
            "--model", str(ch.inpainted / "point_cloud.ply")]  # fmt: skip
    code, _, err = run_cli(T, argv, capsys)
    assert code == 0, err
