"""3DGS training runner (Kerbl et al. 2023; the paper's Gaussian field, Sec. 3.1 / supp. Sec. C).

``train(scene, cfg, out_dir)`` initialises Gaussians from the sparse SfM points, optimises them on the
scene's training views with the 3DGS recipe (see :mod:`inpaint360gs.gs.config`), checkpoints
atomically, stops with :class:`TrainingDivergedError` on NaN/Inf, evaluates on the held-out views and
writes ``point_cloud.ply``, ``metrics.json``, ``config.yaml`` and ``train_log.csv`` to ``out_dir``.
Given the same scene, config and seed it is deterministic, whether or not numba's on-disk kernel
cache exists yet, and a resumed run continues bit-for-bit. (The run that compiled the kernels used
to differ at rounding level from the first step on, e.g. cone 33.62 vs 32.89 dB after 3000 steps:
the compiling process called the kernels' helper functions in their own compiled copies, a process
that loaded the kernels from the cache their copies inside the cached kernel, and with fastmath the
two round differently. Each kernel now holds all of its fast-math code itself; see
``render/numba_kernels.py``. ``tests/test_numba_cold_warm.py`` checks that the PLY files match.)
"""

from __future__ import annotations

import csv
import io
import json
import math
import resource
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import psutil
import torch
import yaml

from inpaint360gs.errors import InputError, TrainingDivergedError
from inpaint360gs.gs.checkpoint import CHECKPOINT_NAME, load_checkpoint, save_checkpoint
from inpaint360gs.gs.config import TrainConfig
from inpaint360gs.gs.evaluate import evaluate_views
from inpaint360gs.gs.gaussians import Gaussians
from inpaint360gs.gs.loss import photometric_loss
from inpaint360gs.gs.optim import (
    PARAM_NAMES,
    Params,
    as_gaussians,
    learning_rates,
    make_optimizers,
    make_params,
    means_lr,
)
from inpaint360gs.gs.strategy import DensifyStrategy
from inpaint360gs.io.atomic import atomic_path, write_text
from inpaint360gs.io.images import to_float
from inpaint360gs.io.ply import write_ply
from inpaint360gs.io.scene import Scene

LOG_FIELDS = [
    "step", "loss", "l1", "ssim", "psnr", "num_gaussians", "sh_degree", "means_lr",
    "cloned", "split", "pruned", "holdout_psnr", "holdout_ssim", "elapsed_s",
]  # fmt: skip


@dataclass
class TrainResult:
    gaussians: Gaussians  # final model (detached, CPU)
    metrics: dict  # what metrics.json holds
    out_dir: Path
    steps: int


def init_gaussians(scene: Scene, cfg: TrainConfig) -> Gaussians:
    """3DGS initialisation from the sparse points: isotropic 3-NN scales, opacity ``init_opacity``."""
    if scene.points.shape[0] == 0:
        raise InputError("the sparse model has no 3D points to initialise Gaussians from", scene.root / "sparse" / "0")
    return Gaussians.from_points(scene.points, scene.point_colors, sh_degree=cfg.sh_degree, init_opacity=cfg.init_opacity)


def peak_rss_mb() -> float:
    """Peak resident memory of this process so far (MiB): the kernel's high-water mark, or psutil's
    current RSS when that is larger (it never is on Linux, but ``ru_maxrss`` units differ on macOS)."""
    hwm = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    return max(hwm, psutil.Process().memory_info().rss / 2**20)


def _check_finite(step: int, params: Params) -> None:
    for k in PARAM_NAMES:
        t = params[k].detach()
        if not torch.isfinite(t).all():
            bad = int((~torch.isfinite(t)).sum())
            raise TrainingDivergedError(f"step {step}: parameter '{k}' has {bad} non-finite value(s)")


class _Window:
    """Running sums of the logged quantities between two log rows."""

    def __init__(self, sums: dict | None = None):
        self.sums = dict(sums or {"loss": 0.0, "l1": 0.0, "ssim": 0.0, "psnr": 0.0, "n": 0, "cloned": 0, "split": 0, "pruned": 0})

    def add(self, **kw) -> None:
        for k, v in kw.items():
            self.sums[k] += v

    def mean(self, k: str) -> float:
        return self.sums[k] / max(self.sums["n"], 1)


class Trainer:
    """One training run in ``out_dir``; call :meth:`run`."""

    def __init__(
        self,
        scene: Scene,
        cfg: TrainConfig,
        out_dir: str | Path,
        *,
        progress: bool = True,
        on_step: Callable[[int, Params], None] | None = None,
    ):
        cfg.validate()
        self.scene = scene
        self.user_cfg = cfg
        self.cfg = cfg.effective()  # schedule_scale applied
        self.out = Path(out_dir)
        self.progress = progress
        self.on_step = on_step
        self.extent = scene.extent
        self.strategy = DensifyStrategy(self.cfg.densify, self.extent)
        self.views = scene.train_views
        # training pixels stay in their stored integer type until used
        self.images = [torch.from_numpy(scene.load_image_raw(v)) for v in self.views]
        self.background = torch.tensor(self.cfg.background, dtype=torch.float32)

    # --- state --------------------------------------------------------------------------------
    def _fresh_state(self) -> None:
        cfg = self.cfg
        torch.manual_seed(cfg.seed)
        self.gen = torch.Generator().manual_seed(cfg.seed)
        self.params = make_params(init_gaussians(self.scene, cfg))
        self.optimizers = make_optimizers(self.params, learning_rates(cfg, self.extent), cfg.adam_eps)
        self.state = self.strategy.initialize_state(self.params["means"].shape[0])
        self.step = 0
        self.order = torch.zeros(0, dtype=torch.long)
        self.order_pos = 0
        self.log_rows: list[dict] = []
        self.window = _Window()
        self.elapsed_before = 0.0

    def _identity(self) -> dict:
        return {
            "config": self.user_cfg.to_dict(),
            "scene": self.scene.name,
            "resize": self.scene.resize,
            "train_views": [v.name for v in self.views],
        }

    def _payload(self) -> dict:
        return {
            "identity": self._identity(),
            "step": self.step,
            "params": {k: p.detach().clone() for k, p in self.params.items()},
            "optimizers": {k: o.state_dict() for k, o in self.optimizers.items()},
            "strategy": {k: v.clone() for k, v in self.state.items()},
            "generator": self.gen.get_state(),
            "torch_rng": torch.get_rng_state(),
            "order": self.order.clone(),
            "order_pos": self.order_pos,
            "log_rows": self.log_rows,
            "window": self.window.sums,
            "elapsed_s": self.elapsed_before + (time.perf_counter() - self.t0),
        }

    def _restore(self, data: dict) -> None:
        mine, theirs = self._identity(), data["identity"]
        if mine != theirs:
            diff = [k for k in mine if mine[k] != theirs.get(k)]
            if "config" in diff:
                a, b = mine["config"], theirs["config"]
                diff = [f"config.{k}" for k in a if a[k] != b.get(k)] + [d for d in diff if d != "config"]
            raise InputError(f"checkpoint was made with different settings ({', '.join(diff)}); start afresh or match them", self.out / CHECKPOINT_NAME)
        self.step = int(data["step"])
        self.params = {k: torch.nn.Parameter(data["params"][k].clone()) for k in PARAM_NAMES}
        self.optimizers = make_optimizers(self.params, learning_rates(self.cfg, self.extent), self.cfg.adam_eps)
        for k, o in self.optimizers.items():
            o.load_state_dict(data["optimizers"][k])
        self.state = {k: v.clone() for k, v in data["strategy"].items()}
        self.gen = torch.Generator()
        self.gen.set_state(data["generator"])
        torch.set_rng_state(data["torch_rng"])
        self.order = data["order"].clone()
        self.order_pos = int(data["order_pos"])
        self.log_rows = list(data["log_rows"])
        self.window = _Window(data["window"])
        self.elapsed_before = float(data["elapsed_s"])

    # --- one step -----------------------------------------------------------------------------
    def _next_view(self) -> int:
        """Random order without replacement, reshuffled each epoch (3DGS ``viewpoint_stack``)."""
        if self.order_pos >= len(self.order):
            self.order = torch.randperm(len(self.views), generator=self.gen)
            self.order_pos = 0
        i = int(self.order[self.order_pos])
        self.order_pos += 1
        return i

    def _train_step(self, render) -> dict:
        cfg, step = self.cfg, self.step
        sh_degree = min(step // cfg.sh_degree_interval, cfg.sh_degree)
        lr = means_lr(step, cfg, self.extent)
        for group in self.optimizers["means"].param_groups:
            group["lr"] = lr
        i = self._next_view()
        view, gt = self.views[i], to_float(self.images[i])
        bg = torch.rand(3, generator=self.gen) if cfg.random_background else self.background
        out = render(as_gaussians(self.params), view.camera, sh_degree=sh_degree, background=bg, backend=cfg.backend)
        loss, l1, s = photometric_loss(out.color, gt, cfg.ssim_lambda)
        if not torch.isfinite(loss):
            raise TrainingDivergedError(f"step {step}: loss is {loss.item()} (rendering view {view.name})")
        loss.backward()
        for o in self.optimizers.values():
            o.step()
            o.zero_grad(set_to_none=True)
        grad2d = out.means2d.grad if out.means2d is not None else None
        stats = self.strategy.step_post_backward(
            self.params, self.optimizers, self.state, step, grad2d, out.radii, view.camera.width, view.camera.height, generator=self.gen
        )
        if self.on_step is not None:
            self.on_step(step, self.params)
        _check_finite(step, self.params)
        with torch.no_grad():
            mse = ((out.color.detach().clamp(0, 1) - gt) ** 2).mean().item()
        return {
            "loss": loss.item(), "l1": l1.item(), "ssim": s.item(),
            "psnr": -10.0 * math.log10(max(mse, 1e-12)), "sh_degree": sh_degree, "means_lr": lr,
            "cloned": stats.cloned, "split": stats.split, "pruned": stats.pruned,
        }  # fmt: skip

    # --- outputs ------------------------------------------------------------------------------
    def _write_log(self) -> None:
        buf = io.StringIO()
        w = csv.DictWriter(buf, fieldnames=LOG_FIELDS)
        w.writeheader()
        w.writerows(self.log_rows)
        write_text(self.out / "train_log.csv", buf.getvalue())

    def _checkpoint(self) -> None:
        save_checkpoint(self.out / CHECKPOINT_NAME, self._payload())
        self._write_log()

    def _evaluate(self) -> dict:
        g = as_gaussians(self.params).map(lambda t: t.detach())
        return evaluate_views(g, self.scene, self.scene.holdout_views, sh_degree=self.cfg.sh_degree, background=self.background, backend=self.cfg.backend)

    def run(self, *, resume: bool = False, overwrite: bool = False) -> TrainResult:
        from tqdm import tqdm

        from inpaint360gs.render.api import render

        self.out.mkdir(parents=True, exist_ok=True)
        ckpt = self.out / CHECKPOINT_NAME
        self.t0 = time.perf_counter()
        self._fresh_state()
        if overwrite and not resume:  # a fresh run replaces the previous one's files
            for name in (CHECKPOINT_NAME, "point_cloud.ply", "metrics.json", "train_log.csv"):
                (self.out / name).unlink(missing_ok=True)
        if resume and ckpt.is_file():
            self._restore(load_checkpoint(ckpt))
        elif not resume and (ckpt.is_file() or (self.out / "point_cloud.ply").is_file()):
            raise InputError("output folder holds a previous run; pass --resume to continue it, --overwrite to replace it, or choose a new folder", self.out)
        cfg = self.cfg
        write_text(
            self.out / "config.yaml",
            yaml.safe_dump({**self._identity(), "scene_root": str(self.scene.root), "effective_config": cfg.to_dict(), "scene_extent": self.extent}, sort_keys=False),
        )
        bar = tqdm(total=cfg.iterations, initial=self.step, disable=not self.progress, desc=f"3DGS {self.scene.name}", dynamic_ncols=True)
        try:
            while self.step < cfg.iterations:
                rec = self._train_step(render)
                self.step += 1
                self.window.add(n=1, **{k: rec[k] for k in ("loss", "l1", "ssim", "psnr", "cloned", "split", "pruned")})
                n = self.params["means"].shape[0]
                evaluated = cfg.eval_every > 0 and self.step % cfg.eval_every == 0 and self.step < cfg.iterations
                if self.step % cfg.log_every == 0 or self.step == cfg.iterations or evaluated:
                    row = {k: self.window.mean(k) for k in ("loss", "l1", "ssim", "psnr")}
                    row.update({k: self.window.sums[k] for k in ("cloned", "split", "pruned")})
                    row.update(step=self.step, num_gaussians=n, sh_degree=rec["sh_degree"], means_lr=rec["means_lr"])
                    row["elapsed_s"] = round(self.elapsed_before + time.perf_counter() - self.t0, 3)
                    if evaluated:
                        ev = self._evaluate()
                        row.update(holdout_psnr=ev["psnr"], holdout_ssim=ev["ssim"])
                    self.log_rows.append(row)
                    self._write_log()  # small; lets a user follow a long run
                    self.window = _Window()
                    bar.set_postfix(loss=f"{row['loss']:.4f}", psnr=f"{row['psnr']:.2f}", n=n, refresh=False)
                bar.update(1)
                if cfg.checkpoint_every > 0 and self.step % cfg.checkpoint_every == 0 and self.step < cfg.iterations:
                    self._checkpoint()
        except TrainingDivergedError:
            self._write_log()  # the rows up to the failure; the last good checkpoint stays
            raise
        finally:
            bar.close()
        train_s = self.elapsed_before + time.perf_counter() - self.t0
        self._checkpoint()
        model = as_gaussians(self.params).map(lambda t: t.detach().clone())
        write_ply(self.out / "point_cloud.ply", model)
        t_eval = time.perf_counter()
        ev = self._evaluate()
        metrics = {
            "scene": self.scene.name,
            "psnr": ev["psnr"],
            "ssim": ev["ssim"],
            "num_holdout_views": ev["num_views"],
            "num_train_views": len(self.views),
            "num_gaussians": int(model.means.shape[0]),
            "iterations": cfg.iterations,
            "train_seconds": round(train_s, 2),
            "eval_seconds": round(time.perf_counter() - t_eval, 2),
            "peak_rss_mb": round(peak_rss_mb(), 1),
            "resolution": [self.views[0].camera.width, self.views[0].camera.height],
            "backend": cfg.backend,
            "threads": torch.get_num_threads(),
            "seed": cfg.seed,
            "per_view": ev["per_view"],
        }
        with atomic_path(self.out / "metrics.json") as tmp:
            tmp.write_text(json.dumps(metrics, indent=2) + "\n")
        return TrainResult(gaussians=model, metrics=metrics, out_dir=self.out, steps=self.step)


def train(
    scene: Scene,
    cfg: TrainConfig,
    out_dir: str | Path,
    *,
    resume: bool = False,
    overwrite: bool = False,
    progress: bool = False,
    on_step: Callable[[int, Params], None] | None = None,
) -> TrainResult:
    """Train 3DGS on ``scene``'s training views and write the run's outputs to ``out_dir``.

    ``resume`` continues from ``out_dir/checkpoint.pt`` when it exists (same settings required);
    ``overwrite`` starts afresh over a previous run's files instead of refusing.
    ``on_step(step, params)`` is called after every optimiser step (inspection and tests).
    """
    return Trainer(scene, cfg, out_dir, progress=progress, on_step=on_step).run(resume=resume, overwrite=overwrite)
