"""What a removal took (:mod:`inpaint360gs.evaluate.removal`, ``inpaint360gs evaluate --removal`` and
``inpaint360gs score-removal``): the model the removal started from is put back together exactly; AMCR
(paper supp. Eq. 1) is the mean coverage of the removal stage's own masks over the training views; at
the test cameras the removed silhouette is the pixels the removed object gives half its colour; the
ground-truth residual, collateral and footprint share against a scene's ``gt/`` — closed-form on a
scene whose truth is its own model, the same in a structure-from-motion-like frame (another scale,
rotation and origin), and against the generator's truth on a generated scene posed by the generator
and one posed by pycolmap."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
import torch
from object_fields import labelled_field

from inpaint360gs.cli import main
from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.io.images import read_mask, write_labels
from inpaint360gs.io.scene import load_scene
from inpaint360gs.remove.config import RemovalConfig
from inpaint360gs.remove.stage import remove_stage
from inpaint360gs.render.api import render
from inpaint360gs.views.unseen import normalised_depth
from inpaint360gs.evaluate.removal import (
    masks_in_test_views,
    original_model,
    removal_masks,
    removal_scores,
    scale_to_truth,
    silhouette_share,
    training_amcr,
    true_poses,
)
from inpaint360gs.metrics.masked import amcr

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
    assert silhouette_share(out, scene) == pytest.approx(np.mean(shares), abs=1e-12)
    # AMCR (supp. Eq. 1): the removal's own masks over the training views, what removal.json records
    train = [read_mask(out / "masks" / f"{v.stem}.png") > 0 for v in scene.train_views]
    assert training_amcr(out, scene) == pytest.approx(amcr(train)) == pytest.approx(json.loads((out / "removal.json").read_text())["amcr_percent"])
    assert training_amcr(out, scene) != pytest.approx(silhouette_share(out, scene))


def test_evaluate_with_removal_records_amcr_and_the_silhouette_apart_from_the_unseen_share(removed, tmp_path, capsys):
    scene, model, labels, out = removed
    renders = tmp_path / "renders"
    renders.mkdir()
    for v in scene.test_views:  # the object-free images themselves as renders
        shutil.copy(scene.root / "images" / v.name, renders / v.name)
    code = main(["evaluate", str(renders), str(scene.root), str(tmp_path / "e.json"), "--removal", str(out), "--nets", "alex"])
    std = capsys.readouterr()
    assert code == 0, std.err
    res = json.loads((tmp_path / "e.json").read_text())
    assert res["scene_metrics"]["amcr"] == pytest.approx(training_amcr(out, scene)) and "AMCR" in std.out
    assert res["scene_metrics"]["silhouette_test"] == pytest.approx(silhouette_share(out, scene))
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


# --- ground-truth scores ---------------------------------------------------------------------------

CLASSES = [0, 3, 7, 9]  # class -> object id: background, the target's top half, its bottom half, a floor patch far from it
NO_EXTRAS = RemovalConfig(hull=False, protect_support=None, support_column=None, footprint_margin=None)  # exactly the ids' Gaussians


@torch.no_grad()
def write_own_truth(root, model: Gaussians, labels: torch.Tensor, scene) -> None:
    """``gt/`` of a blobs scene whose truth is its own model, in the generator's layout: blob 1 is
    the removal target; its footprint is where it gives half the colour, depths are the surfaces
    the model shows with and without it (no surface: 0 with it, infinitely far without)."""
    gt = root / "gt"
    for sub in ("instance", "depth", "depth_free"):
        (gt / sub).mkdir(parents=True, exist_ok=True)
    free = model.subset(labels != 1)
    for v in scene.train_views + scene.holdout_views:
        full, without = render(model, v.camera), render(free, v.camera)
        write_labels(gt / "instance" / f"{v.stem}.png", (share_of(model, labels == 1, v.camera) >= 0.5).astype(np.uint8))
        np.save(gt / "depth" / f"{v.stem}.npy", np.where(full.alpha.numpy() >= 0.5, normalised_depth(full).numpy(), 0.0).astype(np.float32))
        np.save(gt / "depth_free" / f"{v.stem}.npy", np.where(without.alpha.numpy() >= 0.5, normalised_depth(without).numpy(), np.inf).astype(np.float32))
    cams = [{"name": v.name, "R": v.camera.R.double().tolist(), "t": v.camera.t.double().tolist()} for v in scene.views]
    (gt / "cameras.json").write_text(json.dumps({"images": cams}))
    (gt / "objects.json").write_text(json.dumps([{"id": 1, "removal_target": True}, {"id": 2, "removal_target": False}]))


def _classes(model: Gaussians, labels: torch.Tensor) -> torch.Tensor:
    """Class per Gaussian (CLASSES): blob 1 split at its centre's height, a floor corner patch, the rest background."""
    z = model.means[:, 2]
    top = (labels == 1) & (z > z[labels == 1].median())
    patch = (labels == 0) & (model.means[:, 0] < -0.8) & (model.means[:, 1] < -0.8)
    return torch.where(top, 1, torch.where(labels == 1, 2, torch.where(patch, 3, 0)))


def _similar(model: Gaussians, s: float, R: np.ndarray, t: np.ndarray) -> Gaussians:
    """``model`` moved by x -> s R x + t (isotropic Gaussians: the rotation leaves their shape)."""
    Rt = torch.tensor(R, dtype=torch.float32)
    return Gaussians(**{**model.tensors(), "means": s * model.means @ Rt.T + torch.tensor(t, dtype=torch.float32),
                        "log_scales": model.log_scales + float(np.log(s))})


def _similar_scene(src, dst, s: float, R: np.ndarray, t: np.ndarray) -> None:
    """A copy of the scene ``src`` whose cameras and points are in another frame (x -> s R x + t), as
    structure from motion gives them; images and gt/ stay as they are (the truth's frame)."""
    from scene_builder import write_model

    from inpaint360gs.core.camera import Camera

    shutil.copytree(src, dst, ignore=shutil.ignore_patterns("sparse"))
    scene = load_scene(src)
    cams = []
    for v in scene.views:
        c = v.camera
        Rn = c.R.double().numpy() @ R.T  # x_cam * s = R R0^T x' - R R0^T t0 + s t_cam: the same picture
        tn = s * c.t.double().numpy() - Rn @ t
        cams.append(Camera(torch.tensor(Rn, dtype=torch.float32), torch.tensor(tn, dtype=torch.float32), c.fx, c.fy, c.cx, c.cy, c.width, c.height, c.name))
    pts = scene.points.double().numpy()
    write_model(dst / "sparse" / "0", cams, s * pts @ R.T + t, scene.point_colors.numpy())


@pytest.fixture(scope="module")
def truth_scene(make_blobs_scene):
    root, model, labels = make_blobs_scene("truth", n_views=12, n_test=2)
    scene = load_scene(root)
    write_own_truth(root, model, labels, scene)
    return root, model, labels


def _removal(root, model, labels, ids, out, classes=None):
    """Remove the Gaussians of the classes of ``ids`` (classes: :func:`_classes` of ``model``, or given)."""
    scene = load_scene(root)
    classes = _classes(model, labels) if classes is None else classes
    remove_stage(scene, labelled_field(model, classes, CLASSES), out, ids=ids, cfg=NO_EXTRAS, overwrite=True)
    return scene


def test_ground_truth_scores_of_a_scene_whose_truth_is_its_own_model(truth_scene, tmp_path):
    root, model, labels = truth_scene
    # exactly the target: nothing of it left, nothing else changed, AMCR the true footprint share
    scene = _removal(root, model, labels, [3, 7], tmp_path / "exact")
    res = removal_scores(tmp_path / "exact", scene)
    s = res["scores"]
    assert s["residual"] == 0.0 and s["collateral"] == 0.0 and res["above_limits"] == [], res["null_reasons"]
    assert s["amcr"] == pytest.approx(training_amcr(tmp_path / "exact", scene)) and s["amcr_ratio"] == pytest.approx(1.0)
    assert s["gt_footprint_share"] == pytest.approx(np.mean([100 * (read_mask(root / "gt" / "instance" / f"{v.stem}.png") > 0).mean()
                                                             for v in scene.train_views]))
    assert res["scale_to_truth"] == pytest.approx(1.0, abs=1e-5) and set(res["per_view"]) == {v.name for v in scene.train_views}
    # its top half only: the bottom half still shows where the object stood
    _removal(root, model, labels, [3], tmp_path / "half")
    half = removal_scores(tmp_path / "half", scene)
    assert 20.0 < half["scores"]["residual"] < 80.0 and half["scores"]["collateral"] == 0.0
    assert half["scores"]["amcr_ratio"] < 0.8 and [a["limit"] for a in half["above_limits"]] == ["residual"]
    counts = half["per_view"]
    assert half["scores"]["residual"] == pytest.approx(100 * sum(c["residual"] for c in counts.values()) / sum(c["footprint"] for c in counts.values()))
    # the target and a floor patch far from it: collateral, and AMCR beyond the true footprint
    _removal(root, model, labels, [3, 7, 9], tmp_path / "more")
    more = removal_scores(tmp_path / "more", scene)
    assert more["scores"]["residual"] == 0.0 and more["scores"]["collateral"] > 1.0
    assert more["scores"]["amcr_ratio"] > 1.0 and "collateral" in [a["limit"] for a in more["above_limits"]]


def test_ground_truth_scores_are_the_same_in_a_structure_from_motion_frame(truth_scene, tmp_path):
    """The scene's cameras, points and model in another frame (scale 0.154, a rotation, another
    origin; gt/ in the truth's): the scale is recovered from the camera centres and every score
    is the same as in the truth's frame."""
    root, model, labels = truth_scene
    R = scipy_rotation(0.3, -1.1, 2.0)
    s, t = 0.154, np.array([0.4, -2.0, 1.3])
    _similar_scene(root, tmp_path / "sfm", s, R, t)
    moved = _similar(model, s, R, t)
    for ids, name in (([3, 7], "exact"), ([3], "half"), ([3, 7, 9], "more")):
        scene = _removal(root, model, labels, ids, tmp_path / name)
        sfm = _removal(tmp_path / "sfm", moved, labels, ids, tmp_path / f"sfm_{name}", classes=_classes(model, labels))
        assert scale_to_truth(sfm, true_poses(tmp_path / "sfm")) == pytest.approx(1 / s, rel=1e-5)
        a, b = removal_scores(tmp_path / name, scene)["scores"], removal_scores(tmp_path / f"sfm_{name}", sfm)["scores"]
        for k in ("residual", "collateral", "gt_footprint_share", "amcr"):
            assert b[k] == pytest.approx(a[k], abs=0.05), (name, k)


def scipy_rotation(*angles) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    return Rotation.from_euler("xyz", angles).as_matrix()


def test_without_ground_truth_only_amcr_and_the_cli(removed, truth_scene, tmp_path, capsys):
    scene, model, labels, out = removed  # the blobs scene without gt/
    res = removal_scores(out, scene)
    assert res["scores"]["amcr"] == pytest.approx(training_amcr(out, scene))
    assert res["scores"]["residual"] is None and "no ground truth" in res["null_reasons"]["residual"] and res["above_limits"] == []
    root, tmodel, tlabels = truth_scene
    _removal(root, tmodel, tlabels, [3], tmp_path / "half")
    code = main(["score-removal", str(root), str(tmp_path / "half"), str(tmp_path / "s.json")])
    std = capsys.readouterr()
    assert code == 0, std.err
    written = json.loads((tmp_path / "s.json").read_text())
    assert written["scores"]["residual"] > 20 and written["provenance"]["stage"] == "score-removal" and "above: residual" in std.out
    # a removal of another scene: one line naming it, nothing written
    code = main(["score-removal", str(root), str(out), str(tmp_path / "t.json")])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "removal.json" in err[0] and not (tmp_path / "t.json").exists()
    # an old generated scene without gt/depth_free: residual null with the reason, the rest scored
    old = tmp_path / "old"
    shutil.copytree(root, old)
    shutil.rmtree(old / "gt" / "depth_free")
    half = _removal(old, tmodel, tlabels, [3], tmp_path / "old_half")
    res = removal_scores(tmp_path / "old_half", half)
    assert res["scores"]["residual"] is None and "regenerate" in res["null_reasons"]["residual"] and res["scores"]["collateral"] == 0.0
