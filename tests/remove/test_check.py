"""The selection check (docs/architecture.md, "A run checks itself"): on the blobs scene every
Gaussian's object is known, so which selections are an object under the click, a speck, the floor,
or something away from the click has an exact answer."""

from __future__ import annotations

import numpy as np
import pytest
from object_fields import labelled_field

from inpaint360gs.io.scene import load_scene
from inpaint360gs.remove.check import BACKDROP, OBJECT, OFF_CLICK, SUPPORT, TOO_SMALL, SelectionLimits, assess_selection, selection_masks
from inpaint360gs.remove.select import Click, support_heights

IDS = [0, 3, 7]
BLOB_1 = (0.45, 0.0, 0.25)  # scene_builder.blobs_model's first blob (label 1)


@pytest.fixture(scope="module")
def blobs(make_blobs_scene):
    root, model, labels = make_blobs_scene("check", n_views=10)
    scene = load_scene(root)
    return scene, model, labels.numpy(), labelled_field(model, labels, IDS)


def click_on(view, point) -> Click:
    cam = view.camera
    R, t = cam.R.double().numpy(), cam.t.double().numpy()
    xc = R @ np.asarray(point, float) + t
    return Click(view.name, int(cam.fx * xc[0] / xc[2] + cam.cx), int(cam.fy * xc[1] / xc[2] + cam.cy))


def test_the_object_under_the_click_passes(blobs):
    scene, _, labels, field = blobs
    heights, radius, _, _ = support_heights(field, scene)
    v = scene.train_views[0]
    c = click_on(v, BLOB_1)
    got = assess_selection(field, scene, labels == 1, [c], heights=heights, radius=radius)
    assert got.passed and got.verdict == OBJECT
    assert got.gaussians == int((labels == 1).sum())
    assert got.click_distance[v.name] == 0.0
    masks = selection_masks(field, labels == 1, scene)
    assert got.view_share[v.name] == pytest.approx(float(masks[v.name].mean()))
    assert 0.005 < got.view_share[v.name] < 0.5
    assert got.support_share is not None and got.support_share < 0.2


def test_a_handful_of_gaussians_is_a_speck(blobs):
    scene, _, labels, field = blobs
    v = scene.train_views[0]
    two = np.zeros(len(labels), bool)
    two[np.flatnonzero(labels == 1)[:2]] = True
    got = assess_selection(field, scene, two, [click_on(v, BLOB_1)])
    assert not got.passed and got.verdict == TOO_SMALL and got.gaussians == 2
    assert "2 Gaussians" in got.reason


def test_the_floor_is_the_support(blobs):
    scene, _, labels, field = blobs
    heights, radius, _, _ = support_heights(field, scene)
    v = scene.train_views[0]
    floor = labels == 0
    ys, xs = np.nonzero(selection_masks(field, floor, scene, views=[v])[v.name])
    c = Click(v.name, int(xs[len(xs) // 2]), int(ys[len(ys) // 2]))  # a pixel the floor shows
    got = assess_selection(field, scene, floor, [c], heights=heights, radius=radius)
    assert not got.passed and got.verdict == SUPPORT and got.support_share > 0.9
    assert assess_selection(field, scene, floor, [c]).passed  # without the plane, a floor inside the frame is not told from a rug


def test_what_fills_the_frame_or_runs_off_it_is_the_backdrop(blobs):
    scene, _, labels, field = blobs
    v = scene.train_views[0]
    c = click_on(v, BLOB_1)
    h, w = v.camera.height, v.camera.width
    full = {u.name: np.ones((h, w), bool) for u in scene.train_views}
    got = assess_selection(field, scene, labels == 0, [c], masks=full)
    assert not got.passed and got.verdict == BACKDROP and got.view_share[v.name] == 1.0
    # the lower half of every view: 50 % of the photo, off three sides in every view
    lower = np.zeros((h, w), bool)
    lower[h // 2 :] = True
    c_low = Click(v.name, w // 2, h - 2)
    got = assess_selection(field, scene, labels == 0, [c_low], masks={u.name: lower for u in scene.train_views})
    assert not got.passed and got.verdict == BACKDROP and got.border_views == 1.0 and "backdrop" in got.reason
    # a large object off two sides (the plush toy filling the frame) is still an object
    corner = np.zeros((h, w), bool)
    corner[h // 3 :, w // 3 :] = True
    got = assess_selection(field, scene, labels == 0, [c_low], masks={u.name: corner for u in scene.train_views})
    assert got.passed, got.reason


def test_a_selection_away_from_the_click_is_refused(blobs):
    scene, _, labels, field = blobs
    v = scene.train_views[0]
    c = click_on(v, BLOB_1)
    got = assess_selection(field, scene, labels == 2, [c])  # the other blob
    assert not got.passed and got.verdict == OFF_CLICK and got.click_distance[v.name] > 2
    # a wider radius accepts it: the test is the distance, not the label
    wide = assess_selection(field, scene, labels == 2, [c], limits=SelectionLimits(click_radius=10.0))
    assert wide.passed


def test_ids_only_are_checked_on_the_view_that_shows_the_most_of_them(blobs):
    scene, _, labels, field = blobs
    got = assess_selection(field, scene, labels == 1, [])
    assert got.passed and len(got.view_share) == 1
    masks = selection_masks(field, labels == 1, scene)
    (name,) = got.view_share
    assert masks[name].sum() == max(m.sum() for m in masks.values())


def test_a_click_on_the_floor_that_the_field_calls_an_object_fails_the_check(blobs, tmp_path):
    """The undertrained-field case: the floor carries blob 1's id (as the README budget with 100
    distillation steps gave the floor the cone's), so a click on the floor
    resolves to it and the removal takes the floor; the plan's check says so, the stage records it."""
    import json

    import torch

    from inpaint360gs.remove.config import RemovalConfig
    from inpaint360gs.remove.stage import plan_removal, remove_stage

    scene, model, labels, _ = blobs
    floor_as_object = labelled_field(model, torch.from_numpy(np.where(labels == 0, 1, labels)), IDS)  # floor -> id 3
    v = scene.train_views[0]
    ys, xs = np.nonzero(selection_masks(floor_as_object, labels == 0, scene, views=[v])[v.name])
    c = Click(v.name, int(xs[len(xs) // 2]), int(ys[len(ys) // 2]))
    plan = plan_removal(floor_as_object, scene, clicks=[c], cfg=RemovalConfig(footprint_margin=None))
    assert plan.targets == [3]
    assert not plan.check.passed and plan.check.verdict in (SUPPORT, BACKDROP), plan.check.reason
    info = remove_stage(scene, floor_as_object, tmp_path / "rem", clicks=[c], cfg=RemovalConfig(footprint_margin=None))
    assert info["selection_check"]["passed"] is False
    assert json.loads((tmp_path / "rem" / "removal.json").read_text())["selection_check"]["verdict"] == plan.check.verdict
    # the same field, a click on the blob: an object
    ok = plan_removal(floor_as_object, scene, clicks=[click_on(v, (-0.45, 0.15, 0.22))], cfg=RemovalConfig(footprint_margin=None))
    assert ok.targets == [7] and ok.check.passed, ok.check.reason
