"""Bad input to ``inpaint360gs train / render / table``: one line, a documented exit code, nothing
written (docs/architecture.md, "Reliability"). The cases of the dataset CLIs are in
``test_bad_input_dataset.py``; interruptions and file modes in ``test_bad_input_signals.py``."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import torch
from plyfile import PlyData, PlyElement

import scene_builder as sb
from cli_harness import Case, check, garbage_count, ids_unique, option_cases, out_cases, put, remove, restore_threads, run_cli, truncate  # noqa: F401
from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.io.ply import write_ply

T = "inpaint360gs"
W, H = 32, 24
# every train case: a run that wrongly goes ahead stays short; the settings of the `run` fixture
FAST = ["--iterations", "4", "--no-progress", "--threads", "2"]


@pytest.fixture(scope="module")
def tscene(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("bad_method") / "tscene"
    sb.simple_scene(root, n_train=10, n_test=3, width=W, height=H)
    return root


@pytest.fixture(scope="module")
def model(tscene) -> Path:
    from inpaint360gs.io.scene import load_scene

    s = load_scene(tscene)
    path = tscene.parent / "model" / "point_cloud.ply"
    write_ply(path, Gaussians.from_points(s.points, s.point_colors, sh_degree=1, init_opacity=0.5))
    return path


@pytest.fixture(scope="module")
def run(tscene) -> Path:
    """A finished 4-step run of ``tscene`` (checkpoint.pt, point_cloud.ply, ...) made by the CLI."""
    from inpaint360gs.cli import main

    out = tscene.parent / "run"
    assert main(["train", str(tscene), str(out), *FAST]) == 0
    return out


def good_metrics(scene: str, psnr: float = 30.0) -> dict:
    return {"scene": scene, "psnr": psnr, "ssim": 0.9, "num_gaussians": 100, "iterations": 10, "train_seconds": 1.0,
            "eval_seconds": 0.1, "peak_rss_mb": 500.0}


# --- train ---------------------------------------------------------------------------------------

BAD_TRAIN_OPTIONS = {  # case -> the wrong option, after the good ones (the error must name its flag)
    "iterations-zero": ("--iterations", "0"),
    "iterations-negative": ("--iterations", "-5"),
    "iterations-float": ("--iterations", "1e3"),
    "grad-threshold-nan": ("--densify-grad-threshold", "nan"),
    "grad-threshold-inf": ("--densify-grad-threshold", "inf"),
    "grad-threshold-zero": ("--densify-grad-threshold", "0"),
    "schedule-scale-negative": ("--schedule-scale", "-1"),
    "schedule-scale-word": ("--schedule-scale", "fast"),
    "max-gaussians-negative": ("--max-gaussians", "-1"),
    "resize-zero": ("--resize", "0"),
    "sh-degree-too-high": ("--sh-degree", "4"),
    "seed-negative": ("--seed", "-1"),
    "threads-zero": ("--threads", "0"),
    "checkpoint-every-negative": ("--checkpoint-every", "-10"),
    "unknown-option": ("--iterationz", "5"),
    "backend-unknown": ("--backend", "opengl"),
    "resume-with-value": ("--resume=yes",),
}


def train_broken(fn, *extra: str):
    def make(c):
        root, named = c.broken("tscene", fn)
        return ["train", str(root), c.path("out"), *extra, *FAST], str(named)

    return make


def png(path: Path, w: int = W, h: int = H) -> Path:
    sb.write_png(path, np.zeros((h, w, 3), np.uint8))
    return path


def img(root: Path, name: str = "IMG_003.png") -> Path:
    return root / "images" / name


def write_cameras(root: Path, points: np.ndarray | None = None, **kw) -> Path:
    """Rewrite the scene's model with the same cameras and ``points`` (default: 50 random), ``kw`` as
    for :func:`scene_builder.write_model` (camera model and parameters)."""
    cams = sb.orbit_cameras(10, width=W, h=H) + sb.orbit_cameras(3, width=W, h=H, prefix="test_", phase=0.3)
    pts = np.random.default_rng(0).uniform(-1, 1, (50, 3)) if points is None else points
    sb.write_model(root / "sparse" / "0", cams, pts, np.full(pts.shape, 0.5), **kw)
    return root / "sparse" / "0"


def nan_point(root: Path) -> Path:
    pts = np.random.default_rng(0).uniform(-1, 1, (50, 3))
    pts[7, 1] = np.nan
    return write_cameras(root, pts)


def all_test(root: Path) -> Path:
    for p in (root / "images").iterdir():
        p.rename(p.with_name("test_x" + p.name))
    import pycolmap

    rec = pycolmap.Reconstruction(root / "sparse" / "0")
    for im in rec.images.values():
        im.name = "test_x" + im.name
    rec.write(root / "sparse" / "0")
    return root / "sparse" / "0"


def other_content(root: Path) -> None:
    """Same scene name, other pixels in one training view: another scene for the checkpoint."""
    sb.write_png(img(root), np.random.default_rng(99).integers(0, 256, (H, W, 3), dtype=np.uint8))


def resume_run(fn=None, *extra: str, spoil=None):
    """``train --resume`` into a copy of the finished ``run``: on a copy of the scene passed through ``fn``
    (or the scene itself), with ``extra`` settings, its checkpoint passed through ``spoil``."""

    def make(c):
        root = c.broken("tscene", fn)[0] if fn else c.fx("tscene")
        out = c.copy("run", "out")
        if spoil:
            spoil(out / "checkpoint.pt")
        return ["train", str(root), str(out), *FAST, "--resume", *extra], str(out / "checkpoint.pt")

    return make


def into_run(*extra: str, drop_checkpoint: bool = False):
    """``train`` of the unchanged scene into a copy of the finished ``run``."""

    def make(c):
        out = c.copy("run", "out")
        if drop_checkpoint:
            (out / "checkpoint.pt").unlink()
        return ["train", c.fx("tscene"), str(out), *FAST, *extra], str(out)

    return make


def masks_wrong_size(root: Path) -> Path:
    p = root / "unseen_mask" / "test_000.png"
    sb.write_mask(p, np.zeros((H + 4, W), bool))
    return p


# --- how to break the model --------------------------------------------------------------------


def ply_with(c, vertex: np.ndarray, name: str = "bad.ply") -> str:
    p = c.tmp / name
    PlyData([PlyElement.describe(vertex, "vertex")], text=False).write(str(p))
    return str(p)


def model_array(c) -> np.ndarray:
    return PlyData.read(c.fx("model"))["vertex"].data.copy()


def ply_nan(c) -> str:
    v = model_array(c)
    v["opacity"][3] = np.nan
    return ply_with(c, v)


def ply_drop(c, *names: str) -> str:
    v = model_array(c)
    keep = [n for n in v.dtype.names if n not in names]
    out = np.empty(len(v), dtype=[(n, "f4") for n in keep])
    for n in keep:
        out[n] = v[n]
    return ply_with(c, out)


def ply_xyz_only(c) -> str:
    v = np.zeros(5, dtype=[("x", "f4"), ("y", "f4"), ("z", "f4")])
    return ply_with(c, v)


def ply_empty(c) -> str:
    return ply_with(c, model_array(c)[:0])


def ply_truncated(c) -> str:
    p = Path(c.file("bad.ply", Path(c.fx("model")).read_bytes()))
    return str(truncate(p, 0.6))


def render_model(model_fn, *extra: str):
    def make(c):
        m = model_fn(c)
        return ["render", m, c.fx("tscene"), c.path("out"), *extra, "--no-progress"], m

    return make


def render_scene(fn, *extra: str):
    def make(c):
        root, named = c.broken("tscene", fn)
        return ["render", c.fx("model"), str(root), c.path("out"), *extra, "--no-progress"], str(named)

    return make


def render_args(*args: str, named: str):
    return lambda c: (["render", c.fx("model"), c.fx("tscene"), c.path("out"), *args, "--no-progress"], named)


# --- tables ------------------------------------------------------------------------------------


def table(*files):
    """``table reconstruction FILES --csv out.csv`` over files made by ``files`` (each ``c -> path``);
    the error must name the last one."""

    def make(c):
        paths = [f(c) for f in files]
        return ["table", "reconstruction", *paths, "--csv", c.path("out.csv")], paths[-1]

    return make


def good(name: str):
    return lambda c: c.file(f"{name}.json", json.dumps(good_metrics(name)))


def metrics_with(**fields):
    return lambda c: c.file("bad.json", json.dumps({**good_metrics("bad"), **fields}))


def raw(data: bytes | str, name: str = "bad.json"):
    return lambda c: c.file(name, data)


def existing_output(c):
    """A previous table at the output path: an error must leave it as it was."""
    c.file("out.csv", "scene,psnr\nold,1\n")
    return c.file("bad.json", "[1, 2]")


CASES = [
    # train: arguments (all refused by the argument parser or the config check, before the scene is read)
    *option_cases(T, "train", lambda c, args: ["train", c.fx("tscene"), c.path("out"), *FAST, *args], BAD_TRAIN_OPTIONS),
    Case("train-scene-missing", T, lambda c: (["train", c.path("nope"), c.path("out"), *FAST], c.path("nope"))),
    Case("train-scene-is-file", T, lambda c: (["train", c.file("f"), c.path("out"), *FAST], c.path("f"))),
    *out_cases(T, "train", lambda c: ["train", c.fx("tscene")], tuple(FAST), kinds=("out-is-file", "out-under-file", "out-readonly")),
    Case("train-out-is-scene", T, lambda c: (lambda r: (["train", str(r), str(r), *FAST], str(r)))(c.copy("tscene"))),
    # train: the scene folder
    Case("train-no-images-folder", T, train_broken(lambda r: remove(r / "images"))),
    Case("train-no-sparse", T, train_broken(lambda r: remove(r / "sparse", r / "sparse" / "0"))),
    Case("train-sparse-truncated", T, train_broken(lambda r: truncate(r / "sparse" / "0" / "images.bin", 0.7))),
    Case("train-sparse-garbage-count", T, train_broken(lambda r: garbage_count(r / "sparse" / "0"))),
    Case("train-sparse-nan-point", T, train_broken(nan_point)),
    Case("train-sparse-no-points", T, train_broken(lambda r: write_cameras(r, np.zeros((0, 3))))),
    Case("train-camera-distortion", T, train_broken(lambda r: write_cameras(r, model="SIMPLE_RADIAL", params=[60, W / 2, H / 2, 0.01]))),
    Case("train-camera-zero-focal", T, train_broken(lambda r: write_cameras(r, model="PINHOLE", params=[0, 0, W / 2, H / 2]))),
    Case("train-camera-nan-focal", T, train_broken(lambda r: write_cameras(r, model="PINHOLE", params=[np.nan, 60, W / 2, H / 2]))),
    Case("train-registered-image-missing", T, train_broken(lambda r: remove(img(r)))),
    Case("train-unregistered-image", T, train_broken(lambda r: png(img(r, "IMG_999.png")))),
    Case("train-image-truncated-png", T, train_broken(lambda r: truncate(img(r)))),
    Case("train-holdout-image-truncated", T, train_broken(lambda r: truncate(img(r, "IMG_000.png")))),
    Case("train-image-zero-bytes", T, train_broken(lambda r: put(img(r), b""))),
    Case("train-image-is-text", T, train_broken(lambda r: put(img(r), "not a picture"))),
    Case("train-image-wrong-size", T, train_broken(lambda r: png(img(r), w=W + 2))),
    Case("train-test-image-wrong-size", T, train_broken(lambda r: png(img(r, "test_001.png"), w=W + 2))),
    Case("train-mask-wrong-size", T, train_broken(masks_wrong_size)),
    Case("train-scene-json-corrupt", T, train_broken(lambda r: put(r / "scene.json", "{oops"))),
    Case("train-scene-json-list", T, train_broken(lambda r: put(r / "scene.json", "[]"))),
    Case("train-no-training-views", T, train_broken(all_test)),
    Case("train-resize-incomplete-copies", T, train_broken(lambda r: (r / "images_2").mkdir() or r / "images_2", "--resize", "2")),
    # train: a previous run in OUT
    Case("train-previous-run-no-flag", T, into_run()),
    Case("train-resume-finished-run-without-checkpoint", T, into_run("--resume", drop_checkpoint=True)),
    Case("train-resume-other-settings", T, resume_run(None, "--iterations", "5")),
    Case("train-resume-other-scene-same-name", T, resume_run(other_content)),
    Case("train-resume-corrupt-checkpoint", T, resume_run(spoil=lambda p: p.write_bytes(b"PK\x03\x04 not really a zip"))),
    Case("train-resume-truncated-checkpoint", T, resume_run(spoil=truncate)),
    Case("train-resume-checkpoint-not-a-checkpoint", T, resume_run(spoil=lambda p: torch.save({"weights": torch.zeros(3)}, p))),
    # render
    Case("render-model-missing", T, render_model(lambda c: c.path("nope.ply"))),
    Case("render-model-is-folder", T, render_model(lambda c: str(Path(c.file("m/x")).parent))),
    Case("render-model-zero-bytes", T, render_model(lambda c: c.file("bad.ply", b""))),
    Case("render-model-text", T, render_model(lambda c: c.file("bad.ply", "hello, not a ply\n"))),
    Case("render-model-truncated", T, render_model(ply_truncated)),
    Case("render-model-nan", T, render_model(ply_nan)),
    Case("render-model-xyz-only", T, render_model(ply_xyz_only)),
    Case("render-model-no-rotation", T, render_model(lambda c: ply_drop(c, "rot_3"))),
    Case("render-model-odd-sh", T, render_model(lambda c: ply_drop(c, "f_rest_8"))),
    Case("render-model-empty", T, render_model(ply_empty)),
    Case("render-sh-degree-above-model", T, render_args("--sh-degree", "3", named="--sh-degree")),
    Case("render-threads-nan", T, render_args("--threads", "nan", named="--threads")),
    Case("render-scene-missing", T, lambda c: (["render", c.fx("model"), c.path("nope"), c.path("out"), "--no-progress"], c.path("nope"))),
    Case("render-scene-sparse-corrupt", T, render_scene(lambda r: garbage_count(r / "sparse" / "0"))),
    Case("render-scene-camera-distortion", T, render_scene(lambda r: write_cameras(r, model="SIMPLE_RADIAL", params=[60, W / 2, H / 2, 0.01]))),
    *out_cases(T, "render", lambda c: ["render", c.fx("model"), c.fx("tscene")], ("--no-progress",)),
    Case("render-out-holds-model", T, lambda c: (lambda run: (["render", str(run / "point_cloud.ply"), c.fx("tscene"), str(run), "--overwrite", "--no-progress"], str(run)))(
        c.copy("run"))),
    Case("render-out-is-scene", T, lambda c: (lambda r: (["render", c.fx("model"), str(r), str(r), "--overwrite", "--no-progress"], str(r)))(c.copy("tscene"))),
    Case("render-resize-zero", T, render_args("--resize", "0", named="--resize")),
    Case("render-split-unknown", T, render_args("--split", "val", named="--split")),
    Case("render-no-views-in-split", T, render_args("--split", "holdout", "--llffhold", "0", named="holdout")),
    # table
    Case("table-file-missing", T, table(good("a"), lambda c: c.path("nope.json"))),
    Case("table-folder", T, table(good("a"), lambda c: str(Path(c.file("dir/x")).parent))),
    Case("table-binary", T, table(good("a"), raw(bytes(range(256)) * 4))),
    Case("table-empty-file", T, table(good("a"), raw(b""))),
    Case("table-invalid-json", T, table(good("a"), raw("{\"scene\": "))),
    Case("table-json-list", T, table(good("a"), raw("[1, 2, 3]"))),
    Case("table-json-string", T, table(good("a"), raw("\"metrics\""))),
    Case("table-null-value", T, table(good("a"), metrics_with(psnr=None))),
    Case("table-string-value", T, table(good("a"), metrics_with(psnr="31.2"))),
    Case("table-bool-value", T, table(good("a"), metrics_with(ssim=True))),
    Case("table-nan-value", T, table(good("a"), raw(json.dumps(good_metrics("bad")).replace("30.0", "NaN")))),
    Case("table-infinite-value", T, table(good("a"), raw(json.dumps(good_metrics("bad")).replace("30.0", "Infinity")))),
    Case("table-missing-field", T, table(good("a"), lambda c: c.file("bad.json", json.dumps({k: v for k, v in good_metrics("bad").items() if k != "ssim"})))),
    Case("table-scene-not-string", T, table(good("a"), metrics_with(scene=7))),
    Case("table-duplicate-file", T, table(good("a"), lambda c: c.path("a.json"))),
    Case("table-duplicate-file-other-spelling", T, table(good("a"), lambda c: str(Path(c.file("sub/x")).parent / ".." / "a.json"))),
    Case("table-duplicate-scene", T, table(good("a"), lambda c: c.file("again.json", json.dumps(good_metrics("a", 29.0))))),
    Case("table-csv-is-folder", T, lambda c: (["table", "reconstruction", good("a")(c), "--csv", c.path("sub")], c.file("sub/x") and c.path("sub"))),
    Case("table-csv-under-file", T, lambda c: (["table", "reconstruction", good("a")(c), "--csv", c.file("f") + "/out.csv"], c.path("f"))),
    Case("table-md-readonly", T, lambda c: (["table", "reconstruction", good("a")(c), "--md", c.readonly("ro") + "/t.md"], c.path("ro")), needs_permissions=True),
    Case("table-csv-is-an-input", T, lambda c: (["table", "reconstruction", good("a")(c), good("b")(c), "--csv", c.path("b.json")], c.path("b.json"))),
    Case("table-csv-is-md", T, lambda c: (["table", "reconstruction", good("a")(c), "--csv", c.path("t"), "--md", c.path("t")], c.path("t"))),
    Case("table-kind-unknown", T, lambda c: (["table", "ablation", good("a")(c)], "ablation")),
    Case("table-previous-output-kept", T, table(good("a"), existing_output)),
]


@pytest.mark.parametrize("case", ids_unique(CASES))
def test_bad_input(case, tmp_path, request, capsys):
    check(case, tmp_path, request, capsys)


def test_render_of_an_empty_split_writes_nothing_but_a_good_one_works(model, tscene, tmp_path, capsys):
    """The refusals above are not over-eager: the same model and scene render."""
    code, out, err = run_cli(T, ["render", str(model), str(tscene), str(tmp_path / "r"), "--split", "test", "--no-progress"], capsys)
    assert code == 0, err
    assert sorted(p.name for p in (tmp_path / "r" / "color").iterdir()) == ["test_000.png", "test_001.png", "test_002.png"]
