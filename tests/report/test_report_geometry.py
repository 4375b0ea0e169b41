"""The fill's geometry at the test cameras (``inpaint360gs evaluate --model``,
:mod:`inpaint360gs.report.geometry`): the share of unseen-mask pixels a model leaves empty or puts
more than 5 % of the true depth off the true surface, against true depths made by hand."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch

from inpaint360gs.core.errors import InputError
from inpaint360gs.io.images import write_mask
from inpaint360gs.io.ply import write_ply
from inpaint360gs.io.scene import load_scene
from inpaint360gs.render.api import render
from inpaint360gs.report.geometry import NO_GT_DEPTH, depth_off
from inpaint360gs.views.unseen import normalised_depth


@pytest.fixture(scope="module")
def solid(make_blobs_scene):
    """The blobs scene, its model as a PLY, and per test view the model's own depth where it is
    solid (alpha >= 0.9), which is where the unseen masks are put."""
    root, model, _ = make_blobs_scene("geometry", n_views=4, n_test=2)
    ply = root.parent / "model.ply"
    write_ply(ply, model)
    scene = load_scene(root)
    depths = {}
    for v in scene.test_views:
        with torch.no_grad():
            out = render(model, v.camera)
        mask = out.alpha.numpy() >= 0.9
        assert mask.mean() > 0.3
        write_mask(root / "unseen_mask" / v.name, mask)
        depths[v.stem] = normalised_depth(out).double().numpy()
    return root, ply, model, depths


def _write_gt(root, depths, factor: float, scale: float | None = None):
    (root / "gt" / "depth").mkdir(parents=True, exist_ok=True)
    for stem, d in depths.items():
        np.save(root / "gt" / "depth" / f"{stem}.npy", (d * factor).astype(np.float32))
    frame = root / "gt" / "colmap_frame.json"
    frame.unlink(missing_ok=True)
    if scale is not None:
        frame.write_text(json.dumps({"true_from_colmap": {"scale": scale, "matrix_3x4": []}}))


@pytest.mark.parametrize("factor,scale,want", [(1.0, None, 0.0), (1.04, None, 0.0), (0.97, None, 0.0), (1.06, None, 100.0),
                                               (0.94, None, 100.0), (2.0, 2.0, 0.0), (2.0, None, 100.0)])  # fmt: skip
def test_depth_within_five_percent_of_the_true_surface_counts_as_on_it(solid, factor, scale, want):
    """True depth = the model's own depth times ``factor`` (in generator units, ``scale`` of them per
    scene unit): off by 4 % or 3 % is on the surface, by 6 % off it, everywhere in the mask."""
    root, ply, _, depths = solid
    _write_gt(root, depths, factor, scale)
    value, why = depth_off(ply, load_scene(root))
    assert why is None and value == pytest.approx(want, abs=1e-9)


def test_pixels_left_empty_count_as_off_and_missing_truth_is_a_reason(solid, tmp_path):
    root, ply, model, depths = solid
    _write_gt(root, depths, 1.0)
    gone = model.map(lambda t: t.clone())
    gone.means[:, 2] += 100.0  # every Gaussian far above the scene: nothing rendered in the views
    write_ply(tmp_path / "gone.ply", gone)
    assert depth_off(tmp_path / "gone.ply", load_scene(root)) == (100.0, None)
    # half of the model (x > 0 removed): the emptied pixels are off, the rest on the surface
    half = model.subset(model.means[:, 0] <= 0)
    write_ply(tmp_path / "half.ply", half)
    value, _ = depth_off(tmp_path / "half.ply", load_scene(root))
    assert 5.0 < value < 95.0
    np.save(root / "gt" / "depth" / f"{load_scene(root).test_views[0].stem}.npy", np.ones((3, 3), np.float32))
    with pytest.raises(InputError, match="true depth is 3x3"):
        depth_off(ply, load_scene(root))
    for f in (root / "gt" / "depth").iterdir():
        f.unlink()
    (root / "gt" / "depth").rmdir()
    assert depth_off(ply, load_scene(root)) == (None, NO_GT_DEPTH)
