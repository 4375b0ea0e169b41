"""Bad input to ``inpaint360gs inpaint SCENE DISTILL REMOVED OUT`` and ``inpaint360gs evaluate``: one
line, a documented exit code, nothing written (docs/architecture.md, "Reliability"), and refusals that
can be made before the work starts are made before it.

The distillation output is built directly (a Gaussian model with one-hot identity features and an
identity classifier, saved the way ``distill`` saves it) instead of trained, and so are the removal
outputs: each selects one object of the model by its Gaussians' indices."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
import torch

import scene_builder as sb
from cli_harness import Case, check, ids_unique, out_cases, put, remove, restore_threads, run_cli  # noqa: F401
from inpaint360gs.core.gaussians import Gaussians

T = "inpaint360gs"
W, H = 32, 24
# a run that wrongly goes ahead stays short
FAST = ["--virtual-views", "3", "--inpaint-iterations", "2", "--no-progress", "--threads", "1"]

BALL = 1  # a ball standing on the floor: the floor under it was never seen (something to inpaint)
FLOATER = 2  # a small thing floating low above the floor: every view saw the floor around and under it
FAR = 3  # three tiny clusters far away (above, below the floor, beyond the floor) around an empty centre


def scene_model() -> tuple[Gaussians, np.ndarray]:
    """A textured flat floor (id 0) and the objects above; returns (model, object id per Gaussian)."""
    rng = np.random.default_rng(0)
    g = np.arange(-2.0, 2.0 + 1e-9, 0.08)
    x, y = np.meshgrid(g, g)
    floor = np.stack([x.ravel(), y.ravel(), np.zeros(x.size)], 1)
    checker = (np.floor(x.ravel() / 0.4) + np.floor(y.ravel() / 0.4)) % 2
    parts = [(floor, 0.3 + 0.4 * checker[:, None] * np.array([[1.0, 0.8, 0.4]]) + 0.1, 0.06, 0)]
    d = rng.normal(size=(300, 3))
    d *= 0.25 * rng.uniform(0.3, 1.0, (300, 1)) ** (1 / 3) / np.linalg.norm(d, axis=1, keepdims=True)
    parts.append((np.array([0.0, 0.0, 0.25]) + d, np.tile([[0.9, 0.15, 0.1]], (300, 1)), 0.04, BALL))
    d = rng.normal(size=(40, 3))
    d *= 0.05 / np.linalg.norm(d, axis=1, keepdims=True)
    parts.append((np.array([0.7, -0.5, 0.3]) + d, np.tile([[0.1, 0.3, 0.9]], (40, 1)), 0.02, FLOATER))
    far = np.repeat(np.array([[0.0, 0.0, 8.0], [0.0, 0.0, -8.0], [70.0, 70.0, 0.3]]), 5, axis=0) + rng.normal(0, 0.01, (15, 3))
    parts.append((far, np.tile([[0.2, 0.9, 0.2]], (15, 1)), 0.02, FAR))
    pts = np.concatenate([p[0] for p in parts])
    rgb = np.concatenate([p[1] for p in parts]).clip(0, 1)
    scales = np.concatenate([np.full(len(p[0]), p[2]) for p in parts])
    ids = np.concatenate([np.full(len(p[0]), p[3]) for p in parts])
    model = Gaussians.from_points(torch.tensor(pts, dtype=torch.float32), torch.tensor(rgb, dtype=torch.float32), sh_degree=1,
                                  init_opacity=0.98, scales=torch.tensor(scales, dtype=torch.float32))  # fmt: skip
    model.log_scales[ids == 0, 2] = math.log(1e-3)  # flat floor splats: the surface is z = 0
    return model, ids


def cameras(n: int, prefix: str, phase: float = 0.0):
    return sb.orbit_cameras(n, radius=3.0, height=2.5, width=W, h=H, f=28.0, prefix=prefix, phase=phase)


@pytest.fixture(scope="module")
def built(tmp_path_factory) -> Path:
    """``scene/`` (cameras around the objects, random pixels: the stage reads none), ``distill/``,
    and ``removed_<id>/`` for each object."""
    from inpaint360gs.distill.field import MODEL_PLY, write_classifier
    from inpaint360gs.io.ply import write_ply

    root = tmp_path_factory.mktemp("bad_inpaint")
    model, ids = scene_model()
    cams = cameras(12, "IMG_") + cameras(2, "test_", 0.3)
    rng = np.random.default_rng(1)
    floor = model.means[torch.from_numpy(ids == 0)].numpy()[::7]
    sb.write_model(root / "scene" / "sparse" / "0", cams, floor, np.full(floor.shape, 0.5))
    for c in cams:
        sb.write_png(root / "scene" / "images" / c.name, rng.integers(0, 256, (H, W, 3), dtype=np.uint8))
    model.features = torch.nn.functional.one_hot(torch.from_numpy(ids), 4).float()
    write_ply(root / "distill" / MODEL_PLY, model)
    classifier = torch.nn.Linear(4, 4)
    with torch.no_grad():
        classifier.weight.copy_(10.0 * torch.eye(4))
        classifier.bias.zero_()
    write_classifier(root / "distill" / "classifier.json", classifier, [0, BALL, FLOATER, FAR])
    for k in (BALL, FLOATER, FAR):
        removal(root / f"removed_{k}", np.flatnonzero(ids == k), [k])
    return root


def removal(folder: Path, index: np.ndarray, objects: list[int]) -> Path:
    """A removal stage output as far as ``inpaint`` reads it."""
    folder.mkdir(parents=True, exist_ok=True)
    np.save(folder / "removed_index.npy", index)
    (folder / "removal.json").write_text(json.dumps({"objects": objects}) + "\n")
    return folder


def args(c, removed: str, *extra: str, out: str | None = None) -> list[str]:
    root = Path(c.fx("built"))
    return ["inpaint", str(root / "scene"), str(root / "distill"), removed, out or c.path("out"), *FAST, *extra]


def with_removal(spoil, named=None):
    """A copy of the ball's removal passed through ``spoil(folder)``; the error must name what
    ``spoil`` returns (default: the folder)."""

    def make(c):
        import shutil

        folder = c.tmp / "removed"
        shutil.copytree(Path(c.fx("built")) / f"removed_{BALL}", folder)
        got = spoil(folder)
        return args(c, str(folder)), str(got if got is not None else folder)

    return make


def object_removal(k: int):
    def make(c):
        folder = str(Path(c.fx("built")) / f"removed_{k}")
        return args(c, folder), folder

    return make


def lama(kind: str):
    def make(c):
        checkpoint = c.file("lama.onnx", {"text": "not a model\n", "empty": b"", "pytorch": b"PK\x03\x04" + bytes(60)}[kind])
        return args(c, str(Path(c.fx("built")) / f"removed_{BALL}"), "--rgb-inpainter", "lama", "--lama-onnx", checkpoint), checkpoint

    return make


def distill_without_classifier(c):
    import shutil

    root = Path(c.fx("built"))
    d = c.tmp / "distill"
    shutil.copytree(root / "distill", d)
    named = remove(d / "classifier.json")
    return ["inpaint", str(root / "scene"), str(d), str(root / f"removed_{BALL}"), c.path("out"), *FAST], str(named)


def out_is(which: str):
    """OUT is (or holds) one of the inputs, with --overwrite: refused before anything is read."""

    def make(c):
        root = Path(c.fx("built"))
        target = {"removed": root / f"removed_{BALL}", "scene": root / "scene", "holds-inputs": root}[which]
        return args(c, str(root / f"removed_{BALL}"), "--overwrite", out=str(target)), str(target)

    return make


EARLY = [  # refused before the stage's work starts (no rendering at all)
    Case("inpaint-nothing-selected", T, with_removal(lambda f: removal(f, np.zeros(0, np.int64), [BALL]) / "removed_index.npy")),
    Case("inpaint-removal-from-another-model", T, with_removal(lambda f: removal(f, np.array([5, 10**6]), [BALL]) / "removed_index.npy")),
    Case("inpaint-removal-negative-index", T, with_removal(lambda f: removal(f, np.array([-1, 3]), [BALL]) / "removed_index.npy")),
    Case("inpaint-removal-index-not-integers", T, with_removal(lambda f: removal(f, np.array([0.5, 2.0]), [BALL]) / "removed_index.npy")),
    Case("inpaint-removal-index-garbage", T, with_removal(lambda f: put(f / "removed_index.npy", "not numpy") and None)),
    Case("inpaint-removal-json-missing", T, with_removal(lambda f: remove(f / "removal.json"))),
    Case("inpaint-removal-index-missing", T, with_removal(lambda f: remove(f / "removed_index.npy"))),
    Case("inpaint-removal-missing", T, lambda c: (args(c, c.path("nope")), c.path("nope"))),
    Case("inpaint-distill-no-classifier", T, lambda c: distill_without_classifier(c)),
    Case("inpaint-lama-onnx-text", T, lama("text")),
    Case("inpaint-lama-onnx-empty", T, lama("empty")),
    Case("inpaint-lama-onnx-not-onnx", T, lama("pytorch")),
    Case("inpaint-lama-onnx-missing", T, lambda c: (args(c, str(Path(c.fx("built")) / f"removed_{BALL}"), "--rgb-inpainter", "lama", "--lama-onnx", c.path("no.onnx")),
                                                    "--lama-onnx")),
    *out_cases(T, "inpaint", lambda c: args(c, str(Path(c.fx("built")) / f"removed_{BALL}"))[:4], tuple(FAST)),
    Case("inpaint-out-is-removed", T, out_is("removed")),
    Case("inpaint-out-is-scene", T, out_is("scene")),
    Case("inpaint-out-holds-the-inputs", T, out_is("holds-inputs")),
]
LATE = [  # found by looking at the scene: the virtual views and their masks
    Case("inpaint-unseen-mask-empty-everywhere", T, object_removal(FLOATER)),
    Case("inpaint-object-off-screen-in-every-view", T, object_removal(FAR)),
]


@pytest.fixture
def no_work(monkeypatch):
    """The stage's first expensive step fails the case if it is reached."""
    import inpaint360gs.inpaint.stage as stage

    def refuse(*a, **k):
        raise RuntimeError("the stage started its work before refusing the input")

    monkeypatch.setattr(stage, "TrainingVisibility", refuse)


@pytest.mark.parametrize("case", ids_unique(EARLY))
def test_bad_input_refused_before_work(case, tmp_path, request, capsys, no_work):
    check(case, tmp_path, request, capsys)


@pytest.mark.parametrize("case", ids_unique(LATE))
def test_nothing_to_inpaint(case, tmp_path, request, capsys):
    line = check(case, tmp_path, request, capsys)
    assert "nothing to inpaint" in line
    if case.id.endswith("empty-everywhere"):
        assert "saw all the surface" in line
    else:
        assert "cover no pixel of any virtual view" in line


def test_the_same_inputs_inpaint_the_ball(built, tmp_path, capsys):
    """The refusals above are not over-eager: the ball's removal inpaints, and the output holds what
    docs/architecture.md ("Stage outputs") lists."""
    out = tmp_path / "out"
    code, stdout, err = run_cli(T, ["inpaint", str(built / "scene"), str(built / "distill"), str(built / f"removed_{BALL}"), str(out), *FAST], capsys)
    assert code == 0, err
    names = {p.name for p in out.iterdir()}
    assert {"point_cloud.ply", "virtual_cameras.json", "views", "renders", "inpaint.json"} <= names
    rec = json.loads((out / "inpaint.json").read_text())
    assert rec["num_views"] == 3 and rec["new_gaussians"] > 0 and max(rec["fill_share_per_view"]) > 0


def test_the_far_object_is_off_screen_in_every_candidate_virtual_view():
    """What the off-screen case claims: the virtual cameras look at the median of the object's
    Gaussians, an empty point between its clusters, and none of its Gaussians projects into any
    candidate trajectory's images (every radius tried, the default number of views)."""
    from inpaint360gs.views.unseen import project
    from inpaint360gs.views.virtual import VirtualViewsConfig, orbit_cameras, trajectory_geometry

    model, ids = scene_model()
    train = cameras(12, "IMG_")
    far = model.means[torch.from_numpy(ids == FAR)].double()
    centre = far.median(dim=0).values.numpy()
    assert np.linalg.norm(far.numpy() - centre, axis=1).min() > 7.0
    frame, elevation, distance, phase = trajectory_geometry(train, centre)
    cfg = VirtualViewsConfig()
    for f in cfg.radius_factors:
        for cam in orbit_cameras(centre, frame, f * distance, elevation, cfg.num_views, train[0], phase):
            u, v, z = project(cam, far.numpy())
            margin = 4.0  # pixels: more than the clusters' footprint
            assert not ((z > 0) & (u > -margin) & (u < W + margin) & (v > -margin) & (v < H + margin)).any()


# --- evaluate: renders of the test views against the scene -----------------------------------------------


def renders(c, spoil=None, named=None):
    """A renders folder (the test views' own pictures) passed through ``spoil(folder)``."""
    import shutil

    folder = c.tmp / "renders"
    folder.mkdir()
    for p in sorted((Path(c.fx("built")) / "scene" / "images").glob("test_*")):
        shutil.copy(p, folder / p.name)
    got = spoil(folder) if spoil else None
    return folder, got


def evaluate(spoil=None, *extra: str, named: str | None = None, out: str | None = None):
    def make(c):
        folder, got = renders(c, spoil)
        argv = ["evaluate", str(folder), str(Path(c.fx("built")) / "scene"), out or c.path("m.json"), "--nets", "vgg", "--threads", "1", *extra]
        return argv, named or str(got)

    return make


def out_in(c, where: str, rel: str):
    """OUT inside an input folder, at a file the stage reads (or would read on the next run)."""
    argv, _ = evaluate()(c)
    folder = Path(argv[1]) if where == "renders" else Path(argv[2])
    out = str(folder / rel)
    return [*argv[:3], out, *argv[4:]], out


def small_for_alexnet(c):
    folder, _ = renders(c)
    scene = Path(c.fx("built")) / "scene"
    return ["evaluate", str(folder), str(scene), c.path("m.json"), "--threads", "1"], (str(scene / "images"), "LPIPS-alex")


EVALUATE = [
    Case("evaluate-renders-missing", T, lambda c: (["evaluate", c.path("nope"), str(Path(c.fx("built")) / "scene"), c.path("m.json")], c.path("nope"))),
    Case("evaluate-render-wrong-size", T, evaluate(lambda f: sb.write_png(f / "test_001.png", np.zeros((H, W + 2, 3), np.uint8)) or f / "test_001.png")),
    Case("evaluate-render-not-a-picture", T, evaluate(lambda f: put(f / "test_001.png", "not a picture"))),
    Case("evaluate-render-stray", T, evaluate(lambda f: put(f / "test_009.png", (f / "test_000.png").read_bytes()))),
    Case("evaluate-render-missing", T, evaluate(lambda f: remove(f / "test_001.png") and None, named="test_001.png")),
    Case("evaluate-nets-unknown", T, evaluate(None, "--nets", "squeeze", named="--nets")),
    Case("evaluate-inception-missing", T, lambda c: (evaluate(None, "--inception-weights", c.path("no.pth"), named="--inception-weights")(c))),
    Case("evaluate-out-is-a-render", T, lambda c: out_in(c, "renders", "test_000.png")),
    Case("evaluate-out-is-a-new-picture-among-the-renders", T, lambda c: out_in(c, "renders", "test_002.png")),
    Case("evaluate-out-in-scene", T, lambda c: out_in(c, "scene", "metrics.json")),
    Case("evaluate-out-is-a-ground-truth-picture", T, lambda c: out_in(c, "scene", "images/test_000.png")),
    Case("evaluate-out-is-folder", T, lambda c: evaluate(None, named=c.dir("sub"), out=c.path("sub"))(c)),
    Case("evaluate-images-too-small-for-alexnet", T, small_for_alexnet),
]


@pytest.mark.parametrize("case", ids_unique(EVALUATE))
def test_evaluate_bad_input(case, tmp_path, request, capsys):
    check(case, tmp_path, request, capsys)


def test_evaluate_of_the_same_inputs_works(built, tmp_path, capsys):
    import shutil

    folder = tmp_path / "renders"
    folder.mkdir()
    for p in sorted((built / "scene" / "images").glob("test_*")):
        shutil.copy(p, folder / p.name)
    code, _, err = run_cli(T, ["evaluate", str(folder), str(built / "scene"), str(tmp_path / "m.json"), "--nets", "vgg", "--threads", "1"], capsys)
    assert code == 0, err
    res = json.loads((tmp_path / "m.json").read_text())
    assert res["num_views"] == 2 and res["mean"]["lpips"] == 0.0 and res["mean"]["psnr"] is None  # identical pictures: PSNR is +inf
