"""Messages that say what is wrong, and options that do what they say (docs/architecture.md,
"Reliability"): the cause, not a symptom further down (``--min-weight``, an empty file as OUT, no
scene.json, a grayscale render); ``evaluate --resize`` scores renders at that size; a test view
without an unseen mask is a warning on stderr, not a silently smaller average; a corrupt picture is
our one line, without OpenCV's own warning before it."""

from __future__ import annotations

import json
import shutil

import cv2
import pytest

from cli_harness import Case, check, ids_unique, restore_threads, run_cli  # noqa: F401
from inpaint360gs.cli import main
from reliability.chains import DISTILL

T = "inpaint360gs"


def cone(c):
    c.fx("chains_root")
    return c.request.getfixturevalue("chains")["cone"]


def no_scene_json(c):
    scene = shutil.copytree(cone(c).scene, c.tmp / "cone")
    (scene / "scene.json").unlink(missing_ok=True)
    return scene


def grey_render(c):
    """The inpainting's test renders, one of them stored as a grayscale PNG."""
    renders = shutil.copytree(cone(c).inpainted / "renders" / "test", c.tmp / "renders")
    p = sorted(renders.iterdir())[0]
    assert cv2.imwrite(str(p), cv2.cvtColor(cv2.imread(str(p)), cv2.COLOR_BGR2GRAY))
    return renders, p


CASES = [
    Case("distill-min-weight-above-every-weight", T, lambda c: (["distill", str(cone(c).scene), str(cone(c).model), str(cone(c).associate), c.path("out"), *DISTILL,
                                                                  "--min-weight", "2"], ("--min-weight", "must be < 1"))),
    Case("distill-min-weight-drops-every-weight", T, lambda c: (["distill", str(cone(c).scene), str(cone(c).model), str(cone(c).associate), c.path("out"), *DISTILL,
                                                                  "--min-weight", "0.999", "--no-progress"], ("--min-weight", "lower it"))),
    Case("segment-out-is-an-empty-file", T, lambda c: (["segment", str(cone(c).scene), str(cone(c).model), c.file("out", b"")], (c.path("out"), "an empty file, not a folder"))),
    Case("train-out-is-an-empty-file", T, lambda c: (["train", str(cone(c).scene), c.file("out", b"")], (c.path("out"), "an empty file, not a folder"))),
    Case("remove-no-click-and-no-scene-json", T, lambda c: (["remove", str(no_scene_json(c)), str(cone(c).distill), c.path("out")], ("scene.json", "has no scene.json"))),
    Case("run-no-click-and-no-scene-json", T, lambda c: (["run", str(no_scene_json(c)), c.path("out"), "--model", str(cone(c).model)], "has no scene.json")),
    Case("evaluate-grayscale-render", T, lambda c: (lambda r, p: (["evaluate", str(r), str(cone(c).scene), c.path("m.json"), "--nets", "vgg"], (str(p), "grayscale")))(*grey_render(c))),
    Case("evaluate-resize-not-a-factor", T, lambda c: (["evaluate", str(cone(c).removed_renders), str(cone(c).scene), c.path("m.json"), "--resize", "0"], "--resize")),
]  # fmt: skip


@pytest.mark.parametrize("case", ids_unique(CASES))
def test_message_names_the_cause(case, tmp_path, request, capsys):
    check(case, tmp_path, request, capsys)


def test_evaluate_resize_scores_renders_at_that_size(tmp_path, capsys):
    """Renders made at --resize 2 are scored at --resize 2 (the option was once parsed and ignored):
    the test views are read at half size, and the result records it. (64x48: LPIPS needs 16 pixels
    a side at half size.)"""
    import scene_builder as sb
    from inpaint360gs.io.ply import write_ply

    scene, model, _ = sb.blobs_scene(tmp_path / "scene", n_views=6, width=64, height=48)
    write_ply(tmp_path / "model.ply", model.subset(model.means[:, 2] < 0.05))  # the floor only: something to score
    for r in ("1", "2"):
        code, _, err = run_cli(T, ["render", str(tmp_path / "model.ply"), str(scene), str(tmp_path / f"r{r}"), "--resize", r, "--no-progress", "--threads", "2"], capsys)
        assert code == 0, err
        code, _, err = run_cli(T, ["evaluate", str(tmp_path / f"r{r}"), str(scene), str(tmp_path / f"m{r}.json"), "--nets", "vgg", "--threads", "2", "--resize", r], capsys)
        assert code == 0, err
    full, half = (json.loads((tmp_path / f"m{r}.json").read_text()) for r in "12")
    assert half["resize"] == 2 and full["resize"] == 1 and half["provenance"]["scene"]["resize"] == 2
    assert half["mean"]["psnr"] != full["mean"]["psnr"]
    code, _, err = run_cli(T, ["evaluate", str(tmp_path / "r2"), str(scene), str(tmp_path / "m.json"), "--nets", "vgg"], capsys)
    assert code == 2 and "made at --resize 2" in err  # the half-size renders at --resize 1: refused


def test_a_missing_unseen_mask_is_a_warning_on_stderr(chains, tmp_path, capsys):
    ch = chains["cone"]
    scene = shutil.copytree(ch.scene, tmp_path / "cone")
    (scene / "unseen_mask" / "test_001.png").unlink()
    code, _, err = run_cli(T, ["evaluate", str(ch.inpainted / "renders" / "test"), str(scene), str(tmp_path / "m.json"), "--nets", "vgg", "--threads", "2"], capsys)
    assert code == 0, err
    assert err.strip().splitlines() == [f"inpaint360gs evaluate: warning: {scene / 'unseen_mask'}: no unseen mask for 1 of 2 test view(s) (first: test_001.png); "
                                        "masked_* and roi_* means are over the 1 view(s) with one"]  # fmt: skip
    assert json.loads((tmp_path / "m.json").read_text())["num_views_mean"]["masked_psnr"] == 1


def test_a_truncated_picture_is_one_line_without_opencvs_warning(chains, tmp_path, capfd):
    """OpenCV writes its own "[ WARN...]" line straight to the process's stderr: capfd sees it."""
    ch = chains["cone"]
    scene = shutil.copytree(ch.scene, tmp_path / "cone")
    img = scene / "images" / "IMG_003.png"
    img.write_bytes(img.read_bytes()[: img.stat().st_size // 2])
    capfd.readouterr()
    assert main(["segment", str(scene), str(ch.model), str(tmp_path / "out"), "--no-progress", "--threads", "2"]) == 2
    err = capfd.readouterr().err
    assert err.strip().splitlines() == [f"inpaint360gs segment: error: {img}: cannot decode image (corrupt or unsupported format)"]
