"""Object-ID distillation (paper Sec. 3.3) on a hand-built scene: two blobs of Gaussians labelled with
object ids 3 and 7 over a floor of background Gaussians, seen by orbit cameras; the masks are
rendered from the per-Gaussian labels, so the held-out views have exact answers.

Checks: the cached render (W f) and its gradient equal rasterizing the features; distillation
converges (held-out id accuracy); runs repeat byte for byte; the spatial loss (Eq. 4) on hand cases;
classifier.json round trip; every bad input is one InputError (and one line / exit code in the CLI).
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import inpaint360gs  # noqa: F401  (first: sets OMP_WAIT_POLICY before torch starts its thread pool)
import cv2
import numpy as np
import pytest
import torch
from scene_builder import orbit_cameras, write_model, write_png

from inpaint360gs.cli import main
from inpaint360gs.core.errors import InputError, TrainingDivergedError
from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.distill import DistillConfig, IdentityField, distill_stage, read_classifier, read_objects, write_classifier
from inpaint360gs.distill.cached import CachedFeatureRenderer
from inpaint360gs.distill.field import make_classifier
from inpaint360gs.distill.labels import load_labels
from inpaint360gs.distill.loss import knn_graph, object_loss, spatial_loss
from inpaint360gs.distill.stage import Distiller, cache_views
from inpaint360gs.gs.loop import Target
from inpaint360gs.io.ply import write_ply
from inpaint360gs.io.scene import load_scene
from inpaint360gs.render.api import render
from inpaint360gs.render.contributions import contributions

W, H = 64, 48
IDS = (3, 7)  # object ids of the two blobs (not 1, 2: the class -> id mapping is exercised)


def blob_model(seed: int = 0) -> tuple[Gaussians, torch.Tensor]:
    """(Gaussians, object id of each): a floor disc (id 0) and two opaque blobs (ids 3 and 7)."""
    gen = torch.Generator().manual_seed(seed)
    r = torch.sqrt(torch.rand(900, generator=gen)) * 3.0
    a = torch.rand(900, generator=gen) * 2 * math.pi
    floor = torch.stack([r * torch.cos(a), r * torch.sin(a), torch.full_like(r, -0.4)], 1)

    def blob(centre, n):
        d = torch.randn(n, 3, generator=gen)
        return torch.tensor(centre) + 0.35 * d / d.norm(dim=1, keepdim=True) * torch.rand(n, 1, generator=gen) ** (1 / 3)

    pts = torch.cat([floor, blob([0.7, 0.0, 0.0], 250), blob([-0.6, 0.5, 0.05], 250)])
    ids = torch.cat([torch.zeros(900, dtype=torch.long), torch.full((250,), IDS[0]), torch.full((250,), IDS[1])])
    colors = torch.rand(len(pts), 3, generator=gen)
    g = Gaussians.from_points(pts, colors, sh_degree=1, init_opacity=0.9)
    g.log_scales = torch.where(ids[:, None] == 0, torch.log(torch.tensor([0.12, 0.12, 0.02])), torch.log(torch.tensor(0.07)))
    return g, ids


def id_masks(g: Gaussians, ids: torch.Tensor, camera) -> np.ndarray:
    """The id map the labelled Gaussians render to: argmax over composited one-hot labels (0 where nothing is)."""
    onehot = torch.zeros(len(g), 8)
    onehot[torch.arange(len(g)), ids] = 1.0
    c = contributions(g, camera)
    lab = c.render(onehot).argmax(-1)
    lab[c.alpha() < 0.5] = 0
    return lab.numpy().astype(np.uint8)


@pytest.fixture(scope="module")
def blob_scene(tmp_path_factory) -> dict:
    root = tmp_path_factory.mktemp("blobs")
    scene_dir = root / "scene"
    g, ids = blob_model()
    cams = orbit_cameras(16, width=W, h=H, f=50.0, radius=3.0, height=1.2)
    write_model(scene_dir / "sparse" / "0", cams, g.means.double().numpy()[::10], np.full((len(g.means[::10]), 3), 0.5))
    assoc = root / "assoc"
    (assoc / "object_mask").mkdir(parents=True)
    for c in cams:
        with torch.no_grad():
            write_png(scene_dir / "images" / c.name, render(g, c).color)
        cv2.imwrite(str(assoc / "object_mask" / f"{Path(c.name).stem}.png"), id_masks(g, ids, c))
    (assoc / "objects.json").write_text(json.dumps({"objects": [{"id": i, "pixels": 0} for i in IDS], "segmenter": "test"}))
    model = root / "model.ply"
    write_ply(model, g)
    return {"scene": scene_dir, "assoc": assoc, "model": model, "gaussians": g, "ids": ids, "root": root}


def small_cfg(**kw) -> DistillConfig:
    base = dict(iterations=800, knn_sample=0, log_every=50)
    base.update(kw)
    return DistillConfig(**base)


# --- the cached render is the rasterizer ---------------------------------------------------------


def test_cached_render_and_gradients_equal_the_rasterizer(blob_scene):
    """One distillation loss evaluated through the cached W and through render(with_features=True):
    same value, same gradients for the features and the classifier."""
    scene = load_scene(blob_scene["scene"])
    labels = load_labels(blob_scene["assoc"] / "object_mask", scene.train_views, IDS)
    g = blob_scene["gaussians"]
    cfg = small_cfg(knn_sample=0)
    d = Distiller(g, labels, cfg)
    target = d.loop.views[3]
    feats = d.loop.params["features"]

    out = d.renderer(d.loop.gaussians(), target, 0, torch.Generator())
    loss_c, _ = d.loss(out, target, 0)
    loss_c.backward()
    g_cached = (feats.grad.clone(), d.classifier.weight.grad.clone())
    feats.grad = None
    d.classifier.zero_grad()

    ras = render(d.loop.gaussians(), target.camera, with_features=True, backend="numba")
    assert torch.allclose(out.features, ras.features, atol=2e-6)
    ras.gaussian_features, ras.knn_rows = feats, None  # the fields the objective reads
    loss_r, _ = d.loss(ras, target, 0)
    loss_r.backward()
    assert abs(loss_c.item() - loss_r.item()) < 1e-5
    scale = g_cached[0].abs().max().item()
    assert torch.allclose(g_cached[0], feats.grad, atol=1e-4 * scale)
    assert torch.allclose(g_cached[1], d.classifier.weight.grad, atol=1e-5)


# --- convergence, outputs, determinism ------------------------------------------------------------


@pytest.fixture(scope="module")
def distilled(blob_scene, tmp_path_factory):
    out = tmp_path_factory.mktemp("run") / "distill"
    res = distill_stage(load_scene(blob_scene["scene"]), blob_scene["model"], blob_scene["assoc"] / "object_mask", blob_scene["assoc"] / "objects.json", out, small_cfg())
    return res, out


def test_distillation_converges_on_held_out_views(blob_scene, distilled):
    res, out = distilled
    scene = load_scene(blob_scene["scene"])
    g, ids = blob_scene["gaussians"], blob_scene["ids"]
    curve = res.report["loss_curve"]
    assert curve[-1]["ce"] < 0.4 * curve[0]["ce"]
    assert res.report["final"]["train_views"]["pixel_accuracy"] > 0.97
    field = IdentityField.load(out)
    assert field.object_ids == [0, *IDS]
    for v in scene.holdout_views:
        pred, probs = field.render_ids(v.camera)
        truth = torch.from_numpy(id_masks(g, ids, v.camera)).long()
        assert probs.shape == (H, W, 3) and torch.allclose(probs.sum(-1), torch.ones(H, W), atol=1e-5)
        assert (pred == truth).float().mean().item() > 0.97
        for i in IDS:
            inter = ((pred == i) & (truth == i)).sum().item()
            union = ((pred == i) | (truth == i)).sum().item()
            assert inter / union > 0.85, (v.name, i, inter / union)
    # each Gaussian's own class: the blobs' Gaussians are classified as their object
    gp = field.gaussian_probs()
    assert gp.shape == (len(g), 3)
    for c, i in enumerate(IDS, start=1):
        assert (gp[ids == i].argmax(-1) == c).float().mean().item() > 0.9


def test_outputs_and_report(distilled, blob_scene):
    res, out = distilled
    assert sorted(p.name for p in out.iterdir()) == ["classifier.json", "distill.json", "point_cloud.ply"]
    rep = json.loads((out / "distill.json").read_text())
    assert rep["settings"]["iterations"] == 800 and rep["object_ids"] == [0, *IDS]
    assert len(rep["inputs"]["model_sha256"]) == 64 and len(rep["inputs"]["masks_sha256"]) == 64
    assert rep["weights_cache"]["entries"] > 0 and rep["timing_s"]["total"] > 0
    g = IdentityField.load(out).gaussians
    ref = blob_scene["gaussians"]
    assert g.features.shape == (len(ref), 16)
    for k in ("means", "log_scales", "quats", "opacity_logits", "sh0", "shN"):  # geometry and colour frozen
        assert torch.equal(getattr(g, k), getattr(ref, k)), k


def test_same_seed_same_bytes_other_seed_differs(blob_scene, distilled, tmp_path):
    _, first = distilled
    scene = load_scene(blob_scene["scene"])
    args = (blob_scene["model"], blob_scene["assoc"] / "object_mask", blob_scene["assoc"] / "objects.json")
    distill_stage(scene, *args, tmp_path / "again", small_cfg())
    for name in ("point_cloud.ply", "classifier.json"):
        assert (first / name).read_bytes() == (tmp_path / "again" / name).read_bytes(), name
    distill_stage(scene, *args, tmp_path / "seed1", small_cfg(iterations=20, seed=1))
    assert (first / "classifier.json").read_bytes() != (tmp_path / "seed1" / "classifier.json").read_bytes()


def test_sampled_spatial_loss_draws_from_the_loop_generator(blob_scene):
    scene = load_scene(blob_scene["scene"])
    labels = load_labels(blob_scene["assoc"] / "object_mask", scene.train_views, IDS)
    g = blob_scene["gaussians"]
    cache = cache_views(g, labels, small_cfg())
    r = CachedFeatureRenderer(cache, knn_sample=100)
    t = Target(labels.views[0].name, labels.views[0].camera)
    g2 = Gaussians(**{**g.tensors(), "features": torch.zeros(len(g), 4)})
    a = r(g2, t, 0, torch.Generator().manual_seed(5)).knn_rows
    b = r(g2, t, 0, torch.Generator().manual_seed(5)).knn_rows
    assert a.shape == (100,) and torch.equal(a, b)
    assert CachedFeatureRenderer(cache, knn_sample=0)(g2, t, 0, torch.Generator()).knn_rows is None


# --- the spatial loss (Eq. 4) ---------------------------------------------------------------------


def test_object_loss_is_cross_entropy_with_its_gradient():
    """L_obj written over the transposed logits gives torch's cross-entropy and its gradient, in
    float64, with logits large enough that a naive exp would overflow."""
    gen = torch.Generator().manual_seed(3)
    logits = (torch.randn(500, 7, generator=gen, dtype=torch.float64) * 300).requires_grad_()
    labels = torch.randint(0, 7, (500,), generator=gen)
    ref = torch.nn.functional.cross_entropy(logits, labels)
    (g_ref,) = torch.autograd.grad(ref, logits)
    out = object_loss(logits, labels)
    (g,) = torch.autograd.grad(out, logits)
    assert torch.isfinite(out)
    assert out.item() == pytest.approx(ref.item(), rel=1e-12)
    assert torch.allclose(g, g_ref, rtol=1e-10, atol=1e-14)


def test_spatial_loss_hand_cases():
    means = torch.tensor([[0.0, 0, 0], [1.0, 0, 0]])
    nb = knn_graph(means, 5)
    assert nb.tolist() == [[1], [0]]  # k is capped at N - 1, never the point itself
    same = torch.tensor([[1.0, 2.0], [1.0, 2.0]])
    assert abs(spatial_loss(same, nb).item()) < 1e-7
    orth = torch.tensor([[1.0, 0.0], [0.0, 3.0]])
    assert abs(spatial_loss(orth, nb).item() - 1.0) < 1e-7
    diag = torch.tensor([[1.0, 0.0], [2.0, 2.0]])
    assert abs(spatial_loss(diag, nb).item() - (1 - 1 / math.sqrt(2))) < 1e-6
    opposite = torch.tensor([[1.0, 1.0], [-1.0, -1.0]])
    assert abs(spatial_loss(opposite, nb).item() - 2.0) < 1e-6
    assert spatial_loss(same, torch.zeros(2, 0, dtype=torch.long)).item() == 0.0  # no neighbours


def test_knn_graph_skips_self_with_duplicate_centres():
    means = torch.tensor([[0.0, 0, 0], [0.0, 0, 0], [0.0, 0, 0], [5.0, 0, 0]])
    nb = knn_graph(means, 2)
    for i in range(4):
        assert i not in nb[i].tolist()
    assert sorted(nb[0].tolist()) == [1, 2]


@pytest.mark.parametrize("sample", [None, 37])
def test_spatial_loss_kernel_equals_torch_reference(sample):
    gen = torch.Generator().manual_seed(0)
    means = torch.randn(300, 3, generator=gen)
    feats = torch.randn(300, 16, generator=gen)
    feats[5] = 0.0  # a zero feature: its norm is clamped, as torch's cosine_similarity does
    nb = knn_graph(means, 5)
    rows = None if sample is None else torch.randint(0, 300, (sample,), generator=gen)
    f32 = feats.clone().requires_grad_(True)
    f64 = feats.double().requires_grad_(True)
    a, b = spatial_loss(f32, nb, rows), spatial_loss(f64, nb, rows)  # numba kernel / torch autograd
    (3 * a).backward()
    (3 * b).backward()
    assert abs(a.item() - b.item()) < 1e-6
    row_scale = f64.grad.abs().amax(1, keepdim=True)  # the zero feature's gradient is ~1e5 (1/eps): float32 cancellation
    assert bool(((f32.grad.double() - f64.grad).abs() <= 1e-6 + 1e-6 * row_scale).all())


# --- classifier.json ------------------------------------------------------------------------------


def test_classifier_json_round_trip(tmp_path):
    lin = make_classifier(16, 5, torch.Generator().manual_seed(3))
    with torch.no_grad():
        lin.weight[0, 0] = 1 / 3  # a value without a short decimal form
    write_classifier(tmp_path / "c.json", lin, [0, 4, 9, 10, 255])
    back, ids = read_classifier(tmp_path / "c.json")
    assert ids == [0, 4, 9, 10, 255]
    assert torch.equal(back.weight, lin.weight) and torch.equal(back.bias, lin.bias)
    d = json.loads((tmp_path / "c.json").read_text())
    assert d["feature_dim"] == 16 and d["num_classes"] == 5
    for bad in ({"weight": [[1.0]], "bias": [1.0, 2.0], "object_ids": [0]}, {"weight": [[1.0]]}, "[1, 2"):
        (tmp_path / "bad.json").write_text(bad if isinstance(bad, str) else json.dumps(bad))
        with pytest.raises(InputError, match="bad.json"):
            read_classifier(tmp_path / "bad.json")


def test_read_objects_layouts(tmp_path):
    p = tmp_path / "objects.json"
    for data, want in (([1, 2], [1, 2]), ([{"id": 4}, {"id": 0}], [4]), ({"ids": [9, 2]}, [2, 9]), ({"objects": [{"id": 5}]}, [5])):
        p.write_text(json.dumps(data))
        assert read_objects(p) == want
    for data, msg in (({"foo": 1}, "expected a list"), ([1.5], "integer"), (list(range(1, 300)), "more than 256 classes"), ([256], "1..255")):
        p.write_text(json.dumps(data))
        with pytest.raises(InputError, match=msg):
            read_objects(p)


# --- bad inputs -----------------------------------------------------------------------------------


def _copy_assoc(blob_scene, tmp_path) -> Path:
    import shutil

    dst = tmp_path / "assoc"
    shutil.copytree(blob_scene["assoc"], dst)
    return dst


@pytest.mark.parametrize(
    "spoil, message",
    [
        (lambda a: cv2.imwrite(str(a / "object_mask" / "IMG_001.png"), np.zeros((H + 2, W), np.uint8)), "mask is 64x50 but view IMG_001.png is 64x48"),
        (lambda a: (a / "object_mask" / "IMG_002.png").unlink(), "no object mask for training view IMG_002.png"),
        (lambda a: cv2.imwrite(str(a / "object_mask" / "IMG_003.png"), np.full((H, W), 5, np.uint8)), r"object id\(s\) \[5\] not listed"),
        (lambda a: (a / "objects.json").write_text(json.dumps(list(range(1, 300)))), "more than 256 classes"),
    ],
)
def test_bad_masks_are_input_errors(blob_scene, tmp_path, spoil, message):
    assoc = _copy_assoc(blob_scene, tmp_path)
    spoil(assoc)
    with pytest.raises(InputError, match=message):
        distill_stage(load_scene(blob_scene["scene"]), blob_scene["model"], assoc / "object_mask", assoc / "objects.json", tmp_path / "out", small_cfg(iterations=2))
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("shift, message", [((30.0, 0.0, 0.0), "covers only 0.[0-9]+% of the training pixels"), ((0.0, 0.0, 1000.0), "no Gaussian of the model projects")])
def test_model_of_another_scene_is_an_input_error(blob_scene, shift, message):
    g = blob_scene["gaussians"]
    far = Gaussians(**{**g.tensors(), "means": g.means + torch.tensor(shift)})
    with pytest.raises(InputError, match=f"{message}.*is the model from this scene"):
        distill_stage(load_scene(blob_scene["scene"]), far, blob_scene["assoc"] / "object_mask", list(IDS), None, small_cfg(iterations=2))


def test_divergence_raises(blob_scene):
    with pytest.raises(TrainingDivergedError, match="non-finite|loss is"):
        distill_stage(load_scene(blob_scene["scene"]), blob_scene["model"], blob_scene["assoc"] / "object_mask", list(IDS), None, small_cfg(iterations=50, features_lr=1e37))


def test_cli(blob_scene, tmp_path, capsys):
    s, m, a = (str(blob_scene[k]) for k in ("scene", "model", "assoc"))
    out = tmp_path / "out"
    assert main(["distill", s, m, a, str(out), "--iterations", "30", "--threads", "2", "--no-progress"]) == 0
    assert "pixel accuracy" in capsys.readouterr().out
    assert main(["distill", s, m, a, str(out), "--iterations", "30", "--no-progress"]) == 2  # no --overwrite
    assert "not empty" in capsys.readouterr().err
    assert main(["distill", s, m, a, str(out), "--iterations", "5", "--no-progress", "--overwrite"]) == 0
    capsys.readouterr()
    assert main(["distill", s, m, a, str(tmp_path / "o2"), "--iterations", "50", "--features-lr", "1e37", "--no-progress"]) == 3
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "training diverged" in err[0]
    assoc = _copy_assoc(blob_scene, tmp_path)
    (assoc / "object_mask" / "IMG_005.png").unlink()
    assert main(["distill", s, m, str(assoc), str(tmp_path / "o3"), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "no object mask for training view IMG_005.png" in err[0]
    g = blob_scene["gaussians"]
    write_ply(tmp_path / "elsewhere.ply", Gaussians(**{**g.tensors(), "means": g.means + torch.tensor([0.0, 0.0, 1000.0])}))
    assert main(["distill", s, str(tmp_path / "elsewhere.ply"), a, str(tmp_path / "o6"), "--no-progress"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "elsewhere.ply: no Gaussian of the model projects" in err[0]
    (tmp_path / "notassoc").mkdir()
    assert main(["distill", s, m, str(tmp_path / "notassoc"), str(tmp_path / "o4"), "--no-progress"]) == 2  # not an association folder
    assert "objects.json" in capsys.readouterr().err
    assert main(["distill", s, m, a, str(tmp_path / "o5"), "--iterations", "0"]) == 2
