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


def test_another_scenes_removal_is_refused(removal, capsys):
    base, _, other = removal
    argv = [str(other), str(base / "3dgs" / "point_cloud.ply"), str(base / "distill"), str(base / "removed"), str(base / "x.json")]
    code, _, err = run_cli("inpaint360gs", ["capture-scores", *argv], capsys)
    assert code == 2 and len(err.strip().splitlines()) == 1 and "another scene" in err
    assert not (base / "x.json").exists()
