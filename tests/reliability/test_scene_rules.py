"""``validate`` and the stages agree on what a scene is (docs/architecture.md, "Reliability"): views
that share a stem (their per-view outputs would share one file), clicks in ``scene.json`` that no
run can use (a coordinate of 1e400, a view that does not exist, a fraction), a ``scene.json`` nested
too deeply for the parser — each refused by ``validate`` and by every CLI that reads the scene, with
one line and exit status 2 (the same rule: ``core.layout.same_stem``,
``remove.select.clicks_from_json`` / ``click_problem``, ``core.files.parse_json``)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest

from cli_harness import Case, check, ids_unique, restore_threads  # noqa: F401
from reliability.scene_cases import model, rename_in_model, scene_copy

T, D = "inpaint360gs", "inpaint360gs-dataset"
STEM = "share the stem 'IMG_003'"


def twins_in_folders(root: Path):
    """``a/IMG_003.png`` and ``b/IMG_003.png``: two views, one ``segment/IMG_003.png``."""
    for sub, name in (("a", "IMG_003.png"), ("b", "IMG_004.png")):
        (root / "images" / sub).mkdir()
        shutil.move(root / "images" / name, root / "images" / sub / "IMG_003.png")
        rename_in_model(root, name, f"{sub}/IMG_003.png")
    return STEM


def twins_by_suffix(root: Path):
    """``IMG_003.png`` and ``IMG_003.jpg`` (the second a PNG under a .jpg name is still an image)."""
    shutil.move(root / "images" / "IMG_004.png", root / "images" / "IMG_003.jpg")
    rename_in_model(root, "IMG_004.png", "IMG_003.jpg")
    return STEM


def twins_by_case(root: Path):
    """``IMG_003.png`` and ``IMG_003.PNG``."""
    shutil.move(root / "images" / "IMG_004.png", root / "images" / "IMG_003.PNG")
    rename_in_model(root, "IMG_004.png", "IMG_003.PNG")
    return STEM


def clicks(*entries) -> object:
    def put(root: Path):
        (root / "scene.json").write_text(json.dumps({"clicks": list(entries)}))
        return "scene.json"

    return put


def raw_scene_json(text: str, named: str = "scene.json"):
    def put(root: Path):
        (root / "scene.json").write_text(text)
        return named

    return put


BREAKS = {
    "same-stem-in-two-folders": twins_in_folders,  # issue: 28 views, 27 masks, exit 0; validate passed
    "same-stem-two-suffixes": twins_by_suffix,  # issue
    "same-stem-suffix-case": twins_by_case,
    "scene-json-nested-200000": raw_scene_json("[" * 200_000 + "]" * 200_000, "nested too deeply"),  # issue: RecursionError
    "scene-json-nested-object": raw_scene_json('{"a":' * 100_000 + "1" + "}" * 100_000, "nested too deeply"),
}
CLICKS = {
    "click-x-1e400": clicks({"view": "IMG_003.png", "x": 1e400, "y": 3}),  # issue: OverflowError; validate passed
    "click-view-missing": clicks({"view": "IMG_999.png", "x": 3, "y": 3}),  # issue: validate passed
    "click-x-fraction": clicks({"view": "IMG_003.png", "x": 3.5, "y": 3}),
    "click-x-string": clicks({"view": "IMG_003.png", "x": "3", "y": 3}),
    "click-x-bool": clicks({"view": "IMG_003.png", "x": True, "y": 3}),
    "click-no-y": clicks({"view": "IMG_003.png", "x": 3}),
    "click-outside-image": clicks({"view": "IMG_003.png", "x": 3, "y": 24}),
    "click-negative": clicks({"view": "IMG_003.png", "x": -1, "y": 3}),
    "click-on-a-test-view": clicks({"view": "test_000.png", "x": 3, "y": 3}),
    "click-view-not-a-string": clicks({"view": 3, "x": 3, "y": 3}),
    "clicks-not-a-list": raw_scene_json('{"clicks": {"view": "IMG_003.png", "x": 3, "y": 3}}'),
    "click-not-an-object": raw_scene_json('{"clicks": ["IMG_003.png:3,3"]}'),
}
CLIS = {
    "train": lambda r, c: ["train", str(r), c.path("out"), "--iterations", "2", "--no-progress", "--threads", "2"],
    "segment": lambda r, c: ["segment", str(r), model(c), c.path("out"), "--no-progress", "--threads", "2"],
    "run": lambda r, c: ["run", str(r), c.path("out"), "--model", model(c), "--until", "segment", "--no-progress", "--threads", "2"],
    "validate": lambda r, c: ["validate", str(r)],
}


def case(cli: str, name: str, brk) -> Case:
    def make(c):
        root = scene_copy(c)
        named = str(brk(root))
        return CLIS[cli](root, c), "scene.json clicks:" if cli == "validate" and name in CLICKS else named

    return Case(f"{cli}-{name}", D if cli == "validate" else T, make)


# the clicks of scene.json are a run's when no --click or --id is given: `run` and `validate` read them
CASES = [case(cli, name, brk) for cli in CLIS for name, brk in BREAKS.items()]
CASES += [case(cli, name, brk) for cli in ("run", "validate") for name, brk in CLICKS.items()]


@pytest.mark.parametrize("case", ids_unique(CASES))
def test_validate_and_the_stages_refuse_alike(case, tmp_path, request, capsys):
    check(case, tmp_path, request, capsys)


def test_names_with_spaces_and_other_scripts_are_views_like_any(chains, tmp_path):
    """A photo named ``IMG 003.png`` or ``IMG_ü004.png`` is a view (binary models hold any name)."""
    from dataset_tools.capture.validate import validate_scene
    from inpaint360gs.io.scene import load_scene

    root = shutil.copytree(chains["cone"].scene, tmp_path / "cone")
    for old, new in (("IMG_003.png", "IMG 003.png"), ("IMG_004.png", "IMG_ü004.png")):
        shutil.move(root / "images" / old, root / "images" / new)
        rename_in_model(root, old, new)
    scene = load_scene(root)
    assert {"IMG 003.png", "IMG_ü004.png"} <= {v.name for v in scene.views}
    assert scene.load_image(scene.view("IMG 003.png")).shape == (24, 32, 3)
    report = {c.name: c.status for c in validate_scene(root).checks}
    assert report["registration"] == report["distinct stems"] == report["inside the scene"] == "pass", report
