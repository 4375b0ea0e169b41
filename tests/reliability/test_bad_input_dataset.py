"""Bad input to ``inpaint360gs-dataset synth / build / validate / unseen-masks / import / synth-colmap``:
one line, a documented exit code, nothing written, checked before any SfM or rendering
(docs/architecture.md, "Reliability"). No case here runs SfM."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest

import scene_builder as sb
from cli_harness import Case, check, duplicate, garbage_count, ids_unique, option_cases, out_cases, put, remove, run_cli, truncate
from dataset_tools.capture.leaks import remove_leaked_points
from test_build_importers import _source, _usid_name

D = "inpaint360gs-dataset"
SYNTH_SMALL = ["--reduced", "--width", "48", "--height", "36", "--quiet"]


def _img(path: Path, w: int = 32, h: int = 24, seed: int = 0) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    assert cv2.imwrite(str(path), np.random.default_rng(seed).integers(0, 256, (h, w, 3), dtype=np.uint8))
    return path


def _mask(path: Path, w: int, h: int, value: int = 255) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    assert cv2.imwrite(str(path), np.full((h, w), value, np.uint8))
    return path


@pytest.fixture(scope="module")
def base(tmp_path_factory) -> Path:
    return tmp_path_factory.mktemp("bad_dataset")


@pytest.fixture(scope="module")
def captures(base) -> Path:
    """with_objects/IMG_000..003.png + without_objects/IMG_100..101.png, 32x24, all different."""
    root = base / "captures"
    for i in range(4):
        _img(root / "with_objects" / f"IMG_{i:03d}.png", seed=i)
    for i in range(2):
        _img(root / "without_objects" / f"IMG_{100 + i:03d}.png", seed=100 + i)
    return root


@pytest.fixture(scope="module")
def box(base) -> Path:
    """A valid hand-made scene folder (160x120, IMG_000..007 + test_000..001, unseen masks, no leaks)."""
    root = base / "box"
    rec = sb.write_box_scene(sb.box_scene(), root)
    remove_leaked_points(rec)
    rec.write(root / "sparse" / "0")
    return root


@pytest.fixture(scope="module")
def objmasks(base) -> Path:
    """Exact object masks of the box scene's training views."""
    root = base / "objmasks"
    root.mkdir()
    for cam in sb.box_scene().cameras:
        if not cam.name.startswith("test_"):
            cv2.imwrite(str(root / cam.name), sb.box_mask(cam).astype(np.uint8) * 255)
    return root


@pytest.fixture(scope="module")
def usid(base) -> Path:
    src, _, exact = _source(base / "usid_src", _usid_name)
    for name, m in exact.items():
        _mask(src / "unseen_masks" / name, 160, 120)
    return src


@pytest.fixture(scope="module")
def spinnerf(base) -> Path:
    src, _, exact = _source(base / "spin_src", lambda n: ("images", "A" + n.removeprefix("test_")) if n.startswith("test_") else ("images", "B" + n))
    for name in exact:
        _mask(src / "images_2" / "label" / name, 80, 60, 1)
    return src


@pytest.fixture(scope="module")
def synth(base) -> Path:
    from dataset_tools.cli import main

    assert main(["synth", str(base / "synth"), "--scenes", "cone", *SYNTH_SMALL]) == 0
    return base / "synth" / "cone"


# --- helpers that prepare one input and return what the error must name -------------------------


class _Names(dict):
    """``str.format_map`` names: ``{tmp}``, ``{root}`` and any fixture by name (``{objmasks}``)."""

    def __init__(self, c, **known):
        super().__init__(tmp=c.tmp, **known)
        self.c = c

    def __missing__(self, key):
        return self.c.fx(key)


def cmd(stage: str, fixture: str, fn=None, *extra: str, out: str | None = "out", named=None):
    """``<stage> ROOT [OUT] extra...`` with ROOT the fixture (or a copy broken by ``fn``); the error must
    name what ``fn`` returned, or ``named``. ``extra`` and ``named`` may use the ``_Names`` fields."""

    def make(c):
        root, what = c.broken(fixture, fn) if fn else (c.fx(fixture), None)
        names = _Names(c, root=root)
        args = [stage, str(root)] + ([c.path(out)] if out else []) + [a.format_map(names) for a in extra]
        return args, str(named.format_map(names) if named else what)

    return make


def build(fn=None, *extra: str, named=None):
    return cmd("build", "captures", fn, *extra, "--no-progress", named=named)


def validate_fails(fn, *extra: str, check_name: str):
    """``validate`` of a broken copy of the box scene: the report FAILs ``check_name`` (exit 2, one line)."""
    return lambda c: (["validate", str(c.broken("box", fn)[0]), *extra], check_name)


def unseen(fn=None, *extra: str, named=None):
    return cmd("unseen-masks", "box", fn, *extra, out=None, named=named)


def strip_unseen(root: Path) -> None:
    shutil.rmtree(root / "unseen_mask")


def with_objmasks(fn):
    """Object masks copied into the case folder and passed through ``fn(folder) -> named``."""

    def make(c):
        masks = c.copy("objmasks")
        named = fn(masks)
        root, _ = c.broken("box", strip_unseen)
        return ["unseen-masks", str(root), "--object-masks", str(masks)], str(named)

    return make


def build_masks(fn):
    """``build --unseen-masks M`` with one valid mask per object-free photo in M, passed through ``fn(M) -> named``."""

    def make(c):
        masks = c.tmp / "m"
        for name in ("IMG_100.png", "IMG_101.png"):
            _mask(masks / name, 32, 24)
        named = fn(masks)
        return ["build", c.fx("captures"), c.path("out"), "--unseen-masks", str(masks), "--no-progress"], str(named)

    return make


def with_import(fn):
    """A folder of user unseen masks (one valid per test_ view), passed through ``fn(folder) -> named``."""

    def make(c):
        masks = c.tmp / "user"
        for name in ("test_000.png", "test_001.png"):
            _mask(masks / name, 160, 120, 0)
        named = fn(masks)
        root, _ = c.broken("box", strip_unseen)
        return ["unseen-masks", str(root), "--import", str(masks)], str(named)

    return make


def imp(layout: str, fixture: str, fn=None, *extra: str, named=None):
    def make(c):
        args, what = cmd(layout, fixture, fn, *extra, named=named)(c)
        return ["import", *args], what

    return make


def synth_colmap(fn=None, *extra: str, named=None):
    return cmd("synth-colmap", "synth", fn, *extra, "--no-progress", named=named)


def copied(fixture: str, src: str, dst: str):
    """``build`` (captures) or ``import 360usid`` (usid) with a byte-identical copy of ``src`` at ``dst``;
    the error must name both files."""

    def make(c):
        root, _ = c.broken(fixture, lambda r: duplicate(r / src, r / dst))
        argv = ["build", str(root), c.path("out"), "--no-progress"] if fixture == "captures" else ["import", "360usid", str(root), c.path("out")]
        return argv, (str(root / src), str(root / dst))

    return make


def no_object_free(fn=None, *extra: str):
    """``build`` of the captures without without_objects/ (photos with the objects only: a scene without
    ground truth, accepted), broken by ``fn(root) -> (what the error must name, ...)``."""

    def make(c):
        root, _ = c.broken("captures", lambda r: remove(r / "without_objects"))
        named = fn(root)
        return ["build", str(root), c.path("out"), *[a.format_map(_Names(c, root=root)) for a in extra], "--no-progress"], named

    return make


def emptied(folder: Path) -> Path:
    remove(folder).mkdir()
    return folder


def first(folder: Path, pattern: str = "*.png") -> Path:
    return sorted(folder.glob(pattern))[0]


BAD_SYNTH_OPTIONS = {  # case -> the wrong options after `--scenes cone` (the error names the first flag, or what is given)
    "unknown-scene": (("--scenes", "cone", "nope"), "nope"),
    "empty-scene-name": (("--scenes", ""), "''"),
    "width-only": (("--width", "64"), "--height"),
    "size-too-small": ("--width", "4", "--height", "4"),
    "width-nan": ("--width", "nan", "--height", "36"),
    "height-negative": (("--width", "48", "--height", "-36"), "--height"),
    "seed-negative": ("--seed", "-1"),
    "seed-float": ("--seed", "1.5"),
}

BAD_BUILD_OPTIONS = {  # case -> the wrong options (all refused before SfM; the error names the first flag)
    "camera-params-count": ("--camera-params", "1,2"),
    "camera-params-count-pinhole": (("--camera-model", "PINHOLE", "--camera-params", "100,100,16"), "--camera-params"),
    "camera-params-words": ("--camera-params", "a,b,c,d"),
    "camera-params-nan": ("--camera-params", "nan,16,12,0"),
    "camera-params-zero-focal": ("--camera-params", "0,16,12,0"),
    "camera-model-unknown": ("--camera-model", "FISHEYE"),
    "unknown-option": ("--vocab-tree", "x.bin"),
    "downscale-zero": ("--downscale", "0"),
    "downscale-negative": ("--downscale", "2", "-4"),
    "max-features-zero": ("--max-features", "0"),
    "threads-zero": ("--threads", "0"),
    "overlap-negative": ("--overlap", "-1"),
    "cross-pairs-zero": ("--cross-pairs", "0"),
    "exhaustive-max-nan": ("--exhaustive-max", "nan"),
    "min-train-views-zero": ("--min-train-views", "0"),
    "min-train-angle-nan": ("--min-train-angle", "nan"),
    "min-train-angle-90": ("--min-train-angle", "90"),
    "seed-negative": ("--seed", "-3"),
    "remove-unseen-points-without-masks": ("--remove-unseen-points",),
    "matcher-unknown": ("--matcher", "vocab"),
    "sfm-max-size-negative": ("--sfm-max-size", "-1"),
    "sfm-max-size-words": ("--sfm-max-size", "big"),
    "min-registered-above-one": ("--min-registered", "1.5"),
    "min-registered-nan": ("--min-registered", "nan"),
    "partial-and-all-registered": (("--allow-partial", "--require-all-registered"), "--require-all-registered"),
}

CASES = [
    # synth
    *option_cases(D, "synth", lambda c, args: ["synth", c.path("out"), "--scenes", "cone", *args, "--quiet"], BAD_SYNTH_OPTIONS),
    Case("synth-missing-out", D, lambda c: (["synth", "--scenes", "cone", "--quiet"], "OUT")),
    Case("synth-scene-folder-is-file", D, lambda c: (["synth", c.path("out"), "--scenes", "cone", "--quiet"], c.file("out/cone"))),
    *out_cases(D, "synth", lambda c: ["synth"], ("--scenes", "cone", "--quiet"), kinds=("out-is-file", "out-under-file")),
    Case("synth-scene-exists", D, lambda c: (["synth", c.path("out"), "--scenes", "cone", *SYNTH_SMALL], c.file("out/cone/keep.txt") and c.path("out/cone"))),
    Case("synth-out-readonly", D, lambda c: (["synth", c.readonly("ro"), "--scenes", "cone", "--quiet"], c.path("ro")), needs_permissions=True),
    # build: arguments (all refused before SfM)
    *option_cases(D, "build", lambda c, args: ["build", c.fx("captures"), c.path("out"), "--no-progress", *args], BAD_BUILD_OPTIONS),
    Case("build-unseen-masks-missing", D, build(None, "--unseen-masks", "{tmp}/nope", named="{tmp}/nope")),
    # build: the photos
    Case("build-captures-missing", D, lambda c: (["build", c.path("nope"), c.path("out"), "--no-progress"], c.path("nope"))),
    Case("build-captures-is-file", D, lambda c: (["build", c.file("f.png"), c.path("out"), "--no-progress"], c.path("f.png"))),
    Case("build-captures-empty", D, lambda c: (["build", c.dir("empty"), c.path("out"), "--no-progress"], c.path("empty"))),
    Case("build-no-object-inclusive", D, build(lambda r: emptied(r / "with_objects"))),
    Case("build-no-object-free", D, build(lambda r: emptied(r / "without_objects"))),
    # photos with the objects only (no without_objects/) are a scene without ground truth; still refused:
    Case("build-no-object-free-one-photo", D, no_object_free(lambda r: [remove(p) for p in sorted((r / "with_objects").iterdir())[1:]] and str(r / "with_objects"))),
    Case("build-no-object-free-duplicate-photo", D, no_object_free(lambda r: (str(r / "with_objects" / "IMG_001.png"), str(duplicate(r / "with_objects" / "IMG_001.png", r / "with_objects" / "IMG_009.png"))))),
    Case("build-no-object-free-truncated-photo", D, no_object_free(lambda r: str(truncate(r / "with_objects" / "IMG_002.png")))),
    Case("build-no-object-free-unseen-masks", D, no_object_free(lambda r: _mask(r.parent / "m" / "IMG_000.png", 32, 24) and "--unseen-masks", "--unseen-masks", "{tmp}/m")),
    Case("build-duplicate-photo", D, copied("captures", "with_objects/IMG_001.png", "with_objects/IMG_009.png")),
    Case("build-object-free-photo-in-training", D, copied("captures", "without_objects/IMG_100.png", "with_objects/IMG_050.png")),
    Case("build-training-photo-in-object-free", D, copied("captures", "with_objects/IMG_002.png", "without_objects/IMG_150.png")),
    Case("build-same-stem-two-suffixes", D, build(lambda r: _img(r / "with_objects" / "IMG_001.jpg", seed=7))),
    Case("build-reserved-prefix", D, build(lambda r: _img(r / "with_objects" / "test_x.png", seed=8))),
    Case("build-truncated-png", D, build(lambda r: truncate(r / "with_objects" / "IMG_002.png"))),
    Case("build-truncated-jpeg", D, build(lambda r: truncate(put(r / "with_objects" / "IMG_009.jpg", cv2.imencode(".jpg", np.full((24, 32, 3), 90, np.uint8))[1].tobytes()), 0.6))),
    Case("build-zero-byte-photo", D, build(lambda r: put(r / "without_objects" / "IMG_101.png", b""))),
    Case("build-text-named-png", D, build(lambda r: put(r / "with_objects" / "IMG_000.png", "just text"))),
    Case("build-mixed-resolution", D, build(lambda r: _img(r / "with_objects" / "IMG_007.png", w=40, seed=7))),
    Case("build-unseen-mask-wrong-size", D, build_masks(lambda m: _mask(m / "IMG_101.png", 32, 12))),
    Case("build-unseen-mask-missing-one", D, build_masks(lambda m: remove(m / "IMG_101.png").name)),
    Case("build-unseen-mask-corrupt", D, build_masks(lambda m: put(m / "IMG_101.png", "text"))),
    *out_cases(D, "build", lambda c: ["build", c.fx("captures")], ("--no-progress",)),
    Case("build-out-is-captures", D, lambda c: (["build", str(c.copy("captures")), str(c.tmp / "captures"), "--overwrite", "--no-progress"], c.path("captures"))),
    # validate
    Case("validate-json-is-folder", D, lambda c: (["validate", c.fx("box"), "--json", c.path("j")], c.file("j/x") and c.path("j"))),
    Case("validate-json-under-file", D, lambda c: (["validate", c.fx("box"), "--json", c.file("f") + "/r.json"], c.path("f"))),
    Case("validate-json-readonly", D, lambda c: (["validate", c.fx("box"), "--json", c.readonly("ro") + "/r.json"], c.path("ro")), needs_permissions=True),
    Case("validate-json-over-scene-file", D, lambda c: (["validate", str(c.copy("box")), "--json", c.path("box/scene.json")], "--json")),
    Case("validate-json-into-images", D, lambda c: (["validate", str(c.copy("box")), "--json", c.path("box/images/r.json")], "--json")),
    Case("validate-scene-is-file", D, lambda c: (["validate", c.file("scene")], c.path("scene"))),
    Case("validate-scene-missing", D, lambda c: (["validate", c.path("nope")], c.path("nope"))),
    Case("validate-unseen-mask-for-missing-view", D, validate_fails(lambda r: _mask(r / "unseen_mask" / "test_007.png", 160, 120), check_name="test_007.png")),
    Case("validate-unseen-mask-for-training-view", D, validate_fails(lambda r: _mask(r / "unseen_mask" / "IMG_001.png", 160, 120), check_name="IMG_001.png")),
    Case("validate-object-mask-for-missing-view", D, validate_fails(lambda r: _mask(r / "object_mask" / "IMG_042.png", 160, 120), check_name="IMG_042.png")),
    Case("validate-corrupt-sparse", D, validate_fails(lambda r: garbage_count(r / "sparse" / "0"), check_name="points3D.bin")),
    Case("validate-unregistered", D, validate_fails(lambda r: _img(r / "images" / "IMG_999.png", 160, 120), check_name="IMG_999.png")),
    Case("validate-truncated-image", D, validate_fails(lambda r: truncate(r / "images" / "IMG_003.png"), check_name="IMG_003.png")),
    Case("validate-duplicate-test-image", D, validate_fails(lambda r: duplicate(r / "images" / "IMG_004.png", r / "images" / "test_001.png"), check_name="test_001.png")),
    # unseen-masks
    Case("unseen-scene-missing", D, lambda c: (["unseen-masks", c.path("nope"), "--object-masks", c.fx("objmasks")], c.path("nope"))),
    Case("unseen-no-source", D, lambda c: (["unseen-masks", c.fx("box")], "--object-masks")),
    Case("unseen-both-sources", D, lambda c: (["unseen-masks", c.fx("box"), "--object-masks", c.fx("objmasks"), "--import", c.fx("objmasks")], "--import")),
    Case("unseen-object-masks-missing", D, unseen(strip_unseen, "--object-masks", "{tmp}/nope", named="{tmp}/nope")),
    Case("unseen-import-missing", D, unseen(strip_unseen, "--import", "{tmp}/nope", named="{tmp}/nope")),
    Case("unseen-dilate-negative", D, lambda c: (["unseen-masks", c.fx("box"), "--object-masks", c.fx("objmasks"), "--mask-dilate", "-1"], "--mask-dilate")),
    Case("unseen-dilate-nan", D, lambda c: (["unseen-masks", c.fx("box"), "--object-masks", c.fx("objmasks"), "--mask-dilate", "nan"], "--mask-dilate")),
    Case("unseen-exists", D, unseen(None, "--object-masks", "{objmasks}", named="{root}/unseen_mask")),
    Case("unseen-target-is-file", D, unseen(lambda r: strip_unseen(r) or put(r / "unseen_mask", "x"), "--object-masks", "{objmasks}", "--overwrite")),
    Case("unseen-object-mask-missing", D, with_objmasks(lambda m: remove(m / "IMG_005.png").name)),
    Case("unseen-object-mask-wrong-size", D, with_objmasks(lambda m: _mask(m / "IMG_002.png", 80, 60))),
    Case("unseen-object-mask-corrupt", D, with_objmasks(lambda m: put(m / "IMG_002.png", "not a mask"))),
    Case("unseen-object-mask-zero-bytes", D, with_objmasks(lambda m: put(m / "IMG_006.png", b""))),
    Case("unseen-object-mask-truncated", D, with_objmasks(lambda m: truncate(m / "IMG_006.png", 0.6))),
    Case("unseen-import-wrong-size", D, with_import(lambda m: _mask(m / "test_001.png", 80, 60))),
    Case("unseen-import-missing-one", D, with_import(lambda m: remove(m / "test_000.png").name)),
    Case("unseen-import-corrupt", D, with_import(lambda m: put(m / "test_000.png", b"\x89PNG\r\n\x1a\n" + bytes(40)))),
    Case("unseen-no-sparse", D, unseen(lambda r: strip_unseen(r) or remove(r / "sparse", r / "sparse" / "0"), "--object-masks", "{objmasks}")),
    Case("unseen-no-images", D, unseen(lambda r: strip_unseen(r) or remove(r / "images"), "--import", "{objmasks}")),
    Case("unseen-import-into-target", D, unseen(lambda r: r / "unseen_mask", "--import", "{root}/unseen_mask", "--overwrite")),
    # import
    Case("import-layout-unknown", D, lambda c: (["import", "llff", c.fx("usid"), c.path("out")], "llff")),
    Case("import-src-missing", D, lambda c: (["import", "360usid", c.path("nope"), c.path("out")], c.path("nope"))),
    Case("import-usid-no-test-images", D, imp("360usid", "usid", lambda r: remove(r / "test_images"))),
    Case("import-usid-no-unseen-masks", D, imp("360usid", "usid", lambda r: remove(r / "unseen_masks"))),
    Case("import-usid-mask-wrong-size", D, imp("360usid", "usid", lambda r: _mask(r / "unseen_masks" / "001.png", 80, 60))),
    Case("import-usid-mask-corrupt", D, imp("360usid", "usid", lambda r: put(r / "unseen_masks" / "001.png", "no"))),
    Case("import-usid-no-sparse", D, imp("360usid", "usid", lambda r: remove(r / "sparse", r / "sparse" / "0"))),
    Case("import-usid-corrupt-sparse", D, imp("360usid", "usid", lambda r: garbage_count(r / "sparse" / "0"))),
    Case("import-usid-truncated-image", D, imp("360usid", "usid", lambda r: truncate(r / "images" / "IMG_002.png"))),
    Case("import-usid-image-wrong-size", D, imp("360usid", "usid", lambda r: _img(r / "images" / "IMG_002.png", 100, 120))),
    Case("import-usid-reserved-prefix", D, imp("360usid", "usid", lambda r: (r / "images" / "IMG_002.png").rename(r / "images" / "test_9.png") or r / "images" / "test_9.png")),
    Case("import-usid-ground-truth-in-training", D, copied("usid", "test_images/000.png", "images/IMG_000.png")),
    Case("import-usid-duplicate-training-photo", D, copied("usid", "images/IMG_001.png", "images/IMG_003.png")),
    Case("import-spinnerf-n-test-zero", D, imp("spinnerf", "spinnerf", None, "--n-test", "0", named="--n-test")),
    Case("import-spinnerf-n-test-too-many", D, imp("spinnerf", "spinnerf", None, "--n-test", "50", named="--n-test")),
    Case("import-spinnerf-no-labels", D, imp("spinnerf", "spinnerf", lambda r: remove(r / "images_2", r), "--n-test", "2")),
    Case("import-spinnerf-label-missing", D, imp("spinnerf", "spinnerf", lambda r: remove(r / "images_2" / "label" / "A001.png").name, "--n-test", "2")),
    *out_cases(D, "import", lambda c: ["import", "360usid", c.fx("usid")]),
    Case("import-out-is-src", D, lambda c: (["import", "360usid", str(c.copy("usid", "usid")), c.path("usid"), "--overwrite"], c.path("usid"))),
    # synth-colmap
    Case("synth-colmap-scene-missing", D, lambda c: (["synth-colmap", c.path("nope"), c.path("out")], c.path("nope"))),
    Case("synth-colmap-not-generated", D, lambda c: (["synth-colmap", c.fx("box"), c.path("out"), "--no-progress"], "cameras.json")),
    Case("synth-colmap-seed-negative", D, synth_colmap(None, "--seed", "-1", named="--seed")),
    Case("synth-colmap-matcher-unknown", D, synth_colmap(None, "--matcher", "vocab", named="--matcher")),
    Case("synth-colmap-cameras-json-corrupt", D, synth_colmap(lambda r: put(r / "gt" / "cameras.json", "{"))),
    Case("synth-colmap-scene-json-corrupt", D, synth_colmap(lambda r: put(r / "scene.json", "[1]"))),
    Case("synth-colmap-truncated-image", D, synth_colmap(lambda r: truncate(first(r / "images", "IMG_*.png")))),
    Case("synth-colmap-stray-image", D, synth_colmap(lambda r: duplicate(first(r / "images"), r / "images" / "IMG_9999.png"), named="IMG_9999.png")),
    Case("synth-colmap-missing-unseen-mask", D, synth_colmap(lambda r: remove(r / "unseen_mask" / "test_0002.png").name)),
    *out_cases(D, "synth-colmap", lambda c: ["synth-colmap", c.fx("synth")], ("--no-progress",)),
    Case("synth-colmap-out-is-scene", D, lambda c: (["synth-colmap", str(c.copy("synth")), str(c.tmp / "cone"), "--overwrite", "--no-progress"], c.path("cone"))),
]


@pytest.mark.parametrize("case", ids_unique(CASES))
def test_bad_input(case, tmp_path, request, capsys):
    check(case, tmp_path, request, capsys)


def test_validate_still_passes_a_good_scene_and_writes_json(box, tmp_path, capsys):
    """The refusals above are not over-eager: the untouched box scene validates, --json is written."""
    code, out, err = run_cli(D, ["validate", str(box), "--json", str(tmp_path / "r.json")], capsys)
    assert code == 0 and err == "" and "=> PASS" in out, out + err
    assert json.loads((tmp_path / "r.json").read_text())["ok"] is True


def test_failed_validation_still_writes_its_json_report(box, tmp_path, capsys):
    s = tmp_path / "s"
    shutil.copytree(box, s)
    _mask(s / "unseen_mask" / "test_007.png", 160, 120)
    code, out, err = run_cli(D, ["validate", str(s), "--json", str(tmp_path / "r.json")], capsys)
    assert code == 2 and "=> FAIL" in out and len(err.strip().splitlines()) == 1
    assert json.loads((tmp_path / "r.json").read_text())["ok"] is False
