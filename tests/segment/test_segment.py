"""The geometric segmenter and the segment stage on tiny hand-built Gaussian scenes: the frame and the
3D clusters (blobs, plate peeling), per-view ids that differ between views yet match the objects,
the stage's outputs, the CLI and its one-line errors."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest
import torch
from segment_scenes import best_iou, blob, build, cameras, disc, ground, plate_scene, true_labels, two_blobs, write_scene

from inpaint360gs.cli import main
from inpaint360gs.core.errors import InputError
from inpaint360gs.io.images import read_mask
from inpaint360gs.io.ply import write_ply
from inpaint360gs.io.scene import load_scene
from inpaint360gs.segment import get_segmenter, read_segments, segment_stage, segmenter_names
from inpaint360gs.segment.cluster3d import ClusterConfig, cluster_gaussians
from inpaint360gs.segment.frame import scene_frame
from inpaint360gs.segment.geometric import GeometricConfig, GeometricSegmenter
from inpaint360gs.segment.masks import flatten_masks, relabel_by_area, split_components


def _arrays(model):
    return model.means.double().numpy(), model.opacities.numpy(), model.scales.max(1).values.numpy()


def _stub_scene(n: int):
    """What the geometric segmenter reads of a scene: training views with cameras."""
    from types import SimpleNamespace

    return SimpleNamespace(train_views=[SimpleNamespace(camera=c, name=c.name) for c in cameras(n)])


def _purity(labels: np.ndarray, owner: np.ndarray, part: int) -> tuple[int, float]:
    """(the cluster holding most of ``part``'s Gaussians, the fraction of them it holds)."""
    lab = labels[owner == part]
    counts = np.bincount(lab[lab > 0], minlength=labels.max() + 1)
    k = int(np.argmax(counts))
    return k, counts[k] / len(lab)


def test_frame_finds_up_look_at_radius_and_ground():
    model, _ = two_blobs()
    means, opac, _ = _arrays(model)
    f = scene_frame(cameras(), means, opac)
    assert np.allclose(f.up, [0, 0, 1], atol=1e-3)
    assert np.allclose(f.look_at, [0, 0, 0], atol=1e-6)
    assert f.radius == pytest.approx(3.0, rel=1e-6)
    assert abs(f.plane_offset) < 0.005 and f.plane_inliers > 5000
    assert np.allclose(f.heights(np.array([[0.3, 0.2, 0.5]])), [0.5], atol=0.01)


def test_frame_of_a_tilted_scene_in_other_units():
    """Rotated and scaled world: up comes from the cameras, lengths scale with R."""
    model, _ = two_blobs()
    a = np.radians(25)
    rot = torch.tensor([[1, 0, 0], [0, np.cos(a), -np.sin(a)], [0, np.sin(a), np.cos(a)]], dtype=torch.float32)
    s = 7.0
    means = (s * model.means @ rot.T).double().numpy()
    cams = [replace(c, R=c.R @ rot.T, t=s * c.t) for c in cameras()]
    f = scene_frame(cams, means, model.opacities.numpy())
    assert np.allclose(f.up, rot.numpy() @ [0, 0, 1], atol=1e-3)
    assert f.radius == pytest.approx(3.0 * s, rel=1e-5)


def test_clusters_are_the_blobs_and_not_the_ground():
    model, owner = two_blobs()
    means, opac, maxs = _arrays(model)
    f = scene_frame(cameras(), means, opac)
    c = cluster_gaussians(means, opac, maxs, f, ClusterConfig())
    assert c.count == 2 and c.support == []
    k1, p1 = _purity(c.labels, owner, 1)
    k2, p2 = _purity(c.labels, owner, 2)
    assert k1 != k2 and p1 > 0.95 and p2 > 0.95
    assert (c.labels[owner == 0] > 0).mean() < 0.01  # the ground stays unlabelled


def test_a_sparse_model_widens_the_neighbourhoods():
    """60 Gaussians per blob (a model trained on small images): fixed neighbourhoods break the blobs
    into crumbs; widened by the seeds' neighbour distance they are found whole."""
    rng = np.random.default_rng(0)
    model, owner = build([ground(rng), blob(rng, (0.55, 0, 0.25), 0.2, (0.9, 0.2, 0.1), n=60), blob(rng, (-0.55, 0.15, 0.25), 0.2, (0.1, 0.3, 0.9), n=60)])
    means, opac, maxs = _arrays(model)
    f = scene_frame(cameras(), means, opac)
    fixed = cluster_gaussians(means, opac, maxs, f, ClusterConfig(density_eps=0.0))
    assert fixed.count > 2 and fixed.density_scale == 1.0
    c = cluster_gaussians(means, opac, maxs, f, ClusterConfig())
    assert c.count == 2 and c.density_scale > 1.5
    assert _purity(c.labels, owner, 1)[1] == 1.0 and _purity(c.labels, owner, 2)[1] == 1.0
    dense, _ = two_blobs()
    means, opac, maxs = _arrays(dense)
    assert cluster_gaussians(means, opac, maxs, f, ClusterConfig()).density_scale == 1.0  # dense models are left alone


def test_support_peeling_splits_a_plate_from_what_stands_on_it():
    model, owner = plate_scene()
    means, opac, maxs = _arrays(model)
    f = scene_frame(cameras(), means, opac)
    c = cluster_gaussians(means, opac, maxs, f, ClusterConfig())
    assert c.count == 3 and len(c.support) == 1
    plate, pp = _purity(c.labels, owner, 1)
    a, pa = _purity(c.labels, owner, 2)
    b, pb = _purity(c.labels, owner, 3)
    assert plate == c.support[0] and len({plate, a, b}) == 3
    assert pp > 0.95 and pa > 0.8 and pb > 0.8


def test_a_single_object_on_a_layer_is_kept_whole():
    """One blob on the plate: nothing to peel (an object alone on a plate merges with it, documented)."""
    rng_model, owner = plate_scene()
    keep = owner != 3
    model = rng_model.subset(torch.from_numpy(keep))
    means, opac, maxs = _arrays(model)
    c = cluster_gaussians(means, opac, maxs, scene_frame(cameras(), means, opac), ClusterConfig())
    assert c.count == 1 and c.support == []


def test_sparse_gaussians_above_a_plate_go_to_the_object_not_the_plate():
    """Three faint-density Gaussians beside the bottom of a blob on a plate, 4 cm above it: too
    sparse for the groups above the layer (DBSCAN noise there), nearer to the plate below than to
    the blob. They stand above the layer, so they belong to the nearest group (the blob), not to
    the support (growing alone would give them to the plate)."""
    rng = np.random.default_rng(0)
    extra = np.array([[0.41, -0.05, 0.12], [0.41, 0.0, 0.12], [0.41, 0.05, 0.12]])
    parts = [
        ground(rng),
        disc(rng, (0.0, 0.0, 0.08), 0.5, (0.9, 0.9, 0.85)),
        blob(rng, (0.25, 0.0, 0.2), 0.12, (0.9, 0.2, 0.1), n=300),
        blob(rng, (-0.22, 0.1, 0.2), 0.12, (0.1, 0.7, 0.2), n=300),
        (extra, np.tile([0.9, 0.2, 0.1], (3, 1)), np.full((3, 3), 0.02)),
    ]
    model, owner = build(parts)
    means, opac, maxs = _arrays(model)
    c = cluster_gaussians(means, opac, maxs, scene_frame(cameras(), means, opac), ClusterConfig())
    assert c.count == 3 and len(c.support) == 1
    blob_label, _ = _purity(c.labels, owner, 2)
    assert (c.labels[owner == 4] == blob_label).all() and blob_label != c.support[0]


def test_parts_stacked_over_each_other_on_a_layer_stay_one_object():
    """A cone-like object: a base plate, a body on it, and a top separated from the body by a gap
    wider than the peeling neighbourhood (a sparsely reconstructed dark band). The two groups above
    the layer are stacked, not side by side, so nothing is peeled: one object (without the rule:
    base + body + top, three objects)."""
    rng = np.random.default_rng(0)
    model, owner = build([
        ground(rng),
        disc(rng, (0.0, 0.0, 0.08), 0.3, (0.2, 0.2, 0.2)),
        blob(rng, (0.0, 0.0, 0.2), 0.1, (0.9, 0.8, 0.1), n=300),
        blob(rng, (0.0, 0.0, 0.435), 0.06, (0.9, 0.8, 0.1), n=120),
    ])  # fmt: skip
    means, opac, maxs = _arrays(model)
    c = cluster_gaussians(means, opac, maxs, scene_frame(cameras(), means, opac), ClusterConfig())
    assert c.count == 1 and c.support == []
    assert (c.labels[owner > 0] == 1).all()


def test_per_view_ids_differ_between_views_yet_match_the_objects():
    model, owner = two_blobs()
    seg = GeometricSegmenter()
    scene = _stub_scene(12)
    seg.prepare(scene, model)
    assert seg.summary()["objects_3d"] == 2
    id_of_blob1 = set()
    for v in scene.train_views:
        ids = seg.segment(v, None)
        assert ids.dtype == np.uint16
        truth = true_labels(model, owner, v.camera)
        for part in (1, 2):
            if (truth == part).sum() > 30:
                assert best_iou(ids, truth == part) > 0.85, (v.name, part)
        if (truth == 1).sum() > 30:
            id_of_blob1.add(int(np.bincount(ids[truth == 1]).argmax()))
    assert id_of_blob1 == {1, 2}  # numbered per view by area: blob 1 is sometimes the larger, sometimes not


def test_config_is_checked():
    with pytest.raises(InputError, match="eps"):
        GeometricSegmenter(GeometricConfig(cluster=ClusterConfig(eps=0.0)))
    with pytest.raises(InputError, match="min_weight"):
        GeometricSegmenter(GeometricConfig(min_weight=1.5))
    with pytest.raises(InputError, match="unknown segmenter"):
        get_segmenter("felzenszwalb")
    assert segmenter_names() == ["geometric", "oracle", "sam"]


# --- id-image helpers ----------------------------------------------------------------------------------


def test_relabel_and_split_components():
    lab = np.zeros((10, 12), np.int32)
    lab[0:3, 0:3] = 7  # 9 px
    lab[5:10, 5:12] = 7  # 35 px: same label, separate piece
    lab[0:4, 8:12] = 3  # 16 px
    lab[9, 0] = 3  # a crumb of label 3
    assert relabel_by_area(lab)[6, 6] == 1 and relabel_by_area(lab)[0, 0] == 1  # both pieces of 7: 44 px
    ids = split_components(lab, min_area=2, min_fraction=0.2)
    assert ids.dtype == np.uint16
    assert ids[6, 6] == 1 and ids[1, 9] == 2 and ids[0, 0] == 3  # 35, 16, 9 px
    assert ids[9, 0] == 2  # the crumb stays with its label's largest piece


def test_flatten_masks_puts_smaller_on_top():
    big = np.zeros((8, 8), bool)
    big[:, :] = True
    small = np.zeros((8, 8), bool)
    small[2:4, 2:4] = True
    hidden = np.zeros((8, 8), bool)
    hidden[2:3, 2:3] = True
    ids = flatten_masks([small, big, hidden])
    assert ids[0, 0] == 1 and ids[3, 3] == 2 and ids[2, 2] == 3 and ids.max() == 3


# --- the stage and the CLI --------------------------------------------------------------------------------


@pytest.fixture(scope="module")
def blob_scene(tmp_path_factory):
    model, owner = two_blobs()
    root = write_scene(tmp_path_factory.mktemp("seg") / "blobs", model)
    ply = root.parent / "point_cloud.ply"
    write_ply(ply, model)
    return root, ply, model, owner


def test_stage_writes_one_id_image_per_training_view(blob_scene, tmp_path):
    root, ply, model, owner = blob_scene
    scene = load_scene(root)
    info = segment_stage(scene, model, tmp_path / "seg", GeometricSegmenter(), model_path=ply)
    files = sorted(p.name for p in (tmp_path / "seg").iterdir())
    assert files == sorted([f"{v.stem}.png" for v in scene.train_views] + ["segment.json"])
    assert not any(n.startswith("test_") for n in files)
    meta = json.loads((tmp_path / "seg" / "segment.json").read_text())
    assert meta["segmenter"] == "geometric" and meta["reads_ground_truth"] is False
    assert meta["prepared"]["objects_3d"] == 2 and meta["inputs"]["model_sha256"] == info["inputs"]["model_sha256"]
    assert meta["model_check_psnr"] > 30
    segs = read_segments(tmp_path / "seg", scene)
    v = scene.train_views[3]
    assert segs[v.stem].dtype == np.uint16 and segs[v.stem].max() == meta["views"][v.stem]["segments"] == 2
    assert read_mask(tmp_path / "seg" / f"{v.stem}.png").dtype == np.uint16
    # deterministic: same inputs, same bytes
    segment_stage(scene, model, tmp_path / "again", GeometricSegmenter())
    for v in scene.train_views:
        assert (tmp_path / "seg" / f"{v.stem}.png").read_bytes() == (tmp_path / "again" / f"{v.stem}.png").read_bytes()


def _other_scene():
    """A model of another room: other objects on a floor of other colours."""
    model, _ = plate_scene(seed=3)
    return replace(model, sh0=-model.sh0)  # colour c -> 1 - c


def test_stage_refuses_a_model_of_another_scene(blob_scene, tmp_path):
    root, _, _, _ = blob_scene
    other = _other_scene()
    with pytest.raises(InputError, match="does not reproduce the training views"):
        segment_stage(load_scene(root), other, tmp_path / "x", GeometricSegmenter())
    assert not (tmp_path / "x").exists()


def test_cli_segment(blob_scene, tmp_path, capsys):
    root, ply, _, _ = blob_scene
    out = tmp_path / "seg"
    assert main(["segment", str(root), str(ply), str(out), "--no-progress", "--threads", "2"]) == 0
    assert "geometric segmented 12 training views" in capsys.readouterr().out
    assert main(["segment", str(root), str(ply), str(out), "--no-progress"]) == 2  # exists, no --overwrite
    assert "--overwrite" in capsys.readouterr().err
    assert main(["segment", str(root), str(ply), str(out), "--no-progress", "--overwrite", "--tau", "0.01"]) == 0
    assert json.loads((out / "segment.json").read_text())["settings"]["cluster"]["tau"] == 0.01


@pytest.mark.parametrize(
    "extra, message",
    [
        (["--segmenter", "oracle"], "ground-truth instance masks"),
        (["--segmenter", "sam"], "--sam-encoder"),
        (["--segmenter", "nope"], "invalid choice"),
        (["--eps", "-1"], "must be > 0"),
    ],
)
def test_cli_bad_input_is_one_line(blob_scene, tmp_path, capsys, extra, message):
    root, ply, _, _ = blob_scene
    assert main(["segment", str(root), str(ply), str(tmp_path / "o"), "--no-progress", *extra]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and len(err.splitlines()) == 1
    assert not (tmp_path / "o").exists()


def test_cli_bad_model_files(blob_scene, tmp_path, capsys):
    root, _, _, _ = blob_scene
    empty = tmp_path / "empty.ply"
    empty.write_bytes(b"ply\nformat binary_little_endian 1.0\nelement vertex 0\nproperty float x\nend_header\n")
    other = tmp_path / "other.ply"
    write_ply(other, _other_scene())
    for ply, message in ((empty, "empty.ply"), (other, "does not reproduce")):
        assert main(["segment", str(root), str(ply), str(tmp_path / "o"), "--no-progress"]) == 2
        err = capsys.readouterr().err.strip()
        assert message in err and len(err.splitlines()) == 1


def test_nothing_above_the_ground_warns_and_gives_empty_masks():
    model, owner = two_blobs()
    ground_only = model.subset(torch.from_numpy(owner == 0))
    seg = GeometricSegmenter()
    scene = _stub_scene(6)
    with pytest.warns(UserWarning, match="no object found"):
        seg.prepare(scene, ground_only)
    assert not seg.segment(scene.train_views[0], None).any()
