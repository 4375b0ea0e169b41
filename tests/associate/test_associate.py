"""Key Object Management association (paper Sec. 3.2, Eq. 2): the K-Means depth split, GS-IoU,
and view-consistent ids from per-view segments whose ids do not agree."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from inpaint360gs.core.errors import InputError
from inpaint360gs.io.scene import load_scene
from inpaint360gs.render.api import render
from inpaint360gs.associate import AssociationConfig, associate
from inpaint360gs.associate.kom import gs_iou, near_cluster


def test_near_cluster_is_the_exact_two_means_split_per_group():
    groups = np.array([0, 0, 0, 0, 0, 1, 1, 1, 2])
    depth = np.array([5.0, 1.0, 1.2, 5.1, 1.1, 3.0, 3.1, 9.0, 7.0])
    near = near_cluster(groups, depth)
    assert near.tolist() == [False, True, True, False, True, True, True, False, True]
    # keep the nearest 30% of the near cluster (at least one): group 0 keeps depth 1.0 only
    near = near_cluster(groups, depth, keep_near=0.3)
    assert near.tolist() == [False, True, False, False, False, True, False, False, True]


def test_near_cluster_matches_brute_force_kmeans():
    rng = np.random.default_rng(0)
    for _ in range(50):
        z = np.sort(rng.gamma(2.0, 1.0, size=rng.integers(2, 12)))
        best = min(range(1, len(z)), key=lambda k: ((z[:k] - z[:k].mean()) ** 2).sum() + ((z[k:] - z[k:].mean()) ** 2).sum())
        got = near_cluster(np.zeros(len(z), dtype=int), rng.permutation(z))
        assert got.sum() == best


def test_gs_iou_plain_and_public_code_variant():
    db = np.zeros((2, 10), dtype=bool)
    db[0, [0, 1, 2, 3]] = True
    db[1, [8, 9]] = True
    sizes = db.sum(1).astype(float)
    members = np.array([2, 3, 4, 5])
    np.testing.assert_allclose(gs_iou(db, sizes, members, "paper"), [2 / 6, 0.0])
    np.testing.assert_allclose(gs_iou(db, sizes, members, "code"), [2 / (4 + 2), 0.0])


def _true_labels(scene, model, labels):
    """The true object label of every pixel of every training view (one-hot labels rendered)."""
    g = model.map(lambda t: t)
    g.features = torch.nn.functional.one_hot(labels, 3).float()
    truth = {}
    for v in scene.train_views:
        with torch.no_grad():
            out = render(g, v.camera, with_features=True)
        lab = out.features.argmax(-1).numpy()
        lab[out.features.max(-1).values.numpy() < 0.5 * out.alpha.numpy()] = 0
        truth[v.name] = lab
    return truth


def _segments(truth, rng, split=False):
    """Per-view segment images of the true labels with ids shuffled per view (like a 2D segmenter);
    ``split``: blob 1 cut in two segments in every other view (over-segmentation)."""
    segs = {}
    for k, (name, lab) in enumerate(truth.items()):
        ids = rng.permutation(np.arange(1, 50))[:3]
        seg = np.zeros(lab.shape, np.uint16)
        seg[lab == 1], seg[lab == 2] = ids[0], ids[1]
        cols = np.nonzero((lab == 1).any(0))[0]
        if split and k % 2 and len(cols) > 4:
            seg[:, cols[len(cols) // 2] :][lab[:, cols[len(cols) // 2] :] == 1] = ids[2]
        segs[name] = seg
    return segs


@pytest.fixture(scope="module")
def blobs(make_blobs_scene):
    root, model, labels = make_blobs_scene("assoc")
    scene = load_scene(root)
    return scene, model, _true_labels(scene, model, labels)


@pytest.mark.parametrize("split", [False, True])
def test_kom_gives_each_object_one_id_in_every_view(blobs, split):
    scene, model, truth = blobs
    segs = _segments(truth, np.random.default_rng(1), split)
    res = associate(segs, scene, model)
    assert len(res.objects) == 2
    for obj in (1, 2):  # the same id covers the object in every view (a split half inherits the whole's id)
        seen = [n for n in truth if (truth[n] == obj).sum() > 20]
        ids = {int(np.bincount(res.masks[n][truth[n] == obj]).argmax()) for n in seen}
        assert len(ids) == 1 and 0 not in ids, (obj, ids)
        (oid,) = ids
        for n in seen:
            assert (res.masks[n][truth[n] == obj] == oid).mean() > 0.9, n
    for n in truth:  # background stays background
        assert (res.masks[n][truth[n] == 0] == 0).all()


def test_tracker_ablation_links_consecutive_views_by_2d_overlap(blobs):
    scene, model, truth = blobs
    segs = _segments(truth, np.random.default_rng(2))
    res = associate(segs, scene, model, AssociationConfig(method="tracker"))
    assert res.config.method == "tracker" and all(m.dtype == np.uint8 for m in res.masks.values())
    assert {o["id"] for o in res.objects} >= {1, 2}


def test_bad_inputs(blobs):
    scene, model, truth = blobs
    segs = _segments(truth, np.random.default_rng(3))
    first = scene.train_views[0].name
    with pytest.raises(InputError, match="no segments for training view"):
        associate({k: v for k, v in segs.items() if k != first}, scene, model)
    with pytest.raises(InputError, match="segments of view"):
        associate({**segs, first: segs[first][:-1]}, scene, model)
    far = model.map(lambda t: t)
    far.means = model.means + 100.0  # a model from somewhere else: no Gaussian in any view
    with pytest.raises(InputError, match="no segment covers any Gaussian"):
        associate(segs, scene, far)
    with pytest.raises(InputError, match="unknown association method"):
        associate(segs, scene, model, AssociationConfig(method="deva"))


def test_database_is_compared_through_what_the_view_can_label():
    """An object of 400 Gaussians segmented whole in the first view, then only as a 20 x 4 band (80
    of its Gaussians; the rest hidden or missed by the segmenter). Eq. 2 against the whole
    accumulated set scores 80 / 400 = 0.2, not above sigma: each band founds a new object.
    Compared through the Gaussians the view labels, the band inherits the object's id."""
    from inpaint360gs.core.camera import Camera
    from inpaint360gs.associate.kom import kom

    cam = Camera(R=torch.eye(3, dtype=torch.float64), t=torch.zeros(3, dtype=torch.float64), fx=50.0, fy=50.0, cx=0.0, cy=0.0, width=40, height=40)
    ys, xs = np.mgrid[10:30, 10:30].reshape(2, -1) + 0.5  # one Gaussian per pixel, the object at z ~ 1 ...
    z = 1.0 + 0.001 * np.random.default_rng(0).random(ys.size)
    near = np.stack([xs / cam.fx * z, ys / cam.fy * z, z], axis=1)
    far = np.stack([xs / cam.fx * 3.0, ys / cam.fy * 3.0, np.full(ys.size, 3.0)], axis=1)  # ... the wall behind it at z = 3
    means = np.concatenate([near, far])
    segs = []
    for band in (None, 0, 1, 2, 3):
        seg = np.zeros((40, 40), np.uint16)
        if band is None:
            seg[10:30, 10:30] = 7
        else:
            seg[10 + 5 * band : 14 + 5 * band, 10:30] = 3 + band  # 80 pixels
        segs.append(seg)
    cams = [cam] * len(segs)
    out, sizes = kom(segs, cams, means, AssociationConfig(compare="visible").resolved())
    assert len(sizes) == 1 and sizes[0] == 400 and all(set(np.unique(o)) == {0, 1} for o in out)
    out, sizes = kom(segs, cams, means, AssociationConfig(compare="all", part_share=0.0, merge_share=0.0).resolved())
    assert len(sizes) == 5  # the literal reading (and Alg. 1 alone): every band a new object
    out, sizes = kom(segs, cams, means, AssociationConfig(compare="all").resolved())
    assert len(sizes) == 1  # the literal reading with the part rule: each band lies inside the object's set
    with pytest.raises(InputError, match="comparison"):
        AssociationConfig(compare="nearest").resolved()


def _flat_scene(cols: tuple[int, int] = (10, 30)):
    """One Gaussian per pixel of rows/cols 10..29 at z ~ 1 and a wall behind at z = 3, seen by a
    40 x 40 camera; returns (camera, means)."""
    from inpaint360gs.core.camera import Camera

    cam = Camera(R=torch.eye(3, dtype=torch.float64), t=torch.zeros(3, dtype=torch.float64), fx=50.0, fy=50.0, cx=0.0, cy=0.0, width=40, height=40)
    ys, xs = np.mgrid[10:30, cols[0] : cols[1]].reshape(2, -1) + 0.5
    z = 1.0 + 0.001 * np.random.default_rng(0).random(ys.size)
    near = np.stack([xs / cam.fx * z, ys / cam.fy * z, z], axis=1)
    far = np.stack([xs / cam.fx * 3.0, ys / cam.fy * 3.0, np.full(ys.size, 3.0)], axis=1)
    return cam, np.concatenate([near, far])


def test_a_small_split_part_joins_its_object():
    """The object seen whole (400 Gaussians), then split by the segmenter into 360 + 40 pixels: the
    small part's GS-IoU is 40 / 400 = 0.1 < sigma, so Alg. 1 alone founds a second object for it;
    all of its Gaussians lie in the object's set, so the part rule gives it the object's id."""
    from inpaint360gs.associate.kom import kom

    cam, means = _flat_scene()
    whole = np.zeros((40, 40), np.uint16)
    whole[10:30, 10:30] = 4
    split = np.zeros((40, 40), np.uint16)
    split[10:28, 10:30] = 1
    split[28:30, 10:30] = 2
    out, sizes = kom([whole, split], [cam, cam], means, AssociationConfig().resolved())
    assert len(sizes) == 1 and (out[1][10:30, 10:30] == 1).all()
    out, sizes = kom([whole, split], [cam, cam], means, AssociationConfig(part_share=0.0).resolved())
    assert len(sizes) == 2 and (out[1][28:30, 10:30] == 2).all()


def _two_or_one_segment() -> tuple[np.ndarray, np.ndarray]:
    """Segments of :func:`_flat_scene`'s square: two (columns 10-19 and 20-29, ids 5 and 9), or one."""
    two = np.zeros((40, 40), np.uint16)
    two[10:30, 10:20] = 5
    two[10:30, 20:30] = 9
    one = np.zeros((40, 40), np.uint16)
    one[10:30, 10:30] = 2
    return two, one


def test_a_merged_segment_is_divided_between_the_objects():
    """Two objects side by side (columns 10-19 and 20-29), seen apart, then merged into one segment:
    its pixels go to the two ids by the Gaussians behind them and neither set takes the other's
    Gaussians. Without the rule the whole segment takes one id and that object's set swallows the
    other (the next view, apart again, then gives both objects that id)."""
    from inpaint360gs.associate.kom import kom

    cam, means = _flat_scene()
    apart, merged = _two_or_one_segment()
    segs, cams = [apart, merged, apart], [cam] * 3
    out, sizes = kom(segs, cams, means, AssociationConfig().resolved())
    assert len(sizes) == 2 and list(sizes) == [200, 200]
    for o in out:
        assert (o[10:30, 10:20] == 1).all() and (o[10:30, 20:30] == 2).all()
    out, sizes = kom(segs, cams, means, AssociationConfig(merge_share=0.0).resolved())
    assert (out[1][10:30, 10:30] == out[1][10, 10]).all()  # one id over both objects
    assert sizes.max() == 400


def test_pieces_founded_apart_are_joined_when_more_views_see_them_as_one():
    """The object's first view splits it in two halves, which found two objects (nothing to match yet);
    two later views see it whole, and each whole segment is divided between the two halves' sets.
    Two views segmented the pair as one, one as two: the halves are joined into one id in every view
    and their sets into one. Without the step the halves keep their two ids."""
    from inpaint360gs.associate.kom import kom

    cam, means = _flat_scene()
    halves, whole = _two_or_one_segment()
    segs, cams = [halves, whole, whole], [cam] * 3
    out, sizes = kom(segs, cams, means, AssociationConfig().resolved())
    assert list(sizes) == [400]
    assert all((o[10:30, 10:30] == 1).all() and (o > 0).sum() == 400 for o in out)
    out, sizes = kom(segs, cams, means, AssociationConfig(consolidate=False).resolved())
    assert list(sizes) == [200, 200] and (out[1][10:30, 10:20] == 1).all() and (out[1][10:30, 20:30] == 2).all()
    # seen as two in two views and as one in one (the merged-segment case): they stay two objects
    out, sizes = kom([halves, whole, halves], cams, means, AssociationConfig().resolved())
    assert list(sizes) == [200, 200] and (out[2][10:30, 20:30] == 2).all()
