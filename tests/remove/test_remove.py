"""Click/id selection and removal (paper Sec. 3.4 first paragraph; supp. B "Object Removal",
supp. Eq. 1 AMCR) on hand-made identity fields (``object_fields``): every Gaussian's object is
known, so what a click resolves to, what is removed and which pixels are left to fill have exact
answers without training.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch
from object_fields import ball, labelled_field, one_hot_features, points_model

from inpaint360gs.core.errors import InputError
from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.io.images import read_mask
from inpaint360gs.io.ply import read_ply
from inpaint360gs.io.scene import load_scene
from inpaint360gs.remove.config import RemovalConfig
from inpaint360gs.remove.geometry import inlier_points as _inlier_points
from inpaint360gs.remove.geometry import inside_hull, object_body
from inpaint360gs.remove.objects import fill_masks, remove_objects
from inpaint360gs.remove.stage import remove_stage
from inpaint360gs.remove.select import Click, resolve_clicks, select
from inpaint360gs.render.api import render

IDS = [0, 3, 7]  # class -> object id (not 0, 1, 2: the mapping is exercised)


# --- Click.parse ------------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "text, want",
    [
        ("IMG_0003.png:120,88", ("IMG_0003.png", 120, 88)),
        ("IMG_0003:0,0", ("IMG_0003", 0, 0)),
        ("a:b.png:5,6", ("a:b.png", 5, 6)),  # the last colon separates the pixel
        ("IMG.png:12.6,3.2", ("IMG.png", 13, 3)),  # sub-pixel positions round to the nearest pixel
        ("IMG.png: 4, 5", ("IMG.png", 4, 5)),
        ("IMG.png:-1,5", ("IMG.png", -1, 5)),  # parsed; refused against the image size
    ],
)
def test_click_parse(text, want):
    c = Click.parse(text)
    assert (c.view, c.x, c.y) == want
    assert Click.parse(str(c)) == c


@pytest.mark.parametrize("text", ["IMG.png", "IMG.png:5", "IMG.png:5,6,7", "IMG.png:x,y", "IMG.png:,", "", "IMG.png:nan,3", "IMG.png:inf,3", "IMG.png:1e400,3", "5,6", ":5,6"])
def test_malformed_click_is_an_input_error_naming_the_setting(text):
    with pytest.raises(InputError, match="not VIEW:X,Y") as e:
        Click.parse(text)
    assert e.value.setting == "clicks" and e.value.path is None


# --- the blobs scene with a labelled field -----------------------------------------------------------


@pytest.fixture(scope="module")
def blobs(make_blobs_scene):
    """The blobs scene (floor = class 0, blob 1 -> id 3, blob 2 -> id 7) and its labelled field."""
    root, model, labels = make_blobs_scene("remove", n_views=10)
    scene = load_scene(root)
    return scene, model, labels, labelled_field(model, labels, IDS)


@torch.no_grad()
def true_ids(model: Gaussians, labels: torch.Tensor, camera) -> np.ndarray:
    """The object id each pixel shows, from the labels rendered as one-hot weights (not through the
    field): the label with the largest weight where it covers at least half of the pixel."""
    g = Gaussians(**{**model.tensors(), "features": torch.nn.functional.one_hot(labels, 3).float()})
    out = render(g, camera, with_features=True)
    best = out.features.argmax(-1)
    ok = out.features.max(-1).values >= 0.5
    return np.asarray(IDS)[torch.where(ok, best, 0).numpy()]


def centre_pixel(camera, point) -> tuple[int, int]:
    R, t = camera.R.double().numpy(), camera.t.double().numpy()
    xc = R @ np.asarray(point, float) + t
    return int(camera.fx * xc[0] / xc[2] + camera.cx), int(camera.fy * xc[1] / xc[2] + camera.cy)


BLOB_CENTRES = {3: (0.45, 0.0, 0.25), 7: (-0.45, 0.15, 0.22)}  # scene_builder.blobs_model's


def test_a_click_resolves_to_the_object_rendered_there(blobs):
    scene, model, labels, field = blobs
    checked = 0
    for v in scene.train_views:
        truth = true_ids(model, labels, v.camera)
        for oid, centre in BLOB_CENTRES.items():
            x, y = centre_pixel(v.camera, centre)
            if truth[y, x] == oid:  # the blob is not hidden behind the other one here
                assert resolve_clicks(field, scene, [Click(v.name, x, y)]) == [oid]
                checked += 1
    assert checked >= 2 * len(scene.train_views) - 4
    # several clicks, in order; a view may be named by its stem
    v = scene.train_views[0]
    clicks = [Click(v.stem, *centre_pixel(v.camera, BLOB_CENTRES[7])), Click(v.name, *centre_pixel(v.camera, BLOB_CENTRES[3]))]
    assert resolve_clicks(field, scene, clicks) == [7, 3]


class MapField:
    """A stand-in for a field whose rendered id map is given (to pin the click's x/y convention)."""

    def __init__(self, id_map: np.ndarray):
        self.id_map = torch.from_numpy(id_map)

    def render_ids(self, camera, **kw):
        return self.id_map, None


def test_click_reads_column_x_row_y_and_refuses_pixels_outside(blobs):
    scene = blobs[0]
    v = scene.train_views[1]
    w, h = v.camera.width, v.camera.height
    id_map = np.zeros((h, w), np.int64)
    id_map[10, 40] = 5  # row 10, column 40
    id_map[h - 1, w - 1] = 9
    field = MapField(id_map)
    assert resolve_clicks(field, scene, [Click(v.name, 40, 10)]) == [5]
    assert resolve_clicks(field, scene, [Click(v.name, w - 1, h - 1)]) == [9]
    for x, y in ((w, 0), (0, h), (-1, 3), (3, -1), (10**6, 10**6)):
        with pytest.raises(InputError, match=f"outside the {w}x{h} image") as e:
            resolve_clicks(field, scene, [Click(v.name, x, y)])
        assert e.value.setting == "clicks"


def test_click_on_the_background_is_refused(blobs):
    scene, model, labels, field = blobs
    v = scene.train_views[2]
    truth = true_ids(model, labels, v.camera)
    alpha = render(model, v.camera).alpha.detach().numpy()
    floor = np.argwhere((truth == 0) & (alpha > 0.9))[0]  # the floor: a background Gaussian
    empty = np.argwhere(alpha < 1e-3)[0]  # nothing rendered at all
    for (y, x), why in ((floor, "on the background"), (empty, "on empty space")):
        with pytest.raises(InputError, match=why):
            resolve_clicks(field, scene, [Click(v.name, int(x), int(y))])
    with pytest.raises(InputError, match="on the support surface"):  # growing an object from it: none stands there
        select(field, scene, [Click(v.name, int(floor[1]), int(floor[0]))])


def test_nothing_rendered_is_background_whatever_the_classifier_says_of_it(blobs):
    """Where no Gaussian is rendered the feature is zero and Phi answers with its bias alone; a bias
    favouring an object must not turn empty space into that object."""
    scene, model, labels, field = blobs
    biased = labelled_field(model, labels, IDS)
    with torch.no_grad():
        biased.classifier.bias.copy_(torch.tensor([0.0, 3.0, 0.0]))  # object 3 where features are ~0
    v = scene.train_views[2]
    alpha = render(model, v.camera).alpha.detach()
    ids, _ = biased.render_ids(v.camera)
    assert (ids[alpha < 1e-3] == 3).all()  # the raw id map
    assert (biased.render_ids(v.camera, min_alpha=0.5)[0][alpha < 0.5] == 0).all()
    y, x = (int(i) for i in (alpha < 1e-3).nonzero()[0])
    with pytest.raises(InputError, match="on empty space"):
        resolve_clicks(biased, scene, [Click(v.name, x, y)])
    x, y = centre_pixel(v.camera, BLOB_CENTRES[7])
    assert resolve_clicks(biased, scene, [Click(v.name, x, y)]) == [7]


def test_a_click_on_an_object_the_segmenter_missed_grows_it_in_3d(blobs, tmp_path):
    """Blob 2 (id 7) labelled background, as when the 2D masks never found it: a click on it selects
    the Gaussians standing on the floor linked to what the pixel shows (the whole blob, no floor),
    and the removal takes them."""
    scene, model, labels, _ = blobs
    missed = labelled_field(model, torch.where(labels == 2, 0, labels), IDS)
    v = scene.train_views[0]
    x, y = centre_pixel(v.camera, BLOB_CENTRES[7])
    with pytest.raises(InputError, match="on the background"):
        resolve_clicks(missed, scene, [Click(v.name, x, y)])  # the id map alone
    (sel,) = select(missed, scene, [Click(v.name, x, y)])
    assert sel.how == "grown" and sel.object_id is None
    blob = (labels == 2).numpy()
    got = sel.gaussians
    assert (got & blob).sum() / (got | blob).sum() > 0.9 and not (got & (labels == 0).numpy()).any()
    info = remove_stage(scene, missed, tmp_path / "rem", clicks=[Click(v.name, x, y)], cfg=RemovalConfig(footprint_margin=None))
    assert info["selected_by"] == {f"{v.name}:{x},{y}": "grown"} and info["objects"] == []
    removed = np.zeros(len(labels), bool)
    removed[np.load(tmp_path / "rem" / "removed_index.npy")] = True
    assert removed[blob].mean() > 0.95 and not removed[(labels == 1).numpy()].any()


def test_click_on_an_unknown_or_test_view_is_refused(blobs):
    scene, _, _, field = blobs
    with pytest.raises(InputError, match="has no view 'IMG_999.png'"):
        resolve_clicks(field, scene, [Click("IMG_999.png", 3, 3)])
    with pytest.raises(InputError, match="evaluation \\(test_\\) view"):
        resolve_clicks(field, scene, [Click(scene.test_views[0].name, 3, 3)])


# --- removal by id: probability, body, hull ---------------------------------------------------------


def hand_field(parts: list[tuple[np.ndarray, int]], object_ids=IDS):
    """A field from point sets with a class each (-1: no opinion); returns it and each Gaussian's part."""
    pts = np.concatenate([p for p, _ in parts])
    classes = torch.tensor(np.concatenate([np.full(len(p), c) for p, c in parts]), dtype=torch.long)
    part = np.concatenate([np.full(len(p), k) for k, (p, _) in enumerate(parts)])
    return labelled_field(points_model(pts), classes, object_ids), part


@pytest.fixture(scope="module")
def hull_case():
    """Object 3 (a ball of Gaussians at the origin) holding Gaussians the field does not assign to it
    (background features, no opinion, a few of object 7), object 7 beside it, a floor, a whisker of
    object-3 Gaussians linked to the ball, and far object-3 strays with background between."""
    rng = np.random.default_rng(0)
    g = np.linspace(-1.5, 1.5, 16)
    fx, fy = np.meshgrid(g, g)
    parts = {
        "obj3": (ball(rng, 400, 0.3), 1),
        "inside_background": (ball(rng, 30, 0.15), 0),
        "inside_no_opinion": (ball(rng, 20, 0.15), -1),
        "inside_obj7": (ball(rng, 6, 0.15), 2),
        "obj7": (ball(rng, 400, 0.3, (1.0, 0.0, 0.0)), 2),
        "floor": (np.stack([fx.ravel(), fy.ravel(), np.full(fx.size, -0.5)], 1), 0),
        "whisker": (np.stack([np.linspace(0.33, 0.6, 6), np.zeros(6), np.zeros(6)], 1) @ np.array([[0, 1, 0], [-1, 0, 0], [0, 0, 1.0]]), 1),
        "whisker_gap": (np.array([[0.0, 0.45, 0.0], [0.02, 0.52, 0.01]]), 0),  # inside the hull only if the whisker counted
        "strays": (np.array([[0.0, -1.2, 0.6], [0.05, -1.25, 0.62], [0.0, -1.2, 0.65]]), 1),
        "stray_gap": (np.array([[0.0, -0.7, 0.35], [0.0, -0.5, 0.25]]), 0),  # inside the hull only if the strays counted
    }
    field, part = hand_field(list(parts.values()))
    names = list(parts)
    return field, np.asarray(names)[part]


def test_removal_takes_the_object_and_what_lies_inside_its_hull(hull_case):
    field, part = hull_case
    res = remove_objects(field, [3])
    removed = res.removed_mask.numpy()
    for name in ("obj3", "inside_background", "inside_no_opinion"):
        assert removed[part == name].all(), name
    for name in ("inside_obj7", "obj7", "floor", "whisker_gap", "strays", "stray_gap"):
        assert not removed[part == name].any(), name
    # by probability: the ball and the whisker (one body); by hull: the low-probability inside
    assert res.counts == {"3": {"by_probability": 406, "by_hull": 50}}
    assert res.objects == [3]
    assert len(res.kept) + len(res.removed) == len(field.gaussians)
    assert torch.equal(res.removed.means, field.gaussians.means[res.removed_mask])
    assert torch.equal(res.removed.features, field.gaussians.features[res.removed_mask])  # kept to put back


def test_without_the_hull_only_the_probable_gaussians_go(hull_case):
    field, part = hull_case
    res = remove_objects(field, [3], RemovalConfig(hull=False))
    assert np.array_equal(res.removed_mask.numpy(), np.isin(part, ["obj3", "whisker"]))
    assert res.counts["3"]["by_hull"] == 0


def test_other_objects_are_protected_unless_that_is_turned_off(hull_case):
    field, part = hull_case
    res = remove_objects(field, [3], RemovalConfig(protect_others=False))
    assert res.removed_mask.numpy()[part == "inside_obj7"].all()
    assert not res.removed_mask.numpy()[part == "obj7"].any()


def test_background_in_the_hull_is_kept_when_asked(hull_case):
    """protect_background: the hull keeps what the field calls background (the floor an object stands on),
    still takes what has no opinion; off by default."""
    field, part = hull_case
    res = remove_objects(field, [3], RemovalConfig(protect_background=0.5))
    removed = res.removed_mask.numpy()
    assert not removed[part == "inside_background"].any()
    assert removed[part == "inside_no_opinion"].all() and removed[part == "obj3"].all()
    assert res.counts["3"] == {"by_probability": 406, "by_hull": 20}
    # a threshold above every background probability protects nothing
    assert torch.equal(remove_objects(field, [3], RemovalConfig(protect_background=1.0)).removed_mask, remove_objects(field, [3]).removed_mask)


def test_background_on_the_support_plane_is_kept_by_the_hull(hull_case):
    """protect_support (on by default): background Gaussians within 0.008 R of the support plane stay,
    background higher up and what has no opinion still go; no plane (heights None): no guard."""
    field, part = hull_case
    means = field.gaussians.means.numpy().astype(np.float64)
    on_plane = remove_objects(field, [3], heights=means[:, 2], radius=0.16 / 0.008)  # plane z = 0, band |z| < 0.16
    removed = on_plane.removed_mask.numpy()
    assert not removed[part == "inside_background"].any()
    assert removed[part == "inside_no_opinion"].all() and removed[part == "obj3"].all()
    assert on_plane.counts["3"] == {"by_probability": 406, "by_hull": 20}
    below = remove_objects(field, [3], heights=means[:, 2] + 1.0, radius=0.16 / 0.008)  # the band well below the ball
    assert below.removed_mask.numpy()[part == "inside_background"].all()
    assert torch.equal(remove_objects(field, [3], RemovalConfig(protect_support=None), heights=means[:, 2], radius=20.0).removed_mask,
                       remove_objects(field, [3]).removed_mask)


def test_two_objects_at_once(hull_case):
    field, part = hull_case
    res = remove_objects(field, [7, 3])
    removed = res.removed_mask.numpy()
    assert removed[np.isin(part, ["obj3", "obj7", "inside_obj7", "inside_background"])].all()
    assert not removed[np.isin(part, ["floor", "strays", "stray_gap", "whisker_gap"])].any()
    assert set(res.counts) == {"3", "7"}


def test_threshold_decides_what_goes_by_probability():
    rng = np.random.default_rng(1)
    pts = ball(rng, 50, 0.3)
    classes = torch.ones(50, dtype=torch.long)
    field = labelled_field(points_model(pts), classes, IDS)
    # half of them: a weaker opinion, probability e^2/(e^2+2) = 0.787 of object 3
    field.gaussians.features[:25] = one_hot_features(classes[:25], 4, strength=2.0)
    got = remove_objects(field, [3], RemovalConfig(threshold=0.8, hull=False)).removed_mask
    assert got.tolist() == [False] * 25 + [True] * 25
    assert remove_objects(field, [3], RemovalConfig(threshold=0.7, hull=False)).removed_mask.all()
    with pytest.raises(InputError, match=r"no Gaussian has probability > 0.9999 for object\(s\) \[3\]"):
        remove_objects(field, [3], RemovalConfig(threshold=0.9999))


def test_unknown_ids_and_empty_selection_are_refused(hull_case):
    field, _ = hull_case
    for bad in ([5], [3, 4], [0], [256]):
        with pytest.raises(InputError, match=r"unknown object id .* \(the field knows \[3, 7\]\)") as e:
            remove_objects(field, bad)
        assert e.value.setting == "ids"
    with pytest.raises(InputError, match="nothing selected"):
        remove_objects(field, [])


def test_outlier_filter_and_body_on_hand_sets():
    rng = np.random.default_rng(2)
    core = ball(rng, 400, 0.3)
    whisker = np.stack([np.linspace(0.33, 0.6, 6), np.zeros(6), np.zeros(6)], 1)
    pts = np.r_[core, whisker]
    inl = _inlier_points(pts, 10, 2.0)
    assert not any((inl == w).all(1).any() for w in whisker[1:])  # the whisker's tip is filtered out
    assert len(inl) >= 0.97 * len(core)
    assert _inlier_points(pts[:8], 10, 2.0).shape == (8, 3)  # too few for k neighbours: all kept
    far = np.array([[5.0, 0, 0], [5.05, 0, 0]])
    body = object_body(np.r_[pts, far], 4.0, 0.1)
    assert body[: len(pts)].all() and not body[len(pts) :].any()
    probe = np.array([[0.45, 0, 0], [0.0, 0, 0], [2.5, 0, 0], [0.2, 0, 0]])
    assert inside_hull(inl, probe).tolist() == [False, True, False, True]
    assert inside_hull(pts, probe).tolist() == [True, True, False, True]  # unfiltered: the whisker widens the hull
    flat = np.c_[rng.uniform(size=(30, 2)), np.zeros(30)]
    assert not inside_hull(flat, flat).any()  # no volume: nothing is inside
    assert not inside_hull(core[:4], core).any()


# --- fill masks (AMCR) ------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def wall_case(blobs):
    """A view of the blobs scene, an opaque wall of Gaussians filling it behind the origin, and the
    unit vector from the camera through the origin (the view's centre pixel)."""
    view = blobs[0].train_views[0]
    R, t = view.camera.R.double().numpy(), view.camera.t.double().numpy()
    ahead = R.T @ t / np.linalg.norm(t)  # = -eye / |eye|
    right, up = R[0], R[1]  # camera axes in the world
    g = np.linspace(-4, 4, 81)
    wall = np.array([0.8 * ahead + a * right + b * up for a in g for b in g])
    return view, wall, ahead


def wall_model(wall: np.ndarray, front: list[tuple[np.ndarray, float]]) -> Gaussians:
    """The wall (opaque, small Gaussians) and big Gaussians (radius 0.3) at the given centres with the given opacities."""
    m = points_model(np.r_[wall, [c for c, _ in front]], scale=0.1, opacity=0.99)
    for k, (_, opacity) in enumerate(front):
        i = len(wall) + k
        m.log_scales[i] = float(np.log(0.3))
        m.opacity_logits[i] = torch.logit(torch.tensor(opacity))
    return m


def test_a_pixel_is_to_fill_when_removed_gaussians_gave_half_its_colour(wall_case):
    view, wall, _ = wall_case
    cam = view.camera
    front = torch.zeros(len(wall) + 1, dtype=torch.bool)
    front[-1] = True
    cy, cx = cam.height // 2, cam.width // 2
    origin = np.zeros(3)
    for opacity, share, centre in ((0.8, 0.5, True), (0.4, 0.5, False), (0.4, 0.3, True), (0.8, 0.9, False)):
        mask = fill_masks(wall_model(wall, [(origin, opacity)]), front, [view], share)[view.name]
        assert mask.dtype == bool and mask.shape == (cam.height, cam.width)
        assert mask[cy, cx] == centre, (opacity, share)
        assert not mask[0, 0] and not mask[-1, -1]  # the wall's corners: nothing removed there
    # the wall itself removed: what the front Gaussian does not cover is to be filled
    mask = fill_masks(wall_model(wall, [(origin, 0.8)]), ~front, [view])[view.name]
    assert mask[0, 0] and mask[-1, -1] and not mask[cy, cx]


def test_a_removed_gaussian_hidden_behind_a_kept_one_leaves_nothing_to_fill(wall_case):
    view, wall, ahead = wall_case
    cam = view.camera
    m = wall_model(wall, [(np.zeros(3), 0.99), (0.4 * ahead, 0.99)])  # kept in front, removed right behind it
    removed = torch.zeros(len(m), dtype=torch.bool)
    removed[-1] = True
    assert not fill_masks(m, removed, [view])[view.name][cam.height // 2, cam.width // 2]
    removed = torch.zeros(len(m), dtype=torch.bool)
    removed[-2] = True  # the front one removed instead
    assert fill_masks(m, removed, [view])[view.name][cam.height // 2, cam.width // 2]


# --- loading a distillation output ------------------------------------------------------------------


def test_load_field_checks_the_folder_against_the_scene(blobs, tmp_path):
    from object_fields import write_field

    from inpaint360gs.remove.stage import load_field

    scene, _, _, field = blobs
    folder = write_field(tmp_path / "d", field, scene)
    got = load_field(folder, scene)
    assert got.object_ids == IDS and torch.equal(got.gaussians.features, field.gaussians.features)
    rep = json.loads((folder / "distill.json").read_text())
    (folder / "distill.json").write_text(json.dumps({**rep, "inputs": {**rep["inputs"], "scene_content_sha256": "0" * 64}}))
    with pytest.raises(InputError, match=f"made from scene .*, but {scene.root} has content"):
        load_field(folder, scene)
    (folder / "distill.json").write_text(json.dumps({**rep, "inputs": {**rep["inputs"], "resize": 2}}))
    with pytest.raises(InputError, match="made at --resize 2, but this stage runs at --resize 1"):
        load_field(folder, scene)  # docs/architecture.md, "Provenance chain"
    (folder / "distill.json").write_text(json.dumps({**rep, "num_gaussians": 5}))
    with pytest.raises(InputError, match=f"holds {len(field.gaussians)} Gaussians but distill.json records 5"):
        load_field(folder, scene)
    (folder / "distill.json").unlink()  # a folder without its report: loaded as it is
    assert len(load_field(folder, scene).gaussians) == len(field.gaussians)


# --- the stage --------------------------------------------------------------------------------------


def test_remove_stage_outputs(blobs, tmp_path):
    scene, model, labels, field = blobs
    v = scene.train_views[3]
    click = Click(v.name, *centre_pixel(v.camera, BLOB_CENTRES[3]))
    cfg = RemovalConfig(footprint_margin=None)  # the object's own Gaussians only (the footprint column: its own test)
    info = remove_stage(scene, field, tmp_path / "rem", clicks=[click], ids=[3], cfg=cfg, meta={"scene": "s"})
    out = tmp_path / "rem"
    assert sorted(p.name for p in out.iterdir()) == ["masks", "point_cloud.ply", "removal.json", "removed.ply", "removed_index.npy"]
    blob = (labels == 1).numpy()  # blob 1 = object 3: exactly its Gaussians (the floor lies below its hull)
    assert np.array_equal(np.load(out / "removed_index.npy"), np.flatnonzero(blob))
    kept, removed = read_ply(out / "point_cloud.ply"), read_ply(out / "removed.ply")
    assert len(kept) == (~blob).sum() and torch.equal(kept.means, model.means[~torch.from_numpy(blob)])
    assert torch.equal(removed.features, field.gaussians.features[torch.from_numpy(blob)])
    assert sorted(p.name for p in (out / "masks").iterdir()) == sorted(f"{w.stem}.png" for w in scene.train_views)
    pct = []
    for w in scene.train_views:
        m = read_mask(out / "masks" / f"{w.stem}.png") > 127
        truth = true_ids(model, labels, w.camera) == 3
        assert truth.sum() > 10 and (m & truth).sum() / (m | truth).sum() > 0.9, w.name
        pct.append(100 * m.mean())
    rec = json.loads((out / "removal.json").read_text())
    assert rec == info
    assert rec["scene"] == "s" and rec["objects"] == [3] and rec["clicks"] == [str(click)]  # the click and the id: one object
    assert rec["removed_gaussians"] == blob.sum() and rec["kept_gaussians"] == (~blob).sum()
    assert abs(rec["amcr_percent"] - np.mean(pct)) < 1e-6
    # without a footprint column the removal is the object as it stands: its masks over the object's, exactly 1
    over = rec["over_removal"]
    assert over["ratio"] == 1.0 and over["removed_pixels"] == round(sum(pct) / 100 * m.size) == over["standing_pixels"]
    # same inputs, same bytes
    remove_stage(scene, field, tmp_path / "again", clicks=[click], ids=[3], cfg=cfg)
    for name in ["point_cloud.ply", "removed.ply", "removed_index.npy", *(f"masks/{w.stem}.png" for w in scene.train_views)]:
        assert (out / name).read_bytes() == (tmp_path / "again" / name).read_bytes(), name
    # an existing output is kept unless overwrite
    before = (out / "removal.json").read_bytes()
    with pytest.raises(InputError, match="not empty"):
        remove_stage(scene, field, out, ids=[7])
    assert (out / "removal.json").read_bytes() == before
    remove_stage(scene, field, out, ids=[7], overwrite=True)
    assert json.loads((out / "removal.json").read_text())["objects"] == [7]


def test_object_body_keeps_sparse_parts_inside_the_body_and_drops_far_strays():
    """A sparsely reconstructed part of the object (split off the linking graph, within the body's
    grown bounding box) stays with the body; a stray cluster elsewhere in the scene does not."""

    g = np.arange(0.0, 1.0001, 0.05)
    dense = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3)  # the body: spacing 0.05, linked within 0.2
    cap = np.array([[0.5, 0.5, 1.22], [0.1, 0.9, 1.23], [0.9, 0.1, 1.22]])  # isolated pieces 0.22 above it
    stray = 5.0 + np.array([[0.0, 0.0, 0.0], [0.01, 0.0, 0.0], [0.0, 0.01, 0.0]])  # a small cluster far away
    pts = np.concatenate([dense, cap, stray])
    n = len(dense)
    body = object_body(pts, link=4.0, min_part=0.1, near=0.25)
    assert body[: n + 3].all() and not body[n + 3 :].any()
    # without the margin the cap goes with the strays (its pieces are far smaller than the body)
    assert not object_body(pts, link=4.0, min_part=0.1, near=0.0)[n : n + 3].any()


def test_removal_keeps_a_piece_under_the_body_within_half_its_size():
    """The removal's default margin: a sparse piece under the body at 0.35 x its height (a watering
    can's lower part split off the linking graph) belongs to the object; at 0.25 it would not."""

    g = np.arange(0.0, 1.0001, 0.05)
    dense = np.stack(np.meshgrid(g, g, g, indexing="ij"), -1).reshape(-1, 3)
    under = np.array([[0.5, 0.5, -0.35], [0.3, 0.6, -0.36], [0.7, 0.4, -0.35]])
    pts = np.concatenate([dense, under])
    n = len(dense)
    cfg = RemovalConfig()
    assert object_body(pts, cfg.link, cfg.min_part, cfg.body_margin)[n:].all()
    assert not object_body(pts, cfg.link, cfg.min_part, 0.25)[n:].any()


def test_leg_ends_hanging_below_the_object_go_with_it():
    """A leg: removed Gaussians from z = 0.3 up, background-labelled ones below it down to the floor
    (what the 2D masks lose near the floor). The steps down take the leg's end above the support
    guard band, not the floor, not a flat sheet beside the leg at the leg's own height, and nothing
    under a leg that ends high above the floor with a gap."""
    from inpaint360gs.remove.geometry import hanging_below

    up = np.array([0.0, 0.0, 1.0])
    leg = np.stack([np.zeros(40), np.zeros(40), np.linspace(0.02, 0.6, 40)], 1)  # spacing ~0.015
    sheet = np.stack([np.linspace(0.05, 0.5, 10), np.zeros(10), np.full(10, 0.3)], 1)  # beside the leg, level
    floor = np.stack([np.linspace(-0.5, 0.5, 20), np.full(20, 0.01), np.zeros(20)], 1)
    far = np.array([[2.0, 0.0, 0.5], [2.0, 0.0, 0.1]])  # a high removed point, and one far below it
    means = np.concatenate([leg, sheet, floor, far])
    heights = means[:, 2]
    removed = np.zeros(len(means), bool)
    removed[: 40][leg[:, 2] >= 0.3] = True
    removed[len(means) - 2] = True
    band = 0.016
    candidates = ~removed & (heights > band)
    out = hanging_below(means, heights, up, removed, candidates, r=0.02)
    leg_end = np.flatnonzero((np.arange(len(means)) < 40) & ~removed & (heights > band))
    assert out[leg_end].all() and len(leg_end) > 10
    assert not out[40:].any()  # sheet, floor, the point 0.4 below the high one
    assert not hanging_below(means, heights, up, removed, candidates, r=0.0).any()


def _hanging_below_reference(means, heights, up, removed, candidates, r):
    """hanging_below's growth one Gaussian at a time, by brute force (no k-d tree)."""
    flat = means - np.outer(means @ up, up)
    out = np.zeros(len(means), bool)
    cand = candidates & ~removed
    frontier = list(np.flatnonzero(removed))
    while frontier:
        reached = set()
        for f in frontier:
            d = np.sqrt(((flat - flat[f]) ** 2).sum(1))
            drop = heights[f] - heights
            reached |= set(np.flatnonzero(cand & ~out & (d <= r) & (drop >= d) & (drop > 0) & (drop <= 2 * r)).tolist())
        frontier = sorted(reached)
        out[frontier] = True
    return out


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_hanging_below_is_the_one_at_a_time_growth(seed):
    from inpaint360gs.remove.geometry import hanging_below

    rng = np.random.default_rng(seed)
    up = rng.normal(size=3)
    up /= np.linalg.norm(up)
    means = rng.random((600, 3)) * 0.3
    heights = means @ up
    removed = rng.random(600) < 0.05
    candidates = rng.random(600) < 0.7
    got = hanging_below(means, heights, up, removed, candidates, r=0.03)
    assert np.array_equal(got, _hanging_below_reference(means, heights, up, removed, candidates, 0.03)) and got.any()


def test_upright_tells_standing_shapes_from_splats_lying_in_the_plane():
    """Variance along the normal against the sum across it: a vertical needle and one tilted 30 deg
    from the normal are upright; one tilted 60 deg, a flat floor splat and a round one are not."""
    import math

    from inpaint360gs.remove.geometry import upright

    def tilted(deg):  # rotation about x by deg (w, x, y, z)
        h = math.radians(deg) / 2
        return [math.cos(h), math.sin(h), 0.0, 0.0]

    g = points_model(np.zeros((5, 3)))
    with torch.no_grad():
        g.log_scales[:] = torch.log(torch.tensor([[1e-3, 1e-3, 8e-3], [1e-3, 1e-3, 8e-3], [1e-3, 1e-3, 8e-3], [1e-2, 1e-2, 5e-4], [5e-3, 5e-3, 5e-3]]))
        g.quats[:] = torch.tensor([tilted(0), tilted(30), tilted(60), tilted(0), tilted(0)])
    assert upright(g, np.array([0.0, 0.0, 1.0])).tolist() == [True, True, False, False, False]
    assert upright(g, np.array([0.0, 1.0, 0.0])).tolist() == [False, False, True, False, False]  # another normal


def test_support_column_takes_upright_leg_ends_in_the_floor_band_not_the_floor():
    """A leg of object 3 down to z = 0.3, background-labelled below it to 0.02 (what the 2D masks lose
    to the floor), and in the guard band (|z| < 0.016) under it an upright needle (the leg's end on
    the floor) and a flat floor splat: the column takes the leg end and the needle, the floor stays."""
    leg = np.stack([np.zeros(40), np.zeros(40), np.linspace(0.02, 0.6, 40)], 1)
    needle = np.array([[0.0, 0.0, 0.008]])
    splat = np.array([[0.004, 0.0, 0.0]])
    floor = np.stack([np.linspace(-0.5, 0.5, 21), np.full(21, 0.3), np.zeros(21)], 1)
    field, part = hand_field([(leg[leg[:, 2] >= 0.3], 1), (leg[leg[:, 2] < 0.3], 0), (needle, 0), (splat, 0), (floor, 0)])
    with torch.no_grad():
        g = field.gaussians
        g.log_scales[part == 2] = torch.log(torch.tensor([1e-4, 1e-4, 4e-3]))
        g.log_scales[part == 3] = torch.log(torch.tensor([1e-2, 1e-2, 5e-4]))
    means = g.means.numpy().astype(np.float64)
    up = np.array([0.0, 0.0, 1.0])
    kw = dict(heights=means[:, 2], radius=2.0, up=up)  # band 0.008 R = 0.016, column steps 0.01 R = 0.02
    removed = remove_objects(field, [3], RemovalConfig(hull=False, support_column=0.01), **kw).removed_mask.numpy()
    assert removed[part <= 2].all()
    assert not removed[part >= 3].any()
    # the needle as a flat splat: the band keeps it
    with torch.no_grad():
        g.log_scales[part == 2] = torch.log(torch.tensor([4e-3, 4e-3, 1e-4]))
    removed = remove_objects(field, [3], RemovalConfig(hull=False, support_column=0.01), **kw).removed_mask.numpy()
    assert removed[part <= 1].all() and not removed[part >= 2].any()


def test_support_column_is_on_by_default_and_turned_off_by_the_cli(tmp_path):
    """The third removal step is on at 0.01 in RemovalConfig and in `inpaint360gs remove`;
    `--no-support-column` turns it off (the authors' code), `--support-column R` sets R,
    a value outside (0, 1] is refused, and the two flags exclude each other."""
    import argparse

    from inpaint360gs.cli.remove import add_arguments

    assert RemovalConfig().support_column == 0.01
    parser = argparse.ArgumentParser()
    add_arguments(parser)
    base = [str(tmp_path), str(tmp_path), str(tmp_path / "out")]
    assert parser.parse_args(base).support_column == 0.01
    assert parser.parse_args(base + ["--no-support-column"]).support_column is None
    assert parser.parse_args(base + ["--support-column"]).support_column == 0.01
    assert parser.parse_args(base + ["--support-column", "0.02"]).support_column == 0.02
    with pytest.raises(SystemExit):
        parser.parse_args(base + ["--support-column", "0.02", "--no-support-column"])
    with pytest.raises(SystemExit):
        parser.parse_args(base + ["--support-column", "1.5"])


def test_footprint_column_takes_what_stands_on_the_object_s_footprint_and_the_contact_region():
    """An object (a box 0.5 x 0.5 x 0.45 on the floor z = 0) whose dark underside near the floor and
    the floor under it the field calls background (as on real photos: tracks, the contact print),
    faint floaters over it with no opinion, another object poking into its column, and a patch of
    floor beside it that the field took for the object. The footprint column takes the box, its
    underside, the floor under it and within the margin, and the floaters; the other object, the
    mistaken floor patch and the floor beyond the margin stay; nothing is left standing there. Low
    parts of the object beside it (a bucket's teeth, within the support band) go with it."""
    from inpaint360gs.core.support import object_footprint
    from inpaint360gs.metrics.capture import standing_share

    rng = np.random.default_rng(5)
    g = np.linspace(-1.0, 1.0, 81)  # floor spacing 0.025
    fx, fy = np.meshgrid(g, g)
    floor = np.stack([fx.ravel(), fy.ravel(), rng.normal(0, 0.002, fx.size)], 1)
    under_box = (np.abs(floor[:, 0]) <= 0.25) & (np.abs(floor[:, 1]) <= 0.25)
    beside = (floor[:, 0] > 0.45) & (floor[:, 0] < 0.6) & (np.abs(floor[:, 1]) < 0.1)  # taken for the object
    box = np.c_[rng.uniform(-0.25, 0.25, (800, 2)), rng.uniform(0.05, 0.5, 800)]
    underside = np.c_[rng.uniform(-0.24, 0.24, (60, 2)), rng.uniform(0.01, 0.045, 60)]
    floaters = np.c_[rng.uniform(-0.2, 0.2, (20, 2)), rng.uniform(0.55, 0.8, 20)]
    other = ball(rng, 40, 0.05, (0.2, 0.2, 0.3))
    teeth = np.c_[rng.uniform(0.26, 0.3, (30, 1)), rng.uniform(-0.2, 0.2, (30, 1)), rng.uniform(0.004, 0.02, 30)]  # low, beside the box
    parts = [(floor[~under_box & ~beside], 0), (floor[under_box], 0), (floor[beside], 1), (box, 1), (underside, 0), (floaters, -1), (other, 2), (teeth, 1)]
    field, part = hand_field(parts)
    up = np.array([0.0, 0.0, 1.0])
    res = remove_objects(field, [3], RemovalConfig(hull=False), up=up)
    removed = res.removed_mask.numpy()
    assert removed[np.isin(part, [1, 3, 4, 5, 7])].all()  # under the box, the box, its underside, the floaters, its low teeth
    assert not removed[np.isin(part, [2, 6])].any()  # the floor patch taken for the object, the other object
    fp = res.footprints[0]
    assert abs(fp.height - 0.5) < 0.01 and np.allclose(fp.normal, up, atol=0.01) and abs(fp.size - 0.5) < 0.02
    margin = RemovalConfig().footprint_margin * fp.size
    floor_removed = removed[part == 0]
    d = fp.distance(floor[~under_box & ~beside])
    assert floor_removed[d <= margin - 1e-6].all() and not floor_removed[d > margin + 1e-6].any()
    kept = res.kept
    _, standing = standing_share(kept.means.double().numpy(), kept.opacities.double().numpy(), object_footprint(box, np.ones(len(box)), floor, np.ones(len(floor)), up))
    assert standing == len(other)  # what stands there is the other object alone
    # the object as it stands (what the removal's masks are measured against): the box, not the low parts nor any floor
    st = res.standing_mask.numpy()
    assert st[part == 3].mean() > 0.99 and not st[np.isin(part, [0, 1, 2, 4, 5, 6, 7])].any()
    # without the step the underside, the floor under the box and the floaters stay
    off = remove_objects(field, [3], RemovalConfig(hull=False, footprint_margin=None), up=up).removed_mask.numpy()
    assert not off[np.isin(part, [1, 4, 5])].any() and off[part == 2].any()


def test_footprint_column_tells_a_flat_part_of_the_object_from_support_taken_for_it_by_colour():
    """Two low selected patches far from a box's outline (beyond the support reach): a flat red part
    of the object (a cone's base) and a patch of the grey floor the field took for the object. The
    floor's colour around the footprint decides: the red part goes with the object, the grey patch
    stays, and the footprint the inpainting fills widens to the red part; with every colour alike,
    both would stay."""
    from inpaint360gs.core.gaussians import SH_C0

    rng = np.random.default_rng(6)
    floor = _grid_floor(rng)
    beside = (floor[:, 0] > 0.45) & (floor[:, 0] < 0.6) & (np.abs(floor[:, 1]) < 0.1)
    box = np.c_[rng.uniform(-0.25, 0.25, (800, 2)), rng.uniform(0.05, 0.5, 800)]
    base = np.c_[rng.uniform(-0.5, -0.4, (60, 1)), rng.uniform(-0.2, 0.2, (60, 1)), rng.uniform(0.004, 0.02, 60)]
    field, part = hand_field([(floor[~beside], 0), (floor[beside], 1), (box, 1), (base, 1)])
    colours = np.clip(0.5 + rng.normal(0, 0.04, (len(part), 3)), 0, 1)  # grey floor with some texture
    colours[part == 3] = (0.8, 0.1, 0.1)
    with torch.no_grad():
        field.gaussians.sh0[:, 0] = torch.tensor((colours - 0.5) / SH_C0, dtype=torch.float32)
    up = np.array([0.0, 0.0, 1.0])
    res = remove_objects(field, [3], RemovalConfig(hull=False), up=up)
    removed = res.removed_mask.numpy()
    assert removed[part == 3].all() and removed[part == 2].all()
    assert not removed[part == 1].any()
    assert res.counts["footprint"][0]["support_kept"] > 0  # the grey patch's part the selection took
    # the recorded footprint (what the inpainting fills on the support) widens to the red part, not to the grey patch
    fp = res.footprints[0]
    assert (fp.distance(base) <= 1e-9).mean() >= 0.95 and (fp.distance(floor[beside]) > 0.1).all()
    assert abs(fp.height - 0.5) < 0.01
    field.gaussians.sh0[:, 0] = 0.0  # every colour alike: the red part would count as support too
    alike = remove_objects(field, [3], RemovalConfig(hull=False), up=up)
    assert not alike.removed_mask.numpy()[part == 3].all()
    assert abs(alike.footprints[0].size - 0.5) < 0.02  # and the footprint is the box's alone


def test_footprint_column_keeps_the_support_the_views_see_under_the_plane_and_takes_the_dark_underside():
    """A plain sheet gives 3DGS no depth: part of it lies below the support plane, under the object
    and around it. Under the plane in the column, what the views see beside the object's silhouette
    in the sheet's colours is the sheet placed too deep and stays; the dark underside goes, and so
    does sheet-coloured stuff inside the silhouette in the views (only the hole shows it). Without a
    silhouette test (no views), everything under the plane goes."""
    from inpaint360gs.remove.geometry import footprint_columns

    rng = np.random.default_rng(8)
    floor = _grid_floor(rng)
    floor = floor[(np.abs(floor[:, 0]) > 0.3) | (np.abs(floor[:, 1]) > 0.3)]
    box = np.c_[rng.uniform(-0.25, 0.25, (800, 2)), rng.uniform(0.05, 0.5, 800)]
    deep_seen = np.c_[rng.uniform(0.15, 0.25, (40, 1)), rng.uniform(-0.25, 0.25, (40, 1)), rng.uniform(-0.15, -0.04, 40)]
    deep_hidden = np.c_[rng.uniform(-0.1, 0.1, (40, 2)), rng.uniform(-0.15, -0.04, 40)]
    deep_dark = np.c_[rng.uniform(0.15, 0.22, (40, 1)), rng.uniform(-0.22, 0.22, (40, 1)), rng.uniform(-0.15, -0.04, 40)]
    means = np.concatenate([floor, box, deep_seen, deep_hidden, deep_dark])
    part = np.repeat([0, 1, 2, 3, 4], [len(floor), len(box), 40, 40, 40])
    colours = np.clip(0.85 + rng.normal(0, 0.02, (len(means), 3)), 0, 1)  # an off-white sheet
    colours[part == 1] = (0.3, 0.2, 0.1)
    colours[np.isin(part, [2, 3])] = 0.85 + rng.normal(0, 0.003, (80, 3))  # the sheet's colour
    colours[part == 4] = (0.1, 0.08, 0.07)
    body = part == 1

    def share(indices, body_):  # the views see the deep Gaussians near the box's side beside it, those under its middle in it
        return np.where(np.isin(part[indices], [2, 4]), 0.2, 1.0)

    up = np.array([0.0, 0.0, 1.0])
    opac = np.full(len(means), 0.9)
    counts = {}
    out, _ = footprint_columns(means, opac, body.copy(), [body], np.zeros_like(body), up, RemovalConfig(), counts, colours, share)
    assert out[np.isin(part, [1, 3, 4])].all()  # the box, the sheet only the hole shows, the dark underside
    assert not out[part == 2].any() and not out[part == 0].any()
    assert counts["footprint"][0]["support_beside_under_plane"] == 40
    out, _ = footprint_columns(means, opac, body.copy(), [body], np.zeros_like(body), up, RemovalConfig(), {}, colours)
    assert out[np.isin(part, [1, 2, 3, 4])].all()


def test_footprint_column_keeps_sheet_under_the_plane_that_a_quarter_of_the_views_see_beside_the_object():
    """A plain sheet's Gaussians under the plane behind the object's base lie in its silhouette in
    most views and beside it in the rest (a low view sees them in front of the base). On and under
    the plane nothing of the object is, so one that more than a quarter of the views see beside it
    (``RemovalConfig.plane_silhouette``) in the sheet's colours stays; one seen beside it in fewer
    goes. Over the object's top the test stays at half (``column_silhouette``): a faint Gaussian
    there in the silhouette of 60 % of the views is the object's appearance and goes."""
    from inpaint360gs.remove.geometry import footprint_columns

    rng = np.random.default_rng(18)
    floor = _grid_floor(rng)
    floor = floor[(np.abs(floor[:, 0]) > 0.3) | (np.abs(floor[:, 1]) > 0.3)]
    box = np.c_[rng.uniform(-0.25, 0.25, (800, 2)), rng.uniform(0.05, 0.5, 800)]
    often = np.c_[rng.uniform(0.15, 0.25, (40, 1)), rng.uniform(-0.25, 0.25, (40, 1)), rng.uniform(-0.15, -0.04, 40)]
    rarely = np.c_[rng.uniform(-0.25, -0.15, (40, 1)), rng.uniform(-0.25, 0.25, (40, 1)), rng.uniform(-0.15, -0.04, 40)]
    top = np.c_[rng.uniform(-0.1, 0.1, (20, 2)), rng.uniform(0.52, 0.6, 20)]
    means = np.concatenate([floor, box, often, rarely, top])
    part = np.repeat([0, 1, 2, 3, 4], [len(floor), len(box), 40, 40, 20])
    colours = np.clip(0.85 + rng.normal(0, 0.02, (len(means), 3)), 0, 1)  # an off-white sheet
    colours[np.isin(part, [1, 4])] = (0.3, 0.2, 0.1)
    colours[np.isin(part, [2, 3])] = 0.85 + rng.normal(0, 0.003, (80, 3))  # the sheet's colour
    body = part == 1
    in_silhouette = {2: 0.6, 3: 0.85, 4: 0.6}

    def share(indices, body_):
        return np.array([in_silhouette.get(int(p), 1.0) for p in part[indices]])

    up = np.array([0.0, 0.0, 1.0])
    opac = np.full(len(means), 0.9)
    counts = {}
    out, _ = footprint_columns(means, opac, body.copy(), [body], np.zeros_like(body), up, RemovalConfig(), counts, colours, share)
    assert out[np.isin(part, [1, 3, 4])].all()  # the box, sheet only a few views see beside it, the top's appearance
    assert not out[part == 2].any() and not out[part == 0].any()
    assert counts["footprint"][0]["support_beside_under_plane"] == 40
    # at the over-the-top test's half, the sheet seen beside the base in 40 % of the views would go
    out, _ = footprint_columns(means, opac, body.copy(), [body], np.zeros_like(body), up, RemovalConfig(plane_silhouette=0.5), {}, colours, share)
    assert out[part == 2].all()
    with pytest.raises(InputError, match="RemovalConfig.plane_silhouette"):
        RemovalConfig(plane_silhouette=1.5).validate()


def test_footprint_column_keeps_the_support_the_views_see_beside_the_object():
    """A box with a spout reaching over the floor: the outline on the plane covers floor under the
    spout that the photos see beside the object. On the plane, a Gaussian the selection did not
    take stays when the views see it off the object's silhouette and it has the floor's colours;
    the floor under the box (in the silhouette in every view) and a dark print beside it go."""
    from inpaint360gs.core.gaussians import SH_C0
    from inpaint360gs.remove.geometry import footprint_columns

    rng = np.random.default_rng(9)
    floor = _grid_floor(rng)
    box = np.c_[rng.uniform(-0.25, 0.25, (800, 2)), rng.uniform(0.05, 0.5, 800)]
    spout = np.c_[rng.uniform(0.25, 0.45, (80, 1)), rng.uniform(-0.05, 0.05, (80, 1)), rng.uniform(0.25, 0.3, 80)]
    means = np.concatenate([floor, box, spout])
    part = np.repeat([0, 1, 2], [len(floor), len(box), len(spout)])
    under_spout = (part == 0) & (means[:, 0] > 0.3) & (means[:, 0] < 0.45) & (np.abs(means[:, 1]) < 0.05)
    under_box = (part == 0) & (np.abs(means[:, 0]) < 0.24) & (np.abs(means[:, 1]) < 0.24)
    print_ = under_spout & (means[:, 0] < 0.35)  # a dark print beside the box, under the spout's root
    colours = np.clip(0.6 + rng.normal(0, 0.03, (len(means), 3)), 0, 1)
    colours[part > 0] = (0.9, 0.9, 0.95)
    colours[print_] = (0.15, 0.12, 0.1)
    colours[under_spout & ~print_] = 0.6 + rng.normal(0, 0.005, (int((under_spout & ~print_).sum()), 3))  # the floor's colour (the colour test leaves out its tenth farthest from the rest)
    body = part > 0

    def share(indices, body_):  # the views see the floor under the spout beside the silhouette, the floor under the box in it
        return np.where(under_spout[indices], 0.2, 1.0)

    up = np.array([0.0, 0.0, 1.0])
    counts = {}
    out, _ = footprint_columns(means, np.full(len(means), 0.9), body.copy(), [body], np.zeros_like(body), up, RemovalConfig(), counts, colours, share)
    assert out[body].all() and out[under_box].all() and out[print_].all()
    assert not out[under_spout & ~print_].any()
    assert counts["footprint"][0]["support_beside"] == int((under_spout & ~print_).sum())
    # without the silhouette test the column takes the floor under the spout
    out, _ = footprint_columns(means, np.full(len(means), 0.9), body.copy(), [body], np.zeros_like(body), up, RemovalConfig(), {}, colours)
    assert out[under_spout].all()


def test_footprint_column_gives_back_the_support_the_selection_took_beside_the_object():
    """The object field takes a strip of the floor in front of a box with the box (the selection's
    own low Gaussians, within reach of the outline). The views see that strip beside the box
    standing above the plane, and it has the floor's colours: it stays. A dark contact shadow the
    selection took there goes with the box. The silhouette the test reads is the box's above the
    plane: a strip of floor is in its own silhouette in every view."""
    from inpaint360gs.remove.geometry import footprint_columns

    rng = np.random.default_rng(10)
    floor = _grid_floor(rng)
    floor = floor[~((floor[:, 0] > -0.3) & (floor[:, 0] < 0.37) & (np.abs(floor[:, 1]) < 0.3))]
    box = np.c_[rng.uniform(-0.25, 0.25, (800, 2)), rng.uniform(0.05, 0.5, 800)]
    strip = np.c_[rng.uniform(0.29, 0.36, (60, 1)), rng.uniform(-0.25, 0.25, (60, 1)), rng.normal(0, 0.002, 60)]
    shadow = np.c_[rng.uniform(0.255, 0.28, (30, 1)), rng.uniform(-0.25, 0.25, (30, 1)), rng.normal(0, 0.002, 30)]
    means = np.concatenate([floor, box, strip, shadow])
    part = np.repeat([0, 1, 2, 3], [len(floor), len(box), len(strip), len(shadow)])
    colours = np.clip(0.6 + rng.normal(0, 0.03, (len(means), 3)), 0, 1)
    colours[part == 1] = (0.9, 0.8, 0.1)
    colours[part == 2] = 0.6 + rng.normal(0, 0.005, (60, 3))  # the floor's colour
    colours[part == 3] = (0.1, 0.08, 0.07)
    body = part > 0  # the selection: the box, the strip and the shadow

    def share(indices, body_):  # seen from above: in the silhouette where the given body covers the floor
        x = means[body_, 0]
        return np.where((means[indices, 0] >= x.min() - 0.01) & (means[indices, 0] <= x.max() + 0.01), 1.0, 0.2)

    up = np.array([0.0, 0.0, 1.0])
    counts = {}
    out, _ = footprint_columns(means, np.full(len(means), 0.9), body.copy(), [body], np.zeros_like(body), up, RemovalConfig(), counts, colours, share)
    assert out[part == 1].all() and out[part == 3].all()
    assert not out[part == 2].any() and not out[part == 0].any()
    assert counts["footprint"][0]["support_beside"] == 60
    # without the silhouette test the strip goes with the box
    out, _ = footprint_columns(means, np.full(len(means), 0.9), body.copy(), [body], np.zeros_like(body), up, RemovalConfig(), {}, colours)
    assert out[part == 2].all()


def test_stray_gaussians_over_the_support_neither_widen_the_outline_nor_go_when_the_views_see_them_beside_the_object():
    """The object field labels a scatter of Gaussians a little over the floor around a box as the
    box (3DGS puts such Gaussians over a placemat). They stand higher than a tenth of the box's
    height, so before, the outline was their convex hull, and the column took the floor under all of
    it. Now the outline is the box's body (a scatter several spacings apart is not linked to it), the
    floor around the box stays, and the strays seen beside the box in the floor's colours stay too;
    strays in the box's colours (a sparse part of the object) go with it."""
    from inpaint360gs.core.support import object_footprint
    from inpaint360gs.remove.geometry import footprint_columns

    rng = np.random.default_rng(11)
    floor = _grid_floor(rng)
    box = np.c_[rng.uniform(-0.25, 0.25, (3000, 2)), rng.uniform(0.0, 0.5, 3000)]
    ang = rng.uniform(0, 2 * np.pi, 40)
    rad = rng.uniform(0.45, 0.7, 40)
    strays = np.c_[rad * np.cos(ang), rad * np.sin(ang), rng.uniform(0.06, 0.15, 40)]
    means = np.concatenate([floor, box, strays])
    part = np.repeat([0, 1, 2], [len(floor), len(box), len(strays)])
    colours = np.clip(0.6 + rng.normal(0, 0.03, (len(means), 3)), 0, 1)
    colours[part == 1] = (0.9, 0.8, 0.1)
    colours[part == 2] = 0.6 + rng.normal(0, 0.005, (40, 3))  # the floor's colour
    body = part > 0
    up = np.array([0.0, 0.0, 1.0])

    fp = object_footprint(means[body], np.full(body.sum(), 0.9), means[~body], np.full((~body).sum(), 0.9), up)
    assert fp.size == pytest.approx(0.5, rel=0.1)  # the box's 0.5 x 0.5, not the strays' 1.3-wide ring
    assert (fp.distance(means[part == 2]) > 0.1 * fp.size).all()

    def share(indices, body_):  # seen from above: in the silhouette where the given body covers the point
        xy = means[body_, :2]
        lo, hi = xy.min(0) - 0.01, xy.max(0) + 0.01
        return np.where(((means[indices, :2] >= lo) & (means[indices, :2] <= hi)).all(1), 1.0, 0.0)

    under_strays = (part == 0) & (np.linalg.norm(means[:, :2], axis=1) > 0.4)
    counts = {}
    out, _ = footprint_columns(means, np.full(len(means), 0.9), body.copy(), [body], np.zeros_like(body), up, RemovalConfig(), counts, colours, share)
    assert out[part == 1].all()
    assert not out[part == 2].any() and not out[under_strays].any()
    assert counts["footprint"][0]["apart"] == 40 and counts["footprint"][0]["support_beside_apart"] == 40
    # in the box's colours they are the box's own sparse parts: they go
    colours[part == 2] = (0.9, 0.8, 0.1)
    out, _ = footprint_columns(means, np.full(len(means), 0.9), body.copy(), [body], np.zeros_like(body), up, RemovalConfig(), {}, colours, share)
    assert out[part == 2].all() and not out[under_strays].any()


def test_the_objects_low_parts_the_field_gave_to_the_background_go_and_the_support_around_them_stays():
    """A yellow box on a textured pink floor; the field gives the box's yellow teeth, lying on the
    floor in front of it, to the background. They are low, linked to the box and nearer the box's
    colour than the floor's (in chromaticity: the teeth are lit, the box's lower side in shade):
    they go with the box (``RemovalConfig.low_parts``). The floor around them, however textured,
    and a yellow patch on the floor not linked to the box stay; with ``low_parts=None`` the teeth
    stay."""
    from inpaint360gs.remove.geometry import chromaticity, footprint_columns, nearer_object

    rng = np.random.default_rng(12)
    floor = _grid_floor(rng)
    box = np.c_[rng.uniform(-0.25, 0.25, (3000, 2)), rng.uniform(0.0, 0.5, 3000)]
    teeth = np.c_[rng.uniform(0.26, 0.34, (40, 1)), rng.uniform(-0.2, 0.2, (40, 1)), rng.uniform(0.005, 0.02, 40)]
    patch = np.c_[rng.uniform(-0.75, -0.7, (20, 1)), rng.uniform(-0.1, 0.1, (20, 1)), rng.uniform(0.005, 0.02, 20)]
    means = np.concatenate([floor, box, teeth, patch])
    part = np.repeat([0, 1, 2, 3], [len(floor), len(box), len(teeth), len(patch)])
    colours = np.clip(np.array([0.85, 0.62, 0.57]) * rng.uniform(0.6, 1.2, (len(means), 1)), 0, 1)  # a pink floor, lit and shaded
    colours[part == 1] = np.array([0.55, 0.37, 0.02]) * rng.uniform(0.8, 1.6, (3000, 1))  # the box, its lower side in shade
    colours[part >= 2] = (0.9, 0.77, 0.05)
    colours = colours.clip(0, 1)
    assert np.allclose(chromaticity(np.array([[0.6, 0.4, 0.2]])), chromaticity(np.array([[0.3, 0.2, 0.1]])), atol=0.05)  # lit and shaded
    body = part == 1
    up = np.array([0.0, 0.0, 1.0])

    def share(indices, body_):  # seen from above: in the silhouette where the given body covers the point
        xy = means[body_, :2]
        lo, hi = xy.min(0) - 0.01, xy.max(0) + 0.01
        return np.where(((means[indices, :2] >= lo) & (means[indices, :2] <= hi)).all(1), 1.0, 0.0)

    near_teeth = (part == 0) & (means[:, 0] > 0.3) & (np.abs(means[:, 1]) < 0.3)
    counts = {}
    out, _ = footprint_columns(means, np.full(len(means), 0.9), body.copy(), [body], np.zeros_like(body), up, RemovalConfig(), counts, colours, share)
    assert out[part == 1].all() and out[part == 2].all()
    assert not out[part == 3].any() and not out[near_teeth & (means[:, 0] > 0.4)].any()
    assert counts["footprint"][0]["low_parts"] >= 30
    counts = {}
    out, _ = footprint_columns(means, np.full(len(means), 0.9), body.copy(), [body], np.zeros_like(body), up, RemovalConfig(low_parts=None), counts, colours, share)
    assert counts["footprint"][0]["low_parts"] == 0 and out[part == 2].sum() < 20  # only the teeth in the column go
    # in chromaticity the floor's shaded pink is the floor's, the lit teeth the box's
    pos = np.array([[0.5, 0.0, 0.0], [0.3, 0.0, 0.01]])
    cand = np.array([[0.85, 0.62, 0.57], [0.9, 0.77, 0.05]]) * 0.5
    ring = ~body & (part == 0) & (np.linalg.norm(means[:, :2], axis=1) > 0.3)
    assert nearer_object(pos, cand, means[ring], colours[ring], means[body], colours[body]).tolist() == [False, True]


def _grid_floor(rng: np.random.Generator) -> np.ndarray:
    """A floor of Gaussian centres on the plane z = 0: an 81 x 81 grid over [-1, 1]^2, 2 mm of noise in z."""
    g = np.linspace(-1.0, 1.0, 81)
    fx, fy = np.meshgrid(g, g)
    return np.stack([fx.ravel(), fy.ravel(), rng.normal(0, 0.002, fx.size)], 1)
