"""The workflow's outputs never lie in a scene folder (docs/architecture.md, "Reliability"): an
``out_dir`` or ``results_dir`` that overlaps a scene folder (a generated one under ``data_dir``, a
given one, its COLMAP rebuild) is refused when the workflow is planned, naming the setting and the
folder, and nothing is written into the scene (dry runs: nothing is executed)."""

from __future__ import annotations

import pytest
from test_workflow import _dry_run

from cli_harness import tree


@pytest.fixture
def given(tmp_path):
    folder = tmp_path / "captures" / "myscene"
    (folder / "images").mkdir(parents=True)
    (folder / "scene.json").write_text("{}")
    return folder


CASES = {  # name -> (config overrides given the tmp folder and the given scene, the setting named)
    "out-dir-is-data-dir": (lambda t, g: ["scenes=[cone]", f"out_dir={t}/data"], "out_dir"),
    "results-dir-inside-generated-scene": (lambda t, g: ["scenes=[cone]", f"results_dir={t}/data/cone/results"], "results_dir"),
    "out-dir-inside-given-scene": (lambda t, g: [f"scenes=[{g}]", f"out_dir={g}/runs"], "out_dir"),
    "given-scene-is-its-run-folder": (lambda t, g: [f"scenes=[{g}]", f"out_dir={g.parent}"], "out_dir"),  # OUT/myscene is the scene
    "out-dir-inside-colmap-rebuild": (lambda t, g: ["scenes=[cone]", "poses=colmap", f"out_dir={t}/data_colmap/cone/o"], "out_dir"),
}


@pytest.mark.parametrize("name", list(CASES))
def test_outputs_overlapping_a_scene_folder_are_refused(name, tmp_path, given):
    make, setting = CASES[name]
    before = tree(given)
    p = _dry_run(tmp_path, "train_scenes=[]", *make(tmp_path, given))
    out = p.stdout + p.stderr
    assert p.returncode != 0, out[-2000:]
    assert f"config: {setting}" in out and "overlaps the scene folder" in out, out[-2000:]
    assert tree(given) == before
