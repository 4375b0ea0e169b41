"""Bad input to the object-field CLIs ``inpaint360gs segment / associate / distill / remove / run``:
one line on stderr naming the offender, the documented exit code, no traceback, nothing written
(docs/architecture.md, "Reliability"; harness: ``cli_harness``). Inputs are a 32x24 blobs scene
(``scene_builder.blobs_scene``), its exact Gaussian model, the segment and associate stages' outputs
made by the CLIs, and a hand-made distilled field (``object_fields``: blob k is object k).
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest
import torch

import scene_builder as sb
from cli_harness import Case, check, ids_unique, option_cases, out_cases, put, remove, restore_threads, run_cli, truncate  # noqa: F401
from object_fields import labelled_field, write_field
from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.io.ply import write_ply

T = "inpaint360gs"
W, H = 32, 24
VIEW = "IMG_001.png"  # a training view (IMG_000 is held out)


@pytest.fixture(scope="module")
def base(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("bad_object")


def _blobs(root: Path, **kw):
    return sb.blobs_scene(root, n_views=10, width=W, height=H, f=27.5, **kw)


@pytest.fixture(scope="module")
def bscene(base) -> Path:
    return _blobs(base / "bscene")[0]


@pytest.fixture(scope="module")
def bmodel(base, bscene) -> Path:
    model, _ = sb.blobs_model()
    write_ply(base / "model" / "point_cloud.ply", model)
    return base / "model" / "point_cloud.ply"


@pytest.fixture(scope="module")
def other(base) -> Path:
    """Another scene: the same cameras and floor, the blobs elsewhere (same image size)."""
    return _blobs(base / "other", centres=OTHER)[0]


OTHER = ((0.0, 0.5, 0.25), (0.1, -0.5, 0.2))


@pytest.fixture(scope="module")
def other_model(base) -> Path:
    """A model of another room: other blobs on a green floor."""
    from inpaint360gs.core.gaussians import SH_C0

    model, _ = sb.blobs_model(centres=OTHER)
    green = ((torch.tensor([0.05, 0.9, 0.1]) - 0.5) / SH_C0).expand_as(model.sh0).clone()
    write_ply(base / "other_model.ply", Gaussians(**{**model.tensors(), "sh0": green}))
    return base / "other_model.ply"


@pytest.fixture(scope="module")
def segments(base, bscene, bmodel) -> Path:
    from inpaint360gs.cli import main

    out = base / "segments"
    assert main(["segment", str(bscene), str(bmodel), str(out), "--no-progress", "--threads", "2"]) == 0
    return out


@pytest.fixture(scope="module")
def assoc(base, bscene, bmodel, segments) -> Path:
    from inpaint360gs.cli import main

    out = base / "assoc"
    assert main(["associate", str(bscene), str(bmodel), str(segments), str(out)]) == 0
    assert json.loads((out / "objects.json").read_text())["objects"]
    return out


def _field(scene_root: Path, dest: Path, **kw) -> Path:
    from inpaint360gs.io.scene import load_scene

    model, labels = sb.blobs_model(**kw)
    return write_field(dest, labelled_field(model, labels, [0, 1, 2]), load_scene(scene_root))


@pytest.fixture(scope="module")
def distilled(base, bscene) -> Path:
    """A distillation output of ``bscene`` (hand-made: blob 1 is object 1, blob 2 object 2)."""
    return _field(bscene, base / "distilled")


@pytest.fixture(scope="module")
def other_distilled(base, other) -> Path:
    """The same of the other scene."""
    return _field(other, base / "other_distilled", centres=OTHER)


@pytest.fixture(scope="module")
def pixels(bscene, distilled) -> dict:
    """A pixel of object 1, one of the floor and one with nothing, in VIEW (read off the rendered id map)."""
    from inpaint360gs.distill.field import IdentityField
    from inpaint360gs.io.scene import load_scene
    from inpaint360gs.render.api import render

    field = IdentityField.load(distilled)
    cam = load_scene(bscene).view(VIEW).camera
    ids, _ = field.render_ids(cam)
    alpha = render(field.gaussians, cam).alpha.detach()
    pick = lambda m: tuple(int(v) for v in m.nonzero()[0].flip(0))  # (x, y)  # noqa: E731
    return {"object": pick(ids == 1), "floor": pick((ids == 0) & (alpha > 0.9)), "empty": pick(alpha < 1e-3)}


def fixture(c, name: str):
    return c.request.getfixturevalue(name)


def click(c, kind: str) -> str:
    x, y = fixture(c, "pixels")[kind]
    return f"{VIEW}:{x},{y}"


# --- how to spoil the inputs --------------------------------------------------------------------------


def png(path: Path, w: int = W, h: int = H, value: int = 1, dtype=np.uint8) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    assert cv2.imwrite(str(path), np.full((h, w), value, dtype))
    return path


def stem(name: str = VIEW) -> str:
    return Path(name).stem


def ply_no_features(c, folder: Path) -> Path:
    """The distilled folder's point_cloud.ply replaced by the plain 3DGS model (no obj_* features)."""
    shutil.copy2(fixture(c, "bmodel"), folder / "point_cloud.ply")
    return folder / "point_cloud.ply"


def ply_fewer(c, folder: Path) -> Path:
    """point_cloud.ply with Gaussians dropped (distill.json records the original count)."""
    from inpaint360gs.io.ply import read_ply

    g = read_ply(folder / "point_cloud.ply")
    write_ply(folder / "point_cloud.ply", g.subset(torch.arange(len(g)) % 10 != 0))
    return folder / "point_cloud.ply"


def classifier_wider(folder: Path) -> Path:
    """classifier.json for 8 feature channels; the features have 4."""
    p = folder / "classifier.json"
    d = json.loads(p.read_text())
    d["weight"] = [row + [0.0] * 4 for row in d["weight"]]
    d["feature_dim"] = 8
    return put(p, json.dumps(d))


def far_model(c) -> str:
    """The scene's model moved far away: it covers nothing of any view."""
    from inpaint360gs.io.ply import read_ply

    g = read_ply(fixture(c, "bmodel"))
    p = c.tmp / "far.ply"
    write_ply(p, Gaussians(**{**g.tensors(), "means": g.means + torch.tensor([0.0, 0.0, 100.0])}))
    return str(p)


def model_in_run(c) -> str:
    """A copy of the model at ``run/point_cloud.ply`` (as the train stage leaves it)."""
    (c.tmp / "run").mkdir()
    return str(c.copy("bmodel", "run/point_cloud.ply"))


def with_scene_json(data):
    """A copy of the scene with this scene.json."""

    def make(c):
        root = c.copy("bscene")
        put(root / "scene.json", data if isinstance(data, str) else json.dumps(data))
        return root

    return make


# --- segment -----------------------------------------------------------------------------------------


def seg(*extra: str, scene: str = "bscene", model=None, named=None):
    """``segment SCENE MODEL OUT``; ``model(c)`` gives another model path (named by default)."""

    def make(c):
        m = model(c) if model else c.fx("bmodel")
        return ["segment", c.fx(scene), m, c.path("out"), "--no-progress", *extra], named or m

    return make


def seg_scene(fn):
    def make(c):
        root, named = c.broken("bscene", fn)
        return ["segment", str(root), c.fx("bmodel"), c.path("out"), "--no-progress"], str(named)

    return make


BAD_SEGMENT_OPTIONS = {
    "segmenter-unknown": ("--segmenter", "felzenszwalb"),
    "tau-zero": ("--tau", "0"),
    "eps-nan": ("--eps", "nan"),
    "seed-negative": ("--seed", "-1"),
    "resize-zero": ("--resize", "0"),
    "threads-zero": ("--threads", "0"),
    "split-prob-above-one": ("--split-prob", "1.5"),
    "edge-px-negative": ("--edge-px", "-2"),
    "sam-points-zero": ("--sam-points-per-side", "0"),
    "backend-unknown": ("--backend", "opengl"),
}

SEGMENT = [
    *option_cases(T, "segment", lambda c, args: ["segment", c.fx("bscene"), c.fx("bmodel"), c.path("out"), "--no-progress", *args], BAD_SEGMENT_OPTIONS),
    Case("segment-scene-missing", T, lambda c: (["segment", c.path("nope"), c.fx("bmodel"), c.path("out")], c.path("nope"))),
    Case("segment-scene-is-file", T, lambda c: (["segment", c.file("f"), c.fx("bmodel"), c.path("out")], c.path("f"))),
    Case("segment-image-truncated", T, seg_scene(lambda r: truncate(r / "images" / VIEW))),
    Case("segment-image-wrong-size", T, seg_scene(lambda r: sb.write_png(r / "images" / VIEW, np.zeros((H, W + 2, 3), np.uint8)) or r / "images" / VIEW)),
    Case("segment-model-missing", T, seg(model=lambda c: c.path("nope.ply"))),
    Case("segment-model-is-folder", T, seg(model=lambda c: c.dir("m.ply"))),
    Case("segment-model-text", T, seg(model=lambda c: c.file("bad.ply", "not a ply\n"))),
    Case("segment-model-truncated", T, seg(model=lambda c: str(truncate(Path(c.file("bad.ply", Path(c.fx("bmodel")).read_bytes())), 0.6)))),
    Case("segment-model-of-another-scene", T, seg(model=lambda c: c.fx("other_model"))),
    Case("segment-model-far-away", T, seg(model=far_model)),
    Case("segment-oracle-without-gt", T, seg("--segmenter", "oracle", named="gt")),
    Case("segment-sam-encoder-missing", T, seg("--segmenter", "sam", "--sam-encoder", "/nonexistent/enc.onnx", named="/nonexistent/enc.onnx")),
    *out_cases(T, "segment", lambda c: ["segment", c.fx("bscene"), c.fx("bmodel")], ("--no-progress",)),
    Case("segment-out-is-scene", T, lambda c: (lambda r: (["segment", str(r), c.fx("bmodel"), str(r), "--overwrite", "--no-progress"], str(r)))(c.copy("bscene"))),
    Case("segment-out-holds-model", T, lambda c: (["segment", c.fx("bscene"), model_in_run(c), c.path("run"), "--overwrite", "--no-progress"], c.path("run"))),
]


# --- associate ---------------------------------------------------------------------------------------


def asc(*extra: str, segs=None, model=None, named=None):
    """``associate SCENE MODEL SEGMENTS OUT``; ``segs(c)`` a spoilt copy of the segments (path, named)."""

    def make(c):
        s, n = segs(c) if segs else (c.fx("segments"), None)
        m = model(c) if model else c.fx("bmodel")
        return ["associate", c.fx("bscene"), m, str(s), c.path("out"), *extra], str(named or n or m)

    return make


def segs_broken(fn):
    def spoil(c):
        root, named = c.broken("segments", fn)
        return root, named

    return spoil


BAD_ASSOCIATE_OPTIONS = {
    "method-unknown": ("--method", "deva"),
    "variant-unknown": ("--variant", "mine"),
    "sigma-above-one": ("--sigma", "1.5"),
    "sigma-zero": (("--sigma", "0"), "--sigma"),
    "keep-near-zero": (("--keep-near", "0"), "--keep-near"),
    "patch-zero": ("--patch", "0"),
    "min-segment-pixels-negative": ("--min-segment-pixels", "-1"),
    "resize-zero": ("--resize", "0"),
    "llffhold-negative": ("--llffhold", "-8"),
    "other-llffhold-than-segment": (("--llffhold", "0"), "IMG_000.png"),  # IMG_000 trains now: no segments of it
}

ASSOCIATE = [
    *option_cases(T, "associate", lambda c, args: ["associate", c.fx("bscene"), c.fx("bmodel"), c.fx("segments"), c.path("out"), *args], BAD_ASSOCIATE_OPTIONS),
    Case("associate-scene-missing", T, lambda c: (["associate", c.path("nope"), c.fx("bmodel"), c.fx("segments"), c.path("out")], c.path("nope"))),
    Case("associate-segments-missing", T, lambda c: (["associate", c.fx("bscene"), c.fx("bmodel"), c.path("nope"), c.path("out")], c.path("nope"))),
    Case("associate-segments-not-a-segment-output", T, asc(segs=lambda c: (c.dir("empty"), c.path("empty")))),
    Case("associate-segment-json-corrupt", T, asc(segs=segs_broken(lambda r: put(r / "segment.json", "{oops")))),
    Case("associate-segment-png-missing", T, asc(segs=segs_broken(lambda r: remove(r / f"{stem()}.png")))),
    Case("associate-segment-png-corrupt", T, asc(segs=segs_broken(lambda r: put(r / f"{stem()}.png", "not a png")))),
    Case("associate-segment-png-wrong-size", T, asc(segs=segs_broken(lambda r: png(r / f"{stem()}.png", w=W * 2, h=H * 2, dtype=np.uint16)))),
    Case("associate-segment-png-transposed", T, asc(segs=segs_broken(lambda r: png(r / f"{stem()}.png", w=H, h=W, dtype=np.uint16)))),
    Case("associate-segments-of-another-scene", T, asc(segs=lambda c: (lambda o: (o, o / "segment.json"))(c.copy("segments_other")))),
    Case("associate-model-missing", T, asc(model=lambda c: c.path("nope.ply"))),
    Case("associate-model-text", T, asc(model=lambda c: c.file("bad.ply", "not a ply\n"))),
    Case("associate-model-far-away", T, asc(model=far_model)),
    *out_cases(T, "associate", lambda c: ["associate", c.fx("bscene"), c.fx("bmodel"), c.fx("segments")]),
    Case("associate-out-is-segments", T, lambda c: (lambda s: (["associate", c.fx("bscene"), c.fx("bmodel"), str(s), str(s), "--overwrite"], str(s)))(c.copy("segments"))),
    Case("associate-out-is-scene", T, lambda c: (lambda r: (["associate", str(r), c.fx("bmodel"), c.fx("segments"), str(r), "--overwrite"], str(r)))(c.copy("bscene"))),
]


@pytest.fixture(scope="module")
def segments_other(base, other) -> Path:
    """The segment stage's output for the other scene (same view names and size)."""
    from inpaint360gs.cli import main

    model, _ = sb.blobs_model(centres=OTHER)
    write_ply(base / "other_exact.ply", model)
    out = base / "segments_other"
    assert main(["segment", str(other), str(base / "other_exact.ply"), str(out), "--no-progress", "--threads", "2"]) == 0
    return out


# --- distill -----------------------------------------------------------------------------------------

FAST = ["--iterations", "2", "--no-progress", "--threads", "2"]


def dst(*extra: str, assoc=None, model=None, named=None):
    def make(c):
        a, n = assoc(c) if assoc else (c.fx("assoc"), None)
        m = model(c) if model else c.fx("bmodel")
        return ["distill", c.fx("bscene"), m, str(a), c.path("out"), *FAST, *extra], str(named or n or m)

    return make


def assoc_broken(fn):
    return lambda c: c.broken("assoc", fn)


BAD_DISTILL_OPTIONS = {
    "iterations-zero": ("--iterations", "0"),
    "feature-dim-zero": ("--feature-dim", "0"),
    "knn-zero": ("--knn", "0"),
    "knn-sample-negative": ("--knn-sample", "-1"),
    "lambda-space-negative": ("--lambda-space", "-0.1"),
    "features-lr-zero": ("--features-lr", "0"),
    "classifier-lr-inf": ("--classifier-lr", "inf"),
    "min-weight-nan": ("--min-weight", "nan"),
    "seed-word": ("--seed", "one"),
}

DISTILL = [
    *option_cases(T, "distill", lambda c, args: ["distill", c.fx("bscene"), c.fx("bmodel"), c.fx("assoc"), c.path("out"), *FAST, *args], BAD_DISTILL_OPTIONS),
    Case("distill-scene-missing", T, lambda c: (["distill", c.path("nope"), c.fx("bmodel"), c.fx("assoc"), c.path("out"), *FAST], c.path("nope"))),
    Case("distill-assoc-missing", T, lambda c: (["distill", c.fx("bscene"), c.fx("bmodel"), c.path("nope"), c.path("out"), *FAST], c.path("nope"))),
    Case("distill-assoc-no-objects-json", T, dst(assoc=assoc_broken(lambda r: remove(r / "objects.json", r)))),
    Case("distill-assoc-no-mask-folder", T, dst(assoc=assoc_broken(lambda r: remove(r / "object_mask", r)))),
    Case("distill-objects-json-corrupt", T, dst(assoc=assoc_broken(lambda r: put(r / "objects.json", "{oops")))),
    Case("distill-objects-json-bad-id", T, dst(assoc=assoc_broken(lambda r: put(r / "objects.json", json.dumps({"objects": [{"id": 300}]}))))),
    Case("distill-mask-missing", T, dst(assoc=assoc_broken(lambda r: remove(r / "object_mask" / f"{stem()}.png", r / "object_mask")))),
    Case("distill-mask-corrupt", T, dst(assoc=assoc_broken(lambda r: put(r / "object_mask" / f"{stem()}.png", "not a png")))),
    Case("distill-mask-wrong-size", T, dst(assoc=assoc_broken(lambda r: png(r / "object_mask" / f"{stem()}.png", w=W + 1)))),
    Case("distill-mask-unlisted-id", T, dst(assoc=assoc_broken(lambda r: png(r / "object_mask" / f"{stem()}.png", value=9)))),
    Case("distill-model-missing", T, dst(model=lambda c: c.path("nope.ply"))),
    Case("distill-model-text", T, dst(model=lambda c: c.file("bad.ply", "not a ply\n"))),
    Case("distill-model-far-away", T, dst(model=far_model)),
    *out_cases(T, "distill", lambda c: ["distill", c.fx("bscene"), c.fx("bmodel"), c.fx("assoc")], tuple(FAST)),
    Case("distill-out-is-assoc", T, lambda c: (lambda a: (["distill", c.fx("bscene"), c.fx("bmodel"), str(a), str(a), *FAST, "--overwrite"], str(a)))(c.copy("assoc"))),
    Case("distill-out-holds-model", T, lambda c: (["distill", c.fx("bscene"), model_in_run(c), c.fx("assoc"), c.path("run"), *FAST, "--overwrite"], c.path("run"))),
]


# --- remove ------------------------------------------------------------------------------------------


def rm(*sel: str, dist=None, scene: str = "bscene", named=None):
    """``remove SCENE DISTILL OUT SEL...``; ``dist(c)`` a spoilt copy of the distilled folder (path, named)."""

    def make(c):
        d, n = dist(c) if dist else (c.fx("distilled"), None)
        args = [a(c) if callable(a) else a for a in sel]
        return ["remove", c.fx(scene), str(d), c.path("out"), *args, "--threads", "2"], str(named or n)

    return make


def dist_broken(fn):
    return lambda c: c.broken("distilled", fn)


def dist_broken_c(fn):
    """``fn(c, root)``: a spoiler that needs the case's context."""
    return lambda c: c.broken("distilled", lambda r: fn(c, r))


BAD_REMOVE_OPTIONS = {
    "id-zero": ("--id", "0"),
    "id-word": ("--id", "blob"),
    "threshold-above-one": ("--threshold", "1.5"),
    "threshold-nan": ("--threshold", "nan"),
    "resize-zero": ("--resize", "0"),
    "llffhold-negative": ("--llffhold", "-1"),
}

BAD_CLICKS = ["IMG_001.png", "IMG_001.png:5", "IMG_001.png:5,6,7", "IMG_001.png:x,y", "IMG_001.png:inf,3", "IMG_001.png:nan,3", ":5,6", "5,6"]

REMOVE = [
    *option_cases(T, "remove", lambda c, args: ["remove", c.fx("bscene"), c.fx("distilled"), c.path("out"), "--id", "1", *args], BAD_REMOVE_OPTIONS),
    *[Case(f"remove-click-malformed-{i}", T, rm("--click", text, named=text)) for i, text in enumerate(BAD_CLICKS)],
    Case("remove-nothing-selected", T, rm(named="--click")),
    Case("remove-unknown-id", T, rm("--id", "9", named="--id")),
    Case("remove-unknown-id-beside-a-good-one", T, rm("--id", "1", "--id", "5", named="unknown object id 5")),
    Case("remove-click-on-the-floor", T, rm("--click", lambda c: click(c, "floor"), named="on the support surface")),
    Case("remove-click-on-nothing", T, rm("--click", lambda c: click(c, "empty"), named="on empty space")),
    Case("remove-click-outside-the-image", T, rm("--click", f"{VIEW}:{W},{H // 2}", named=f"outside the {W}x{H} image")),
    Case("remove-click-negative", T, rm("--click", f"{VIEW}:-1,3", named="outside")),
    Case("remove-click-unknown-view", T, rm("--click", "IMG_999.png:3,3", named="IMG_999.png")),
    Case("remove-click-on-a-test-view", T, rm("--click", "test_000.png:3,3", named="test_000.png")),
    Case("remove-scene-json-click-outside", T, lambda c: (["remove", str(with_scene_json({"clicks": [{"view": VIEW, "x": 3, "y": 99}]})(c)), c.fx("distilled"),
                                                           c.path("out")], ("scene.json", "outside"))),  # fmt: skip
    Case("remove-scene-json-clicks-malformed", T, lambda c: (["remove", str(with_scene_json({"clicks": "IMG_001.png:3,4"})(c)), c.fx("distilled"), c.path("out")],
                                                              "scene.json")),  # fmt: skip
    Case("remove-scene-missing", T, lambda c: (["remove", c.path("nope"), c.fx("distilled"), c.path("out"), "--id", "1"], c.path("nope"))),
    Case("remove-distill-missing", T, lambda c: (["remove", c.fx("bscene"), c.path("nope"), c.path("out"), "--id", "1"], c.path("nope"))),
    Case("remove-no-classifier", T, rm("--id", "1", dist=dist_broken(lambda r: remove(r / "classifier.json")))),
    Case("remove-classifier-corrupt", T, rm("--id", "1", dist=dist_broken(lambda r: put(r / "classifier.json", "{oops")))),
    Case("remove-classifier-other-width", T, rm("--id", "1", dist=dist_broken(classifier_wider))),
    Case("remove-no-point-cloud", T, rm("--id", "1", dist=dist_broken(lambda r: remove(r / "point_cloud.ply")))),
    Case("remove-point-cloud-truncated", T, rm("--id", "1", dist=dist_broken(lambda r: truncate(r / "point_cloud.ply", 0.6)))),
    Case("remove-point-cloud-without-features", T, rm("--id", "1", dist=dist_broken_c(ply_no_features))),
    Case("remove-point-cloud-other-count", T, rm("--id", "1", dist=dist_broken_c(ply_fewer))),
    Case("remove-distill-json-corrupt", T, rm("--id", "1", dist=dist_broken(lambda r: put(r / "distill.json", "{oops")))),
    Case("remove-distilled-from-another-scene", T, lambda c: (["remove", c.fx("bscene"), c.fx("other_distilled"), c.path("out"), "--id", "1"],
                                                               str(Path(c.fx("other_distilled")) / "distill.json"))),  # fmt: skip
    *out_cases(T, "remove", lambda c: ["remove", c.fx("bscene"), c.fx("distilled")], ("--id", "1")),
    Case("remove-out-is-distill", T, lambda c: (lambda d: (["remove", c.fx("bscene"), str(d), str(d), "--id", "1", "--overwrite"], str(d)))(c.copy("distilled"))),
    Case("remove-out-is-scene", T, lambda c: (lambda r: (["remove", str(r), c.fx("distilled"), str(r), "--id", "1", "--overwrite"], str(r)))(c.copy("bscene"))),
]


# --- run ---------------------------------------------------------------------------------------------

RUN_FAST = ["--no-progress", "--threads", "2", "--iterations", "2", "--distill-iterations", "2", "--until", "segment"]


def rn(*extra: str, named, scene=None, out=None):
    """``run SCENE OUT --model MODEL ...`` (a run that wrongly goes ahead stays short)."""

    def make(c):
        s = scene(c) if scene else c.fx("bscene")
        o = out(c) if out else c.path("out")
        args = [a(c) if callable(a) else a for a in extra]
        return ["run", str(s), str(o), *RUN_FAST, *args], named(c) if callable(named) else named

    return make


BAD_RUN_OPTIONS = {
    "until-unknown": ("--until", "render"),
    "iterations-zero": ("--iterations", "0"),
    "distill-iterations-zero": ("--distill-iterations", "0"),
    "segmenter-unknown": ("--segmenter", "slic"),
    "association-unknown": ("--association", "deva"),
    "id-zero": ("--id", "0"),
    "max-gaussians-negative": ("--max-gaussians", "-1"),
}

RUN = [
    *option_cases(T, "run", lambda c, args: ["run", c.fx("bscene"), c.path("out"), *RUN_FAST, "--id", "1", *args], BAD_RUN_OPTIONS),
    Case("run-scene-missing", T, lambda c: (["run", c.path("nope"), c.path("out"), "--id", "1"], c.path("nope"))),
    Case("run-scene-is-file", T, lambda c: (["run", c.file("f"), c.path("out"), "--id", "1"], c.path("f"))),
    Case("run-model-missing", T, rn("--id", "1", "--model", lambda c: c.path("nope.ply"), named=lambda c: c.path("nope.ply"))),
    Case("run-model-text", T, rn("--id", "1", "--model", lambda c: c.file("bad.ply", "not a ply\n"), named=lambda c: c.path("bad.ply"))),
    Case("run-model-of-another-scene", T, rn("--id", "1", "--model", lambda c: c.fx("other_model"), named=lambda c: c.fx("other_model"))),
    *[Case(f"run-click-malformed-{i}", T, rn("--click", text, named=text)) for i, text in enumerate(BAD_CLICKS)],
    Case("run-nothing-selected", T, rn(named="--click")),
    Case("run-click-outside-the-image", T, rn("--click", f"{VIEW}:{W + 3},1", named=f"outside the {W}x{H} image")),
    Case("run-click-unknown-view", T, rn("--click", "IMG_999.png:3,3", named="IMG_999.png")),
    Case("run-click-on-a-test-view", T, rn("--click", "test_001.png:3,3", named="test_001.png")),
    Case("run-scene-json-clicks-malformed", T, rn(named="scene.json", scene=with_scene_json({"clicks": [{"view": VIEW, "x": "left"}]}))),
    Case("run-scene-json-click-outside", T, rn(named=("scene.json", "outside"), scene=with_scene_json({"clicks": [{"view": VIEW, "x": 500, "y": 3}]}))),
    Case("run-scene-json-corrupt", T, rn("--id", "1", named="scene.json", scene=with_scene_json("{oops"))),
    *out_cases(T, "run", lambda c: ["run", c.fx("bscene")], ("--id", "1", *RUN_FAST), kinds=("out-is-file", "out-under-file", "out-readonly")),
    Case("run-out-not-a-run", T, rn("--id", "1", named=lambda c: c.path("out"), out=lambda c: Path(c.file("out/keep.txt", "precious")).parent)),
    Case("run-out-is-scene", T, lambda c: (lambda r: (["run", str(r), str(r), "--id", "1", *RUN_FAST], str(r)))(c.copy("bscene"))),
]


CASES = [*SEGMENT, *ASSOCIATE, *DISTILL, *REMOVE, *RUN]


@pytest.mark.parametrize("case", ids_unique(CASES))
def test_bad_input(case, tmp_path, request, capsys):
    check(case, tmp_path, request, capsys)


# --- the refusals are not over-eager: the same inputs, put right, work --------------------------------


def test_good_inputs_go_through(bscene, distilled, pixels, tmp_path, capsys):
    x, y = pixels["object"]
    code, out, err = run_cli(T, ["remove", str(bscene), str(distilled), str(tmp_path / "r"), "--click", f"{VIEW}:{x},{y}", "--threads", "2"], capsys)
    assert code == 0, err
    assert json.loads((tmp_path / "r" / "removal.json").read_text())["objects"] == [1]
    code, out, err = run_cli(T, ["remove", str(bscene), str(distilled), str(tmp_path / "r"), "--id", "2", "--overwrite", "--threads", "2"], capsys)
    assert code == 0, err
    assert json.loads((tmp_path / "r" / "removal.json").read_text())["objects"] == [2]


def test_remove_takes_the_clicks_scene_json_names(bscene, distilled, pixels, tmp_path, capsys):
    root = shutil.copytree(bscene, tmp_path / "scene")
    x, y = pixels["object"]
    (root / "scene.json").write_text(json.dumps({"clicks": [{"object": 1, "view": VIEW, "x": x, "y": y}]}))
    # distill.json's hash is of the scene's content, not of its name or scene.json: the copy matches
    code, _, err = run_cli(T, ["remove", str(root), str(distilled), str(tmp_path / "r"), "--threads", "2"], capsys)
    assert code == 0, err
    rec = json.loads((tmp_path / "r" / "removal.json").read_text())
    assert rec["objects"] == [1] and rec["clicks"] == [f"{VIEW}:{x},{y}"]


def test_associate_follows_the_segment_stage_hold_out(bscene, bmodel, tmp_path, capsys):
    """``--llffhold`` as given to ``segment``: every view trains with 0, and association finds its segments."""
    seg, out = tmp_path / "seg", tmp_path / "assoc"
    code, _, err = run_cli(T, ["segment", str(bscene), str(bmodel), str(seg), "--llffhold", "0", "--no-progress", "--threads", "2"], capsys)
    assert code == 0, err
    code, _, err = run_cli(T, ["associate", str(bscene), str(bmodel), str(seg), str(out), "--llffhold", "0"], capsys)
    assert code == 0, err
    assert (out / "object_mask" / "IMG_000.png").is_file()
