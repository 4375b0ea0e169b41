"""AMCR (paper supp. Eq. 1) on a run's own removal masks at the test cameras (``inpaint360gs evaluate
--removal``, :mod:`inpaint360gs.report.amcr`): the model the removal started from is put back
together exactly, its footprint at the training cameras is the removal stage's own masks, at the
test cameras the pixels the removed object gives half its colour, and AMCR their mean coverage."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
import torch
from object_fields import labelled_field

from inpaint360gs.cli import main
from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.io.images import read_mask
from inpaint360gs.io.scene import load_scene
from inpaint360gs.remove.config import RemovalConfig
from inpaint360gs.remove.stage import remove_stage
from inpaint360gs.render.api import render
from inpaint360gs.report.amcr import original_model, removal_amcr, removal_masks, masks_in_test_views

IDS = [0, 3, 7]  # class -> object id


@pytest.fixture(scope="module")
def removed(make_blobs_scene):
    """Blob 1 (id 3) removed by probability alone (no hull, footprint or support steps), so that
    exactly its Gaussians go; returns (scene, model, labels, removal folder)."""
    root, model, labels = make_blobs_scene("amcr", n_views=8, n_test=3)
    scene = load_scene(root)
    field = labelled_field(model, labels, IDS)
    out = root.parent / "removed"
    cfg = RemovalConfig(hull=False, protect_support=None, support_column=None, footprint_margin=None)
    remove_stage(scene, field, out, ids=[3], cfg=cfg)
    return scene, field.gaussians, labels, out


@torch.no_grad()
def share_of(model: Gaussians, flags: torch.Tensor, camera) -> np.ndarray:
    """Per pixel, the share of its colour the flagged Gaussians give (Eq. 1 weights)."""
    g = Gaussians(**{**model.tensors(), "features": flags.float()[:, None]})
    return render(g, camera, with_features=True).features[..., 0].numpy()


def test_the_original_model_is_put_back_exactly(removed):
    scene, model, labels, out = removed
    got, mask = original_model(out)
    assert torch.equal(mask, labels == 1)
    for k, t in model.tensors().items():
        assert torch.equal(got.tensors()[k], t), k


def test_masks_are_the_removals_own_at_training_views_and_its_footprint_at_test_views(removed):
    scene, model, labels, out = removed
    # at the training cameras: the masks the removal stage wrote, pixel for pixel
    masks = removal_masks(out, scene.train_views)
    for v in scene.train_views:
        assert np.array_equal(masks[v.name], read_mask(out / "masks" / f"{v.stem}.png") > 0), v.name
    # at the test cameras: where blob 1 gives at least half of the colour
    test = masks_in_test_views(out, scene)
    assert list(test) == [v.name for v in scene.test_views]
    shares = []
    for v in scene.test_views:
        want = share_of(model, labels == 1, v.camera) >= 0.5
        assert np.array_equal(test[v.name], want) and 0 < want.mean() < 0.5
        shares.append(100.0 * want.mean())
    assert removal_amcr(out, scene) == pytest.approx(np.mean(shares), abs=1e-12)


def test_evaluate_with_removal_records_amcr_apart_from_the_unseen_share(removed, tmp_path, capsys):
    scene, model, labels, out = removed
    renders = tmp_path / "renders"
    renders.mkdir()
    for v in scene.test_views:  # the object-free images themselves as renders
        shutil.copy(scene.root / "images" / v.name, renders / v.name)
    code = main(["evaluate", str(renders), str(scene.root), str(tmp_path / "e.json"), "--removal", str(out), "--nets", "alex"])
    std = capsys.readouterr()
    assert code == 0, std.err
    res = json.loads((tmp_path / "e.json").read_text())
    assert res["scene_metrics"]["amcr"] == pytest.approx(removal_amcr(out, scene)) and "AMCR" in std.out
    assert res["scene_metrics"]["unseen_share"] is None  # the blobs scene has no unseen masks: nothing to share

    # not a removal: one line naming it, nothing written
    code = main(["evaluate", str(renders), str(scene.root), str(tmp_path / "f.json"), "--removal", str(scene.root)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "removal.json" in err[0] and not (tmp_path / "f.json").exists()
    broken = tmp_path / "broken"
    shutil.copytree(out, broken)
    np.save(broken / "removed_index.npy", np.load(out / "removed_index.npy")[:-1])
    code = main(["evaluate", str(renders), str(scene.root), str(tmp_path / "f.json"), "--removal", str(broken)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "removed_index.npy" in err[0] and "indices" in err[0]
