"""3DGS training runner (Kerbl et al. 2023; the paper's Gaussian field, Sec. 3.1 / supp. Sec. C).

``train_stage(scene, out, cfg)`` initialises Gaussians from the sparse SfM points, optimises them on the
scene's training views with the 3DGS recipe (see :mod:`inpaint360gs.gs.config`), checkpoints
atomically, stops with :class:`TrainingDivergedError` on NaN/Inf, evaluates on the held-out views and
writes ``point_cloud.ply``, ``metrics.json``, ``config.yaml`` and ``train_log.csv`` to ``out``.
Given the same scene, config and seed it is deterministic, whether or not numba's on-disk kernel
cache exists yet (each kernel holds all of its fast-math code itself, see
``render/numba_kernels.py``; ``tests/render/test_numba_cold_warm.py`` checks that the PLY files match),
and a resumed run continues bit-for-bit.
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

from inpaint360gs.core.errors import InputError, TrainingDivergedError
from inpaint360gs.gs.checkpoint import CHECKPOINT_NAME, load_checkpoint, save_checkpoint
from inpaint360gs.gs.config import TrainConfig
from inpaint360gs.gs.evaluate import evaluate_views
from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.core.progress import stage_bar
from inpaint360gs.gs.loss import photometric_loss
from inpaint360gs.gs.loop import OptimizationLoop, SceneViews, Target
from inpaint360gs.gs.optim import Params, learning_rates, means_lr
from inpaint360gs.gs.strategy import DensifyStrategy
from inpaint360gs.io import provenance
from inpaint360gs.io.arguments import bool_argument, check_stage_call
from inpaint360gs.io.atomic import atomic_path, write_text
from inpaint360gs.io.ply import write_ply
from inpaint360gs.io.scene import Scene

# every file a run writes into its folder; the last two only when it finishes
RUN_FILES = (CHECKPOINT_NAME, "train_log.csv", "config.yaml", "point_cloud.ply", "metrics.json")
FINISHED_FILES = RUN_FILES[-2:]

LOG_FIELDS = [
    "step", "loss", "l1", "ssim", "psnr", "num_gaussians", "sh_degree", "means_lr",
    "cloned", "split", "pruned", "holdout_psnr", "holdout_ssim", "elapsed_s",
]  # fmt: skip


@dataclass
class TrainResult:
    """What :func:`train` returns."""

    gaussians: Gaussians  # final model (detached, CPU)
    metrics: dict  # what metrics.json holds
    out_dir: Path  # the run's folder
    steps: int  # optimiser steps done in all (resumed ones included)


def init_gaussians(scene: Scene, cfg: TrainConfig, info: dict | None = None) -> Gaussians:
    """3DGS initialisation from the sparse points (with ``support_init`` on, or auto on a plain
    support, also points on the support where they leave the photos uncovered:
    :mod:`inpaint360gs.gs.support_init`): isotropic 3-NN scales, opacity ``init_opacity``. ``info``,
    when given, receives what the support points did (``support_init``: their mode, ``support_points``:
    how many were added, ``support_uncovered``: the share of the support's cells no SfM point covers)."""
    if scene.points.shape[0] == 0:
        raise InputError("the sparse model has no 3D points to initialise Gaussians from", scene.root / "sparse" / "0")
    points, colors = scene.points, scene.point_colors
    if cfg.support_init != "off":
        from inpaint360gs.gs.support_init import with_support_points

        points, colors, report = with_support_points(scene, auto=cfg.support_init == "auto")
        if info is not None:
            info.update(support_init=cfg.support_init, **report)
    return Gaussians.from_points(points, colors, sh_degree=cfg.sh_degree, init_opacity=cfg.init_opacity)


def peak_rss_mb() -> float:
    """Peak resident memory of this process so far (MiB): the kernel's high-water mark, or psutil's
    current RSS when that is larger (it never is on Linux, but ``ru_maxrss`` units differ on macOS)."""
    hwm = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024.0
    return max(hwm, psutil.Process().memory_info().rss / 2**20)


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
    """One 3DGS training run in ``out_dir`` on the shared :class:`OptimizationLoop`; call :meth:`run`."""

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
        self.views = scene.train_views
        from inpaint360gs.render.backends import preferred_device

        self.device = preferred_device(self.cfg.backend)  # the GPU for gsplat, else the CPU
        self.source = SceneViews(scene, self.views, device=self.device)
        for v in scene.holdout_views:  # every input the run reads is decoded now, before any training step
            scene.load_image_raw(v)
        self.fingerprint = scene.fingerprint()
        self.background = torch.tensor(self.cfg.background, dtype=torch.float32)

    # --- the 3DGS recipe as the loop's injected parts ---------------------------------------------
    def _render(self, g: Gaussians, target: Target, step: int, gen: torch.Generator):
        from inpaint360gs.render.api import render

        cfg = self.cfg
        sh_degree = min(step // cfg.sh_degree_interval, cfg.sh_degree)  # one SH band more every interval
        bg = torch.rand(3, generator=gen) if cfg.random_background else self.background
        return render(g, target.camera, sh_degree=sh_degree, background=bg, backend=cfg.backend, absgrad=self.absgrad)

    def _loss(self, out, target: Target, step: int):
        loss, l1, s = photometric_loss(out.color, target.data["image"], self.cfg.ssim_lambda)
        return loss, {"l1": l1.item(), "ssim": s.item()}

    def _fresh_state(self) -> None:
        cfg = self.cfg
        self.resumed_from: int | None = None
        lrs: dict[str, float | Callable[[int], float]] = dict(learning_rates(cfg, self.extent))
        lrs["means"] = lambda step: means_lr(step, cfg, self.extent)  # exponential decay (3DGS)
        self.init_info: dict = {}
        start = init_gaussians(self.scene, cfg, self.init_info).to(self.device)
        # a sparse capture (support points added) densifies on the absolute gradient (gs/strategy.py)
        strategy = DensifyStrategy(cfg.densify, self.extent, sparse_start=self.init_info.get("support_points", 0) > 0)
        self.init_info["densify_gradient"] = strategy.gradient
        self.absgrad = strategy.gradient == "abs"
        self.loop = OptimizationLoop(
            start,
            train=lrs,
            views=self.source,
            render_fn=self._render,
            loss_fn=self._loss,
            strategy=strategy,
            seed=cfg.seed,
            adam_eps=cfg.adam_eps,
            on_step=self.on_step,
        )
        self.log_rows: list[dict] = []
        self.window = _Window()
        self.elapsed_before = 0.0

    @property
    def step(self) -> int:
        """Optimiser steps done so far."""
        return self.loop.step_index

    def _identity(self) -> dict:
        return {
            "config": self.user_cfg.to_dict(),
            "scene": self.scene.name,
            "scene_content_sha256": self.fingerprint,
            "scene_read_sha256": self.scene.read_fingerprint(),  # the images_<R>/ copies read at this resize too
            "resize": self.scene.resize,
            "train_views": [v.name for v in self.views],
        }

    def _payload(self) -> dict:
        return {
            "identity": self._identity(),
            "loop": self.loop.state_dict(),
            "log_rows": self.log_rows,
            "window": self.window.sums,
            "elapsed_s": self.elapsed_before + (time.perf_counter() - self.t0),
        }

    def _restore(self, data: dict) -> None:
        self.loop.load_state_dict(data["loop"])
        self.log_rows = list(data["log_rows"])
        self.window = _Window(data["window"])
        self.elapsed_before = float(data["elapsed_s"])
        self.resumed_from = int(self.loop.step_index)

    def _train_step(self) -> dict:
        cfg = self.cfg
        res = self.loop.step()
        with torch.no_grad():
            mse = ((res.out.color.detach().clamp(0, 1) - res.target.data["image"]) ** 2).mean().item()
        return {
            "loss": res.loss, "l1": res.logs["l1"], "ssim": res.logs["ssim"],
            "psnr": -10.0 * math.log10(max(mse, 1e-12)),
            "sh_degree": min(res.step // cfg.sh_degree_interval, cfg.sh_degree), "means_lr": means_lr(res.step, cfg, self.extent),
            "cloned": res.stats.cloned, "split": res.stats.split, "pruned": res.stats.pruned,
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
        g = self.loop.gaussians().map(lambda t: t.detach())
        return evaluate_views(g, self.scene, self.scene.holdout_views, sh_degree=self.cfg.sh_degree, background=self.background, backend=self.cfg.backend)

    def _prepare_folder(self, resume: bool, overwrite: bool) -> dict | None:
        """Decide what happens to ``out`` before any work; returns the checkpoint to resume from.

        ``resume`` with a checkpoint: continue it; it must come from the same scene content and
        settings, else an error (with ``overwrite`` too: start afresh, what a workflow wants).
        ``resume`` without a checkpoint: start afresh, unless a finished run's outputs are there
        (an error: resuming never silently replaces a run); a config and log alone are what a run
        killed (SIGKILL) before its first checkpoint leaves, with nothing to resume: replaced. No
        ``resume``: refuse a previous run unless ``overwrite``, which deletes it.
        """
        ckpt = self.out / CHECKPOINT_NAME
        previous = [self.out / n for n in RUN_FILES if (self.out / n).is_file()]
        finished = [p for p in previous if p.name in FINISHED_FILES]
        if resume and ckpt.is_file():
            data = load_checkpoint(ckpt)
            mismatch = self._identity_mismatch(data.get("identity", {}))
            if mismatch is None:
                return data
            if not overwrite:
                raise InputError(mismatch, ckpt)
        elif resume and finished and not overwrite:
            raise InputError(
                f"resume: no {CHECKPOINT_NAME} to continue from, but the folder holds a previous run's "
                f"{finished[0].name}; overwrite that run, or choose a new folder",
                self.out,
            )
        elif previous and not (resume or overwrite):
            raise InputError("output folder holds a previous run; pass --resume to continue it, --overwrite to replace it, or choose a new folder", self.out)
        for p in previous:
            p.unlink()
        return None

    def _identity_mismatch(self, theirs: dict) -> str | None:
        """Why a checkpoint with identity ``theirs`` cannot continue this run, or None."""
        mine = self._identity()
        if mine == theirs:
            return None
        diff = [k for k in mine if mine[k] != theirs.get(k)]
        if "scene_content_sha256" in diff or "scene_read_sha256" in diff:
            return "checkpoint was made on a scene with different content (sparse model or images differ); pass --overwrite to start afresh"
        if "config" in diff:
            a, b = mine["config"], theirs.get("config", {})
            diff = [f"config.{k}" for k in a if a[k] != b.get(k)] + [d for d in diff if d != "config"]
        return f"checkpoint was made with different settings ({', '.join(diff)}); start afresh (--overwrite) or match them"

    def run(self, *, resume: bool = False, overwrite: bool = False) -> TrainResult:
        """Train to the end and write the outputs; ``resume``/``overwrite`` as in :func:`train`.
        A failed run leaves its checkpoint (with log and config) or nothing."""
        self.t0 = time.perf_counter()
        self._fresh_state()
        data = self._prepare_folder(resume, overwrite)
        if data is not None:
            self._restore(data)
        created = not self.out.exists()
        self.out.mkdir(parents=True, exist_ok=True)
        try:
            return self._run()
        except BaseException:
            # a failed or interrupted run leaves what resumes it (checkpoint + its log and config), or nothing
            if not (self.out / CHECKPOINT_NAME).is_file():
                for n in RUN_FILES:
                    (self.out / n).unlink(missing_ok=True)
                if created and not any(self.out.iterdir()):
                    self.out.rmdir()
            raise

    def _run(self) -> TrainResult:
        cfg = self.cfg
        write_text(
            self.out / "config.yaml",
            yaml.safe_dump({**self._identity(), "scene_root": str(self.scene.root), "effective_config": cfg.to_dict(), "scene_extent": self.extent}, sort_keys=False),
        )
        bar = stage_bar(cfg.iterations, f"3DGS {self.scene.name}", self.progress, initial=self.step, dynamic_ncols=True)
        try:
            while self.step < cfg.iterations:
                rec = self._train_step()
                self.window.add(n=1, **{k: rec[k] for k in ("loss", "l1", "ssim", "psnr", "cloned", "split", "pruned")})
                n = len(self.loop.params["means"])
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
            if (self.out / CHECKPOINT_NAME).is_file():
                self._write_log()  # the rows up to the failure, beside the last good checkpoint
            raise
        finally:
            bar.close()
        train_s = self.elapsed_before + time.perf_counter() - self.t0
        self._checkpoint()
        model = self.loop.detached()
        t_eval = time.perf_counter()
        ev = self._evaluate()  # before the model is written: a failure here leaves no PLY without metrics
        write_ply(self.out / "point_cloud.ply", model)
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
            "resumed_from_step": self.resumed_from,  # None: trained from step 0 in one go
            "init": {"sfm_points": int(self.scene.points.shape[0]), **self.init_info},
            "per_view": ev["per_view"],
            # what the model was made from (docs/architecture.md, "Provenance chain")
            provenance.KEY: provenance.make("train", self.scene, {}, self.user_cfg.to_dict()),
        }
        provenance.add_outputs(metrics, self.out, "point_cloud.ply")
        with atomic_path(self.out / "metrics.json") as tmp:
            tmp.write_text(json.dumps(metrics, indent=2) + "\n")
        return TrainResult(gaussians=model, metrics=metrics, out_dir=self.out, steps=self.step)


def train_stage(
    scene: Scene,
    out: str | Path,
    cfg: TrainConfig | None = None,
    *,
    resume: bool = False,
    overwrite: bool = False,
    progress: bool = False,
    on_step: Callable[[int, Params], None] | None = None,
) -> TrainResult:
    """Train 3DGS on ``scene``'s training views and write the run's outputs to ``out``.

    Args:
        scene: The scene; its sparse points initialise the Gaussians, its holdout views are evaluated.
        out: The run's folder (created when absent).
        cfg: Training settings (validated; ``schedule_scale`` applied); None: the defaults.
        resume: Continue from ``out/checkpoint.pt`` when it exists (same scene content and settings required).
        overwrite: Start afresh over a previous run's files instead of refusing.
        progress: Show a progress bar.
        on_step: ``on_step(step, params)`` after every optimiser step (inspection and tests).

    Returns:
        TrainResult: the final model (detached, CPU), what ``metrics.json`` holds, the folder, the steps.

    Raises:
        InputError: Invalid settings, a scene without sparse points, or a folder holding a previous
            run (or a checkpoint of other settings) that ``resume``/``overwrite`` do not allow to use.
    """
    check_stage_call("train_stage", scene, out, cfg, TrainConfig, overwrite=overwrite, progress=progress)
    bool_argument(resume, "train_stage.resume")
    return Trainer(scene, cfg or TrainConfig(), out, progress=progress, on_step=on_step).run(resume=resume, overwrite=overwrite)
