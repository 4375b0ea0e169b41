"""The ground-truth removal scores (:func:`inpaint360gs.evaluate.removal.removal_scores`) against the
generator's own truth, on a generated scene posed by the generator and on one posed by pycolmap (the
realistic family's default: cameras, points and models in the reconstruction's frame and units).

The model is the truth itself: one small Gaussian on the true surface behind each pixel of every
third training view (the generator's depth and colours, through the true cameras, then into the
scene's frame by ``gt/colmap_frame.json``'s similarity), labelled by the generator's instance ids.
Removing exactly the target's Gaussians must leave no residual and no collateral and an AMCR near
the true footprint share; removing only the target's top half must leave a large residual (which a
depth in the wrong units would hide: nothing would lie at the object's true depth)."""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch
from object_fields import labelled_field

from dataset_tools.synth.generate import generate_scene
from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.evaluate.removal import removal_scores, scale_to_truth, target_ids, true_poses
from inpaint360gs.io.images import read_image, read_mask, to_float
from inpaint360gs.io.scene import load_scene
from inpaint360gs.remove.config import RemovalConfig
from inpaint360gs.remove.stage import remove_stage

CLASSES = [0, 3, 7]  # background, the target's top half, its bottom half
NO_EXTRAS = RemovalConfig(hull=False, protect_support=None, support_column=None, footprint_margin=None)


def truth_model(root, scene, stride: int = 1) -> tuple[Gaussians, torch.Tensor]:
    """Gaussians on the true surfaces every third training view sees (one per ``stride`` x ``stride``
    pixels), in the scene's frame, and their classes (CLASSES)."""
    cams = json.loads((root / "gt" / "cameras.json").read_text())
    poses, targets = true_poses(root), target_ids(root)
    frame = root / "gt" / "colmap_frame.json"
    M = np.asarray(json.loads(frame.read_text())["true_from_colmap"]["matrix_3x4"]) if frame.is_file() else np.hstack([np.eye(3), np.zeros((3, 1))])
    s = float(np.linalg.norm(M[:, 0]))
    pts, cols, ids, size = [], [], [], []
    for v in scene.train_views[::3]:
        R, t = poses[v.name]
        d = np.load(root / "gt" / "depth" / f"{v.stem}.npy").astype(np.float64)[::stride, ::stride]
        ii, jj = np.mgrid[0 : d.shape[0], 0 : d.shape[1]] * stride
        x = np.stack([(jj + 0.5 - cams["cx"]) / cams["fx"] * d, (ii + 0.5 - cams["cy"]) / cams["fy"] * d, d], -1).reshape(-1, 3)
        world = (x - t) @ R  # R^T (x_cam - t)
        pts.append((world - M[:, 3]) @ M[:, :3] / s**2)  # into the scene's frame: (sR)^-1 (x - t)
        cols.append(to_float(read_image(root / "images" / v.name))[::stride, ::stride].reshape(-1, 3).numpy())
        ids.append(read_mask(root / "gt" / "instance" / f"{v.stem}.png")[::stride, ::stride].ravel())
        size.append(np.full(d.size, 0.5 * stride) * d.ravel() / cams["fx"] / s)
    P = np.concatenate(pts)
    target = np.isin(np.concatenate(ids), targets)
    height = P @ (M[:, :3].T @ np.array([0.0, 0.0, 1.0])) / s  # true z (up) of each point, up to an offset
    top = target & (height > np.median(height[target]))
    classes = torch.from_numpy(np.where(top, 1, np.where(target, 2, 0)))
    model = Gaussians.from_points(torch.tensor(P, dtype=torch.float32), torch.tensor(np.concatenate(cols), dtype=torch.float32), sh_degree=0,
                                  init_opacity=0.95, scales=torch.tensor(np.concatenate(size), dtype=torch.float32))
    return model, classes


@pytest.mark.slow
@pytest.mark.parametrize("name, size, posed_by", [("cube", (96, 72), "generator"), ("duck-dev2", (256, 192), "pycolmap")])
def test_scores_against_the_generators_truth(tmp_path, name, size, posed_by):
    root = generate_scene(name, tmp_path / "data", reduced=True, width=size[0], height=size[1])
    assert (root / "gt" / "colmap_frame.json").is_file() == (posed_by == "pycolmap")
    scene = load_scene(root, load_masks=False)
    model, classes = truth_model(root, scene)
    field = labelled_field(model, classes, CLASSES)
    if posed_by == "pycolmap":  # the reconstruction's own units: the scale comes back from the camera centres
        frame = json.loads((root / "gt" / "colmap_frame.json").read_text())["true_from_colmap"]
        assert scale_to_truth(scene, true_poses(root)) == pytest.approx(frame["scale"], rel=1e-3) and abs(np.log(frame["scale"])) > 0.1
    remove_stage(scene, field, tmp_path / "exact", ids=[3, 7], cfg=NO_EXTRAS)
    exact = removal_scores(tmp_path / "exact", scene)["scores"]
    assert exact["residual"] <= 1.0 and exact["collateral"] <= 1.0, exact
    assert 0.8 < exact["amcr_ratio"] < 1.3 and exact["gt_footprint_share"] > 1.0, exact
    remove_stage(scene, field, tmp_path / "half", ids=[3], cfg=NO_EXTRAS)
    half = removal_scores(tmp_path / "half", scene)
    assert half["scores"]["residual"] > 20.0 and "residual" in [a["limit"] for a in half["above_limits"]], half["scores"]
