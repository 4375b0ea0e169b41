"""3DGS training end to end on a tiny scene: it learns, outputs, resumes bit-for-bit, detects NaN; CLI."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
import torch
import yaml
from scene_builder import orbit_cameras, write_model, write_png

from inpaint360gs.cli import main
from inpaint360gs.core.errors import InputError, TrainingDivergedError
from inpaint360gs.gs.checkpoint import load_checkpoint
from inpaint360gs.gs.config import DensifyConfig, TrainConfig
from inpaint360gs.gs.evaluate import evaluate_views
from inpaint360gs.core.gaussians import SH_C0, Gaussians
from inpaint360gs.gs.trainer import init_gaussians, train_stage
from inpaint360gs.io.ply import read_ply
from inpaint360gs.io.scene import load_scene

W, H = 48, 36


@pytest.fixture(scope="module", autouse=True)
def _two_threads():
    old = torch.get_num_threads()
    torch.set_num_threads(2)
    yield
    torch.set_num_threads(old)


def ground_truth_model(n: int = 300) -> Gaussians:
    """A coloured sphere of small opaque Gaussians: the scene the images are rendered from."""
    g = torch.Generator().manual_seed(1)
    d = torch.randn(n, 3, generator=g)
    pts = d / d.norm(dim=1, keepdim=True)
    colors = 0.5 + 0.45 * torch.sin(3 * pts + torch.tensor([0.0, 2.0, 4.0]))
    return Gaussians.from_points(pts, colors, sh_degree=3, init_opacity=0.95)


@pytest.fixture(scope="module")
def tiny_scene(tmp_path_factory) -> Path:
    from inpaint360gs.render.api import render

    root = tmp_path_factory.mktemp("tiny") / "sphere"
    model = ground_truth_model()
    cams = orbit_cameras(12, width=W, h=H, f=40.0, radius=3.5) + orbit_cameras(2, width=W, h=H, f=40.0, radius=3.5, prefix="test_", phase=0.2)
    for c in cams:
        with torch.no_grad():
            write_png(root / "images" / c.name, render(model, c).color)
    rng = np.random.default_rng(0)  # sparse points: a noisy subset of the surface with its colours, like SfM
    pts = model.means.numpy()[::3] + rng.normal(0, 0.05, size=(100, 3))
    rgb = (model.sh0[::3, 0] * SH_C0 + 0.5).clamp(0, 1).numpy()
    write_model(root / "sparse" / "0", cams, pts, rgb)
    return root


def small_config(iterations: int, **kw) -> TrainConfig:
    dens = DensifyConfig(densify_from=20, densify_until=iterations - 20, densify_every=20, opacity_reset_every=kw.pop("reset", 1000))
    base = dict(iterations=iterations, sh_degree_interval=40, means_lr_max_steps=iterations, densify=dens, log_every=10, checkpoint_every=0)
    base.update(kw)
    return TrainConfig(**base)


def test_training_learns_and_writes_outputs(tiny_scene, tmp_path):
    scene = load_scene(tiny_scene)
    cfg = small_config(200)
    before = evaluate_views(init_gaussians(scene, cfg), scene, scene.holdout_views)
    res = train_stage(scene, tmp_path / "run", cfg)
    log = pd.read_csv(tmp_path / "run" / "train_log.csv")
    assert log["loss"].iloc[-1] < 0.5 * log["loss"].iloc[0]
    assert res.metrics["psnr"] > before["psnr"] + 6.0, (before["psnr"], res.metrics["psnr"])
    assert res.metrics["num_holdout_views"] == 2 and res.metrics["num_train_views"] == 10
    assert log["split"].sum() + log["cloned"].sum() > 0  # densification happened
    assert res.metrics["num_gaussians"] == len(res.gaussians) == log["num_gaussians"].iloc[-1]
    # outputs: PLY equals the returned model; metrics.json, config.yaml
    ply = read_ply(tmp_path / "run" / "point_cloud.ply")
    for k in ("means", "log_scales", "quats", "opacity_logits", "sh0", "shN"):
        assert torch.equal(getattr(ply, k), getattr(res.gaussians, k))
    m = json.loads((tmp_path / "run" / "metrics.json").read_text())
    assert m["psnr"] == pytest.approx(res.metrics["psnr"]) and m["peak_rss_mb"] > 50 and set(m["per_view"]) == {"IMG_000.png", "IMG_008.png"}
    conf = yaml.safe_load((tmp_path / "run" / "config.yaml").read_text())
    assert TrainConfig.from_dict(conf["config"]) == cfg
    # a second run into the same folder without --resume is refused
    with pytest.raises(InputError, match="--resume"):
        train_stage(scene, tmp_path / "run", cfg)


def test_resume_continues_bit_for_bit(tiny_scene, tmp_path):
    scene = load_scene(tiny_scene)
    cfg = small_config(70, checkpoint_every=25, random_background=True, reset=30)  # crosses densification + resets
    full = train_stage(scene, tmp_path / "full", cfg)

    class Stop(Exception):
        pass

    def stop_at(step, params):
        if step == 37:
            raise Stop

    with pytest.raises(Stop):
        train_stage(scene, tmp_path / "cut", cfg, on_step=stop_at)
    assert load_checkpoint(tmp_path / "cut" / "checkpoint.pt")["loop"]["step"] == 25
    resumed = train_stage(scene, tmp_path / "cut", cfg, resume=True)
    for k in ("means", "log_scales", "quats", "opacity_logits", "sh0", "shN"):
        assert torch.equal(getattr(full.gaussians, k), getattr(resumed.gaussians, k)), k
    a = pd.read_csv(tmp_path / "full" / "train_log.csv").drop(columns="elapsed_s")
    b = pd.read_csv(tmp_path / "cut" / "train_log.csv").drop(columns="elapsed_s")
    pd.testing.assert_frame_equal(a, b)
    with pytest.raises(InputError, match="config.seed"):
        train_stage(scene, tmp_path / "cut", small_config(70, checkpoint_every=25, random_background=True, reset=30, seed=5), resume=True)


def test_nan_in_parameters_stops_with_the_step_and_tensor(tiny_scene, tmp_path):
    scene = load_scene(tiny_scene)

    def poison(step, params):
        if step == 12:
            with torch.no_grad():
                params["log_scales"][3, 1] = float("nan")

    with pytest.raises(TrainingDivergedError, match="step 12: parameter 'log_scales'"):
        train_stage(scene, tmp_path / "run", small_config(30, checkpoint_every=5), on_step=poison)
    ck = load_checkpoint(tmp_path / "run" / "checkpoint.pt")
    assert ck["loop"]["step"] == 10 and all(torch.isfinite(v).all() for v in ck["loop"]["params"].values())
    assert not (tmp_path / "run" / "point_cloud.ply").exists()


def test_nan_loss_stops_training(tiny_scene, tmp_path, monkeypatch):
    import inpaint360gs.render.api as api

    real, calls = api.render, [0]

    def bad_render(*a, **kw):
        out = real(*a, **kw)
        calls[0] += 1
        if calls[0] == 4:
            out.color = out.color * float("nan")
        return out

    monkeypatch.setattr(api, "render", bad_render)
    with pytest.raises(TrainingDivergedError, match="step 3: loss is nan"):
        train_stage(load_scene(tiny_scene), tmp_path / "run", small_config(10))


def test_cli_train_and_render(tiny_scene, tmp_path, monkeypatch, capsys):
    out = tmp_path / "cli"
    argv = ["train", str(tiny_scene), str(out), "--iterations", "30", "--schedule-scale", "auto", "--no-progress", "--threads", "2"]
    assert main(argv) == 0
    assert {"point_cloud.ply", "metrics.json", "config.yaml", "train_log.csv", "checkpoint.pt"} <= {p.name for p in out.iterdir()}
    conf = yaml.safe_load((out / "config.yaml").read_text())
    assert conf["config"]["schedule_scale"] == pytest.approx(30 / 30000) and conf["effective_config"]["densify"]["densify_until"] == 15
    assert main(argv) == 2 and "--resume" in capsys.readouterr().err  # existing run, no --resume
    assert main(argv + ["--resume"]) == 0  # already complete: re-evaluates and rewrites outputs
    before = json.loads((out / "metrics.json").read_text())
    assert main(argv + ["--overwrite"]) == 0  # a fresh run over the old one: same seed, same model
    after = json.loads((out / "metrics.json").read_text())
    assert (after["psnr"], after["num_gaussians"]) == (before["psnr"], before["num_gaussians"])

    import inpaint360gs.io.images as images

    real = images.read_image

    def no_test_pixels(path):
        assert not Path(path).name.startswith("test_"), "render read a test image"
        return real(path)

    monkeypatch.setattr(images, "read_image", no_test_pixels)
    r = tmp_path / "renders"
    assert main(["render", str(out / "point_cloud.ply"), str(tiny_scene), str(r), "--split", "test", "--threads", "2"]) == 0
    assert sorted(p.name for p in (r / "color").iterdir()) == ["test_000.png", "test_001.png"]
    d = np.load(r / "depth" / "test_000.npy")
    assert d.shape == (H, W) and d.max() > 0.1
    info = json.loads((r / "render.json").read_text())
    import cv2

    png = cv2.imread(str(r / "depth" / "test_000.png"), cv2.IMREAD_UNCHANGED)
    assert png.dtype == np.uint16 and np.allclose(png / info["depth_png_scale"]["test_000.png"], d, atol=1e-3)
    assert main(["train", str(tmp_path / "missing"), str(tmp_path / "o2"), "--no-progress"]) == 2


@pytest.mark.parametrize("value, raises", [(float("nan"), True), (float("inf"), True), (-float("inf"), True), (3.0e38, False)])
def test_finite_check_of_the_loop(value, raises):
    """The per-step check reads the parameters' sum first: a NaN or inf anywhere is caught and
    counted; finite values whose sum overflows (2 x 3e38 in float32) are not an error."""
    from types import SimpleNamespace

    from inpaint360gs.gs.loop import OptimizationLoop

    p = torch.zeros(1000, 3)
    p[10, 1] = value
    p[20, 2] = value if not raises else 0.0
    loop = SimpleNamespace(params={"means": p, "frozen": torch.full((2,), float("nan"))}, schedules={"means": 1e-3})
    if raises:
        with pytest.raises(TrainingDivergedError, match="step 7: parameter 'means' has 1 non-finite"):
            OptimizationLoop._check_finite(loop, 7)
    else:
        assert not torch.isfinite(p.sum())
        OptimizationLoop._check_finite(loop, 7)  # finite values, overflowing sum: no error; unscheduled tensors are not read
