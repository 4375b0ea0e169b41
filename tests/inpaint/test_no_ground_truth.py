"""A scene without object-free ground truth (photos with the object only, no ``test_`` views): the scene
loader, ``render --split test`` and the inpainting stage's outputs (renders/test/, grid.png) cope.
The dataset side (build, validate) and ``evaluate`` are tested in test_build_*.py, test_validate.py
and test_metrics_evaluate.py."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch

import scene_builder as sb
from cli_harness import run_cli
from inpaint360gs.core.layout import is_test_name
from inpaint360gs.inpaint.conditioned import InpaintedView
from inpaint360gs.inpaint.stage import GRID_COLUMNS, _spread, write_inpainting
from inpaint360gs.io.images import read_image
from inpaint360gs.io.ply import write_ply
from inpaint360gs.io.scene import load_scene
from inpaint360gs.render.api import render

W, H = 48, 36


@pytest.fixture(scope="module")
def blobs(tmp_path_factory):
    """(scene without test_ views, scene with 2, the blobs model, the model without blob 1)."""
    base = tmp_path_factory.mktemp("nogt")
    no_gt, model, labels = sb.blobs_scene(base / "no_gt", n_views=8, n_test=0, width=W, height=H, f=40.0)
    with_gt, _, _ = sb.blobs_scene(base / "with_gt", n_views=8, n_test=2, width=W, height=H, f=40.0)
    return no_gt, with_gt, model, model.subset(labels != 1)


def _views(model, n: int) -> list[InpaintedView]:
    """``n`` stand-in results of the 2D inpainting at cameras along an orbit (named virtual_*)."""
    out = []
    for c in sb.orbit_cameras(n, radius=2.5, height=1.2, width=W, h=H, f=40.0, prefix="virtual_", phase=0.1):
        with torch.no_grad():
            r = render(model, c, backend="torch")
        m = np.zeros((H, W), bool)
        m[10:20, 15:30] = True
        out.append(InpaintedView(c, r.color.numpy(), r.depth.numpy(), m, np.ones((H, W), bool), np.zeros((H, W), bool)))
    return out


def test_scene_loader_with_zero_test_views(blobs):
    no_gt, with_gt, _, _ = blobs
    scene = load_scene(no_gt)
    assert scene.test_views == [] and len(scene.train_views) == 7 and len(scene.holdout_views) == 1
    assert not scene.has_ground_truth and scene.extent > 0
    assert load_scene(with_gt).has_ground_truth


def test_spread_picks_evenly_spaced_views():
    assert _spread(3, 4) == [0, 1, 2]
    assert _spread(10, 4) == [0, 3, 6, 9]
    assert _spread(0, 4) == []


@pytest.mark.parametrize("with_test", [False, True])
def test_inpainting_outputs_without_test_views(blobs, tmp_path, with_test):
    no_gt, with_gt, model, final = blobs
    scene = load_scene(with_gt if with_test else no_gt)
    views = _views(final, 7)
    record = {"views": "virtual"}
    out = tmp_path / "inpainted"
    write_inpainting(final, model, record, views, scene, out, backend="torch")
    renders = sorted(p.name for p in (out / "renders" / "test").iterdir())
    grid = read_image(out / "grid.png")
    info = json.loads((out / "inpaint.json").read_text())
    assert (out / "point_cloud.ply").is_file() and (out / "trajectory.gif").is_file()
    if with_test:
        assert renders == ["test_000.png", "test_001.png"]
        assert grid.shape == (2 * H, 2 * W, 3) and info["grid"] == {"cameras": "test", "views": renders}
        return
    assert renders == []  # no ground truth: nothing rendered at test_ cameras, the folder is there
    picked = _spread(len(views), GRID_COLUMNS)
    assert grid.shape == (2 * H, len(picked) * W, 3)
    assert info["grid"] == {"cameras": "virtual", "views": [views[i].camera.name for i in picked]}
    # top row: the scene before (blob 1 present), bottom row: after; they differ where blob 1 was
    assert np.abs(grid[:H].astype(int) - grid[H:].astype(int)).max() > 50


def test_render_test_split_of_a_scene_without_test_views_is_one_line(blobs, tmp_path, capsys):
    no_gt, _, model, _ = blobs
    ply = tmp_path / "m.ply"
    write_ply(ply, model)
    code, out, err = run_cli("inpaint360gs", ["render", str(ply), str(no_gt), str(tmp_path / "r"), "--split", "test", "--no-progress", "--backend", "torch"], capsys)
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert "no test_ views" in err and "--split train" in err and "Traceback" not in err
    assert not (tmp_path / "r").exists()
    code, out, err = run_cli("inpaint360gs", ["render", str(ply), str(no_gt), str(tmp_path / "r"), "--split", "train", "--no-progress", "--backend", "torch"], capsys)
    assert code == 0, err
    assert not any(is_test_name(p.name) for p in (tmp_path / "r" / "color").iterdir())
