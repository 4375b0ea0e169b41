"""``inpaint360gs capture-scores`` on a removal of the blobs scene without ground truth: the scores
follow from the renders (nothing outside the footprint changes, nothing stands in the column), and a
removal of another scene is refused by its provenance."""

from __future__ import annotations

import json

import pytest

import scene_builder as sb
from cli_harness import run_cli
from inpaint360gs.io.ply import write_ply
from inpaint360gs.io.scene import load_scene
from inpaint360gs.remove.stage import remove_stage
from object_fields import labelled_field, write_field

IDS = [0, 3, 7]


@pytest.fixture(scope="module")
def removal(tmp_path_factory):
    base = tmp_path_factory.mktemp("capture")
    root, model, labels = sb.blobs_scene(base / "scene", n_views=8, n_test=0)
    scene = load_scene(root)
    write_ply(base / "3dgs" / "point_cloud.ply", model)
    field = labelled_field(model, labels, IDS)
    write_field(base / "distill", field, scene)
    remove_stage(scene, field, base / "removed", ids=[3])
    other, _, _ = sb.blobs_scene(base / "other", n_views=9, n_test=0)
    return base, root, other


def test_scores_of_a_clean_removal(removal, capsys):
    base, root, _ = removal
    argv = [str(root), str(base / "3dgs" / "point_cloud.ply"), str(base / "distill"), str(base / "removed"), str(base / "scores.json")]
    code, out, err = run_cli("inpaint360gs", ["capture-scores", *argv], capsys)
    assert code == 0, err
    s = json.loads((base / "scores.json").read_text())
    for split in ("train", "held-out"):
        row = s["psnr_outside"][split]
        assert row["removed"] == pytest.approx(row["3dgs"], abs=0.01)  # outside the grown footprint the renders agree
        assert row["3dgs"] > 40  # the photos are the model's own renders
    assert s["standing"]["removed"]["share"] == 0.0 and "inpainted" not in s["standing"]
    assert "Standing in the footprint column" in out


def test_a_result_that_leaves_half_the_object_fails_the_beside_check(removal, tmp_path):
    """The removal of one half of blob 3 (the field labels the other half background) leaves that
    half just outside the removed half's footprint. Taken as the run's final scene (an inpainting
    that changed nothing), the run check's ``beside_inpainted`` fails on it and passes on the
    removal of the whole blob; after ``remove`` the score is reported, not judged."""
    from inpaint360gs.evaluate.capture import CaptureRun, score_capture
    from inpaint360gs.evaluate.limits import CheckLimits
    from inpaint360gs.io.ply import read_ply
    from inpaint360gs.pipeline.check import score_checks

    base, root, _ = removal
    scene = load_scene(root)
    model = read_ply(base / "3dgs" / "point_cloud.ply")
    labels = sb.blobs_model()[1]  # the fixture's model's labels (blob 3 is label 1)
    half = labels.clone()
    blob = labels == 1
    x = model.means[:, 0]
    half[blob & (x > x[blob].median())] = 0
    write_field(tmp_path / "distill", labelled_field(model, half, IDS), scene)
    remove_stage(scene, labelled_field(model, half, IDS), tmp_path / "removed", ids=[3])
    checks = {}
    for name, distill, removed in (("whole", base / "distill", base / "removed"), ("half", tmp_path / "distill", tmp_path / "removed")):
        scores, _ = score_capture(scene, CaptureRun(base / "3dgs" / "point_cloud.ply", distill, removed, removed))
        checks[name] = {c.name: c for stage in ("remove", "inpaint") for c in score_checks(scores, CheckLimits(), stage)}
    assert checks["whole"]["beside_inpainted"].passed and checks["whole"]["beside_inpainted"].value < 0.005
    half_left = checks["half"]["beside_inpainted"]
    assert not half_left.passed and half_left.value > 0.5  # the half left is about as large as the footprint
    assert checks["half"]["beside_removed"].passed and checks["half"]["beside_removed"].value == half_left.value  # reported only


def test_an_object_drawn_back_into_the_fill_fails_the_in_fill_check(removal):
    """Taken as the run's final scene, the 3DGS itself (a fill that draws the object back) shows the
    blob's colours over most of its footprint; the clean removal shows none. With a limit the check
    fails the first and passes the second; without one (the default) it is reported, not judged."""
    from inpaint360gs.evaluate.capture import CaptureRun, score_capture
    from inpaint360gs.evaluate.limits import CheckLimits
    from inpaint360gs.pipeline.check import score_checks

    base, root, _ = removal
    scene = load_scene(root)
    checks = {}
    for name, final in (("clean", base / "removed"), ("object", base / "3dgs")):
        scores, _ = score_capture(scene, CaptureRun(base / "3dgs" / "point_cloud.ply", base / "distill", base / "removed", final))
        checks[name] = {lim: {c.name: c for c in score_checks(scores, CheckLimits(in_fill=lim), "inpaint")} for lim in (None, 0.02)}
    clean, drawn = checks["clean"][0.02]["in_fill_inpainted"], checks["object"][0.02]["in_fill_inpainted"]
    assert clean.passed and clean.value < 0.005, clean
    assert not drawn.passed and drawn.value > 0.5, drawn
    reported = checks["object"][None]["in_fill_inpainted"]
    assert reported.passed and reported.value == drawn.value and reported.limit == "reported"


def test_another_scenes_removal_is_refused(removal, capsys):
    base, _, other = removal
    argv = [str(other), str(base / "3dgs" / "point_cloud.ply"), str(base / "distill"), str(base / "removed"), str(base / "x.json")]
    code, _, err = run_cli("inpaint360gs", ["capture-scores", *argv], capsys)
    assert code == 2 and len(err.strip().splitlines()) == 1 and "another scene" in err
    assert not (base / "x.json").exists()


def _scores(psnr: dict, standing: tuple[float, float], lap: float, lum: float) -> dict:
    return {"psnr_outside": psnr, "standing": {"removed": {"share": standing[0], "count": 1}, "inpainted": {"share": standing[1], "count": 1}},
            "texture": {"inpainted": {"laplacian": lap, "luminance": lum, "ring_laplacian": 0.1, "views": 3}}}  # fmt: skip


def test_several_runs_are_judged_by_their_worst():
    from inpaint360gs.evaluate.capture import format_worst_case, worst_case
    from inpaint360gs.evaluate.limits import CheckLimits

    runs = [
        _scores({"train": {"3dgs": 26.0, "removed": 25.95, "inpainted": 25.9}, "held-out": {"3dgs": 24.0, "removed": 24.0, "inpainted": 24.0}}, (0.0, 0.01), 0.9, 1.02),
        _scores({"train": {"3dgs": 26.0, "removed": 25.3, "inpainted": 25.2}, "held-out": {"3dgs": 24.0, "removed": 23.9, "inpainted": 23.9}}, (0.079, 0.003), 1.5, 0.88),
        _scores({"train": {"3dgs": 26.0, "removed": 26.0, "inpainted": 26.1}, "held-out": {"3dgs": 24.0, "removed": 24.1, "inpainted": 24.1}}, (0.0, 0.0), 0.5, 1.1),
    ]  # fmt: skip
    s = worst_case(runs)
    d = s["drop_removed_train"]
    assert d["values"] == pytest.approx([0.05, 0.7, 0.0]) and d["worst"] == pytest.approx(0.7) and d["median"] == pytest.approx(0.05)
    assert not d["passed"] and s["drop_removed_held-out"]["passed"]
    assert s["drop_inpainted_train"]["worst"] == pytest.approx(0.1) and s["drop_inpainted_train"]["passed"]
    assert s["standing_removed"]["worst"] == pytest.approx(0.079) and not s["standing_removed"]["passed"]
    assert s["standing_inpainted"]["worst"] == pytest.approx(0.01) and s["standing_inpainted"]["passed"]
    assert s["fill_laplacian"]["worst"] == pytest.approx(0.5) and not s["fill_laplacian"]["passed"]  # |log 0.5| > |log 1.5|
    assert s["fill_luminance"]["worst"] == pytest.approx(0.88) and s["fill_luminance"]["passed"]
    assert worst_case(runs, CheckLimits(laplacian=(0.4, 1.6)))["fill_laplacian"]["passed"]
    text = format_worst_case(s, 3)
    assert "Over 3 runs" in text and text.count("FAILED") == 3
    # a score no run has is not scored, not a pass
    none = worst_case([{"psnr_outside": {}, "standing": {}, "texture": {}}])
    assert all(r["passed"] is None and r["worst"] is None for r in none.values())
