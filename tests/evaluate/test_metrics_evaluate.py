"""evaluate_stage on small hand-built scenes: values, null handling, JSON safety, input errors."""

from __future__ import annotations

import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest
import torch

from inpaint360gs.core.errors import InputError
from inpaint360gs.io.images import read_image, to_float
from inpaint360gs.metrics import (
    lpips,
    masked_lpips,
    masked_psnr,
    masked_ssim,
    psnr,
    roi_lpips,
    roi_psnr,
    roi_ssim,
    ssim,
)
from inpaint360gs.evaluate.stage import evaluate_stage, metric_names
from inpaint360gs.metrics.masked import EMPTY_ROI_REASON, INFINITE_PSNR_REASON
from scene_builder import simple_scene, write_png
from test_metrics_distribution import generated_inception  # noqa: F401 (session fixture)

W, H = 64, 48


def blurred(img: np.ndarray, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    out = img.astype(np.float64)
    out = (out + np.roll(out, 1, axis=1) + np.roll(out, 1, axis=0)) / 3 + rng.normal(0, 8, img.shape)
    return np.clip(out, 0, 255).astype(np.uint8)


@pytest.fixture()
def scene(tmp_path: Path) -> tuple[Path, Path]:
    """Scene with 4 test views: test_000 normal mask, test_001 empty mask, test_002 no mask file,
    test_003 rendered perfectly (render == ground truth). Returns (scene_dir, renders_dir)."""
    root, renders = tmp_path / "scene", tmp_path / "renders"
    simple_scene(root, n_train=6, n_test=4, width=W, height=H, seed=1)
    mask = np.zeros((H, W), np.uint8)
    mask[10:30, 20:50] = 255
    mask[0, 0] = 127  # not > 127: outside the mask
    write_png(root / "unseen_mask" / "test_000.png", mask)
    write_png(root / "unseen_mask" / "test_001.png", np.zeros((H, W), np.uint8))
    write_png(root / "unseen_mask" / "test_003.png", mask)
    for i in range(4):
        gt = read_image(root / "images" / f"test_{i:03d}.png")
        write_png(renders / f"test_{i:03d}.png", gt if i == 3 else blurred(gt, i))
    return root, renders


def load(path: Path) -> torch.Tensor:
    return to_float(read_image(path))


def test_values_match_the_metric_functions_and_nulls_have_reasons(scene):
    root, renders = scene
    res = evaluate_stage(renders, root)
    json.dumps(res, allow_nan=False)  # no NaN / inf anywhere
    assert res["num_views"] == 4 and res["views"] == [f"test_{i:03d}.png" for i in range(4)]
    assert list(res["mean"]) == metric_names(("vgg", "alex"))
    mask = torch.zeros(H, W, dtype=torch.bool)
    mask[10:30, 20:50] = True
    r, g = load(renders / "test_000.png"), load(root / "images" / "test_000.png")
    v = res["per_view"]["test_000.png"]
    assert v["psnr"] == pytest.approx(psnr(r, g), abs=1e-9)
    assert v["ssim"] == pytest.approx(ssim(r, g), abs=1e-12)
    assert v["masked_psnr"] == pytest.approx(masked_psnr(r, g, mask), abs=1e-9)
    assert v["masked_ssim"] == pytest.approx(masked_ssim(r, g, mask), abs=1e-12)
    assert v["roi_psnr"] == pytest.approx(roi_psnr(r, g, mask), abs=1e-9)
    assert v["roi_ssim"] == pytest.approx(roi_ssim(r, g, mask), abs=1e-12)
    with torch.inference_mode():
        assert v["lpips"] == pytest.approx(lpips(r.permute(2, 0, 1), g.permute(2, 0, 1)).item(), abs=1e-5)
        assert v["lpips_alex"] == pytest.approx(lpips(r.permute(2, 0, 1), g.permute(2, 0, 1), "alex").item(), abs=1e-5)
    assert v["masked_lpips"] == pytest.approx(masked_lpips(r, g, mask), abs=1e-5)
    assert v["roi_lpips_alex"] == pytest.approx(roi_lpips(r, g, mask, net="alex"), abs=1e-5)
    assert res["null_reasons"]["per_view"].get("test_000.png") is None

    # empty mask (the unseen region hidden in this view): roi and masked null with the reason, so
    # the means are over the other views (masked PSNR would be +inf there and void the mean)
    e, er = res["per_view"]["test_001.png"], res["null_reasons"]["per_view"]["test_001.png"]
    assert all(e[f"{c}_{m}"] is None and er[f"{c}_{m}"] == EMPTY_ROI_REASON for m in ("psnr", "ssim", "lpips", "lpips_alex") for c in ("roi", "masked"))
    # no mask file: masked and roi null
    n, nr = res["per_view"]["test_002.png"], res["null_reasons"]["per_view"]["test_002.png"]
    assert all(n[k] is None and "no unseen mask" in nr[k] for k in res["mean"] if k.startswith(("masked_", "roi_")))
    assert n["psnr"] is not None
    # perfect render: every PSNR is +inf -> null with a reason, and so is every mean including it
    p, pr = res["per_view"]["test_003.png"], res["null_reasons"]["per_view"]["test_003.png"]
    assert p["psnr"] is None and pr["psnr"] == INFINITE_PSNR_REASON and p["lpips"] == 0.0 and p["ssim"] == pytest.approx(1.0)
    for k in ("psnr", "masked_psnr", "roi_psnr"):
        assert res["mean"][k] is None and "+inf" in res["null_reasons"]["mean"][k]

    # means: over the views where the metric is defined, with the count stated
    counts = res["num_views_mean"]
    assert counts["ssim"] == 4 and counts["masked_ssim"] == 2 and counts["roi_ssim"] == 2 and counts["unseen_share"] == 3
    ssims = [res["per_view"][f"test_{i:03d}.png"]["roi_ssim"] for i in (0, 3)]
    assert res["mean"]["roi_ssim"] == pytest.approx(sum(ssims) / 2)
    assert res["mean"]["lpips"] == pytest.approx(np.mean([res["per_view"][x]["lpips"] for x in res["views"]]))
    # the unseen share over the 3 views with a mask file: 600 of 3072 pixels twice, 0 once; no removal given: no AMCR
    assert res["scene_metrics"]["unseen_share"] == pytest.approx(100 * (600 / 3072 * 2) / 3)
    assert res["scene_metrics"]["amcr"] is None and "--removal" in res["null_reasons"]["scene_metrics"]["amcr"]
    assert res["scene_metrics"]["silhouette_test"] is None and "--removal" in res["null_reasons"]["scene_metrics"]["silhouette_test"]

    sm = res["scene_metrics"]
    assert sm["fid"] is None and "Inception" in res["null_reasons"]["scene_metrics"]["fid"]
    assert math.isfinite(sm["fd_vgg16"]) and sm["fd_vgg16"] > 0 and math.isfinite(sm["kid_vgg16"])
    assert set(res["conventions"]) == {"full", "masked", "roi"}
    assert {"fid", "fd_vgg16", "kid_vgg16", "unseen_share", "amcr", "silhouette_test"} <= set(res["definitions"])
    assert all(len(w["sha256"]) == 64 for k, w in res["weights"].items() if k.startswith("lpips"))
    assert res["weights"]["inception"] is None


def test_silhouette_of_given_removal_masks_and_the_given_amcr(scene):
    """The removed silhouette at the test cameras from hand-made removal masks: the mean over every
    test view of the percentage of its pixels in the mask, apart from the unseen share and from AMCR
    (over the training views, given as it is); a missing or misshapen mask is refused."""
    root, renders = scene
    masks = {f"test_{i:03d}.png": np.zeros((H, W), bool) for i in range(4)}
    masks["test_000.png"][:, :16] = True  # a quarter of the view
    masks["test_001.png"][:] = True
    masks["test_003.png"][0, :3] = True
    res = evaluate_stage(renders, root, nets=("alex",), removal_masks=masks, training_amcr=7.5)
    assert res["scene_metrics"]["silhouette_test"] == pytest.approx((25.0 + 100.0 + 0.0 + 100 * 3 / (H * W)) / 4)
    assert res["num_views_mean"]["silhouette_test"] == 4 and "silhouette_test" not in res["null_reasons"]["scene_metrics"]
    assert res["scene_metrics"]["amcr"] == 7.5 and "amcr" not in res["null_reasons"]["scene_metrics"]
    assert res["scene_metrics"]["unseen_share"] == pytest.approx(100 * (600 / 3072 * 2) / 3)
    with pytest.raises(InputError, match="no removal mask for test view test_002.png"):
        evaluate_stage(renders, root, nets=("alex",), removal_masks={k: v for k, v in masks.items() if k != "test_002.png"})
    with pytest.raises(InputError, match="removal mask of test_001.png is"):
        evaluate_stage(renders, root, nets=("alex",), removal_masks={**masks, "test_001.png": np.ones((H, W + 1), bool)})


def test_fid_with_a_weights_file_and_one_net_only(scene, generated_inception):  # noqa: F811
    root, renders = scene
    res = evaluate_stage(renders, root, nets=("alex",), inception_weights=generated_inception)
    assert math.isfinite(res["scene_metrics"]["fid"]) and "fid" not in res["null_reasons"]["scene_metrics"]
    assert res["weights"]["inception"]["matches_pytorch_fid"] is False  # generated, not the published file
    assert "lpips" not in res["mean"] and "lpips_alex" in res["mean"]
    assert math.isfinite(res["scene_metrics"]["fd_vgg16"])  # VGG features even without VGG LPIPS


def test_the_output_folder_of_render_is_read_through_its_color_subfolder(scene, tmp_path):
    """`inpaint360gs render` writes color/ and depth/ under its OUT: evaluate takes that OUT as is."""
    root, renders = scene
    out = tmp_path / "render_out"
    shutil.copytree(renders, out / "color")
    (out / "depth").mkdir()
    (out / "render.json").write_text("{}")
    a = evaluate_stage(out, root, nets=("alex",))
    b = evaluate_stage(renders, root, nets=("alex",))
    assert a["per_view"] == b["per_view"]


def test_input_errors(scene, tmp_path):
    root, renders = scene
    extra = renders / "test_009.png"
    shutil.copy(renders / "test_000.png", extra)
    with pytest.raises(InputError, match="matches no test view") as e:
        evaluate_stage(renders, root)
    assert e.value.path == extra and "\n" not in str(e.value)
    extra.unlink()

    (renders / "test_001.png").unlink()
    with pytest.raises(InputError, match="missing render for test view test_001.png"):
        evaluate_stage(renders, root)
    write_png(renders / "test_001.png", np.zeros((H, W + 2, 3), np.uint8))
    with pytest.raises(InputError, match=r"render is 66x48 but test view test_001.png is 64x48") as e:
        evaluate_stage(renders, root)
    assert e.value.path == renders / "test_001.png"
    write_png(renders / "test_001.png", np.zeros((H, W, 3), np.uint8))

    with pytest.raises(InputError, match="Inception weights file not found"):
        evaluate_stage(renders, root, inception_weights=tmp_path / "nope.pth")
    with pytest.raises(InputError, match="renders folder not found"):
        evaluate_stage(tmp_path / "nope", root)



def test_scene_without_test_views_reports_no_ground_truth(tmp_path, capsys):
    """Photos with the object only: nothing to score against; not an error (library and CLI)."""
    from inpaint360gs.cli import main
    from inpaint360gs.core.layout import NO_GROUND_TRUTH

    no_test = tmp_path / "no_test"
    simple_scene(no_test, n_train=4, n_test=0, width=W, height=H)
    renders = tmp_path / "renders"
    renders.mkdir()  # what the inpaint stage leaves in renders/test/ for such a scene
    res = evaluate_stage(renders, no_test)
    json.dumps(res, allow_nan=False)
    assert NO_GROUND_TRUTH == "no ground truth: the scene has no object-free test_ views"
    assert res["ground_truth"] is False and res["reason"] == NO_GROUND_TRUTH
    assert res["num_views"] == 0 and res["views"] == [] and res["per_view"] == {}
    assert list(res["mean"]) == metric_names(("vgg", "alex")) and set(res["mean"].values()) == {None}
    assert set(res["null_reasons"]["mean"].values()) == {NO_GROUND_TRUTH}
    assert set(res["scene_metrics"]) == {"fid", "fd_vgg16", "kid_vgg16", "unseen_share", "amcr", "silhouette_test", "roi_depth_off"}
    assert set(res["scene_metrics"].values()) == {None}
    assert set(res["null_reasons"]["scene_metrics"].values()) == {NO_GROUND_TRUTH}

    out = tmp_path / "m.json"
    assert main(["evaluate", str(renders), str(no_test), str(out)]) == 0
    std = capsys.readouterr()
    assert NO_GROUND_TRUTH in std.out and std.err == ""
    saved = json.loads(out.read_text())
    assert saved["ground_truth"] is False and saved["mean"]["psnr"] is None and saved["reason"] == NO_GROUND_TRUTH
