"""Object-ID distillation (paper Sec. 3.3, supp. B "Object Feature Distillation", Alg. 1): the
associated per-view object masks are distilled into identity features of the frozen Gaussian field.

``distill_stage(scene, model, masks_dir, objects, out, cfg)``:

1. read and check every input (model, object ids, one mask per training view) before any work;
2. give each Gaussian a random feature f_i in R^F (Gaussian Grouping's initialisation: U[0, 1)
   mapped through the SH DC convention, (u - 0.5) / C0) and Phi = Linear(F, Q) its default init,
   both from a generator seeded with ``cfg.seed``;
3. cache each training view's compositing weights W (:mod:`.cached`) and the kNN graph of the
   centres (:func:`.loss.knn_graph`);
4. run the shared :class:`~inpaint360gs.gs.loop.OptimizationLoop` for ``cfg.iterations`` steps
   training only ``features`` and Phi (no densification): L = CE(softmax(Phi(W f)), O) + lambda L_space;
5. write ``point_cloud.ply`` (features as ``obj_*``), ``classifier.json`` and ``distill.json``
   (inputs with sha256, settings, loss curve, timings, memory) atomically into ``out``.

Same inputs and seed give the same ``point_cloud.ply`` and ``classifier.json`` bytes (``distill.json``
also records wall times).
"""

from __future__ import annotations

import json
import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import torch

from inpaint360gs.core.errors import InputError
from inpaint360gs.core.files import sha256_file
from inpaint360gs.core.gaussians import SH_C0, Gaussians
from inpaint360gs.core.progress import stage_bar
from inpaint360gs.distill.cached import CachedFeatureRenderer, spatial_order
from inpaint360gs.distill.config import DistillConfig
from inpaint360gs.distill.field import CLASSIFIER_JSON, DISTILL_JSON, MODEL_PLY, IdentityField, make_classifier, write_classifier
from inpaint360gs.distill.labels import Labels, load_labels, read_objects
from inpaint360gs.distill.loss import knn_graph, object_loss, spatial_loss
from inpaint360gs.gs.loop import OptimizationLoop, Target, TargetList
from inpaint360gs.gs.trainer import peak_rss_mb
from inpaint360gs.io import provenance
from inpaint360gs.io.arguments import check_stage_call
from inpaint360gs.io.atomic import atomic_dir
from inpaint360gs.io.ply import read_ply, write_ply
from inpaint360gs.io.scene import Scene
from inpaint360gs.render.contributions import Contributions, contributions

MIN_COVERAGE = 0.01  # a model covering less of the training pixels (alpha >= 0.5) is not of this scene


@dataclass
class DistillResult:
    """What :func:`distill` returns."""

    field: IdentityField  # the model with its distilled features and the classifier
    report: dict  # what distill.json holds
    out_dir: Path | None  # where it was written, None when not




def init_features(n: int, dim: int, generator: torch.Generator) -> torch.Tensor:
    """Random identity features (Gaussian Grouping: uniform colours stored as SH DC, (u - 0.5) / C0)."""
    return (torch.rand(n, dim, generator=generator) - 0.5) / SH_C0


def cache_views(model: Gaussians, labels: Labels, cfg: DistillConfig, where: str | Path = "model") -> dict[str, Contributions]:
    """W of every training view; InputError (naming ``where``) when the model does not cover the views (another scene's model)."""
    cache = {v.name: contributions(model, v.camera, backend=cfg.backend, min_weight=cfg.min_weight) for v in labels.views}
    covered = sum(int((c.alpha() >= 0.5).sum()) for c in cache.values())
    total = sum(c.width * c.height for c in cache.values())
    if sum(c.nnz for c in cache.values()) == 0:
        if cfg.min_weight > 0:
            raise InputError(f"no compositing weight in any of the {len(cache)} training views is at least {cfg.min_weight:g}: lower it (weights lie in [0, 1])", setting="DistillConfig.min_weight")
        raise InputError(f"no Gaussian of the model projects into any of the {len(cache)} training views; is the model from this scene?", where)
    if covered < MIN_COVERAGE * total:
        if cfg.min_weight > 0:
            raise InputError(f"after dropping weights below {cfg.min_weight:g} the model covers {100 * covered / total:.2f}% of the training pixels: lower it", setting="DistillConfig.min_weight")
        raise InputError(
            f"the model covers only {100 * covered / total:.2f}% of the training pixels (alpha >= 0.5); is the model from this scene?", where
        )
    empty = [name for name, c in cache.items() if c.nnz == 0]
    if empty:
        warnings.warn(f"{len(empty)} training view(s) see no Gaussian (first: {empty[0]}); their masks cannot be distilled")
    return cache


class _Window:
    """Mean loss terms over the steps since the last row of the loss curve (``acc``: the last step's view)."""

    def __init__(self):
        self.sums = {"loss": 0.0, "ce": 0.0, "space": 0.0}
        self.n = 0
        self.acc = None

    def add(self, loss: float, logs: dict) -> None:
        self.sums["loss"] += loss
        for k in ("ce", "space"):
            self.sums[k] += logs[k]
        self.acc = logs.get("acc", self.acc)
        self.n += 1

    def row(self, step: int) -> dict:
        row = {"step": step, **{k: round(v / max(self.n, 1), 6) for k, v in self.sums.items()}}
        return {**row, "view_pixel_accuracy": None if self.acc is None else round(self.acc, 5)}


class Distiller:
    """The distillation set-up on the shared loop: cached weights, objective, classifier.

    Internally the Gaussians are put in Morton (Z-curve) order of their centres
    (:func:`.cached.spatial_order`), so the rows the sparse products and the kNN loss touch together
    lie close in memory (faster sparse products); :meth:`field` returns them in the
    model's own order. Everything random is drawn in the model's order, so the result does not
    depend on this.
    """

    def __init__(self, model: Gaussians, labels: Labels, cfg: DistillConfig, where: str | Path = "model"):
        self.cfg = cfg
        self.model = model
        self.labels = labels
        dev, dt = model.means.device, model.means.dtype
        t0 = time.perf_counter()
        self.order = spatial_order(model.means)
        local = model.subset(self.order)
        self.cache = cache_views(local, labels, cfg, where)
        self.timing = {"weights_cache": time.perf_counter() - t0}
        t0 = time.perf_counter()
        gen = torch.Generator().manual_seed(cfg.seed)
        feats = init_features(len(model), cfg.feature_dim, gen).to(device=dev, dtype=dt)[self.order]
        self.classifier = make_classifier(cfg.feature_dim, labels.num_classes, gen).to(device=dev, dtype=dt)
        self.neighbours = knn_graph(local.means, cfg.knn).to(dev)
        targets = [Target(v.name, v.camera, {"labels": lab.to(dev)}) for v, lab in zip(labels.views, labels.labels)]
        self.renderer = CachedFeatureRenderer(self.cache, 0 if cfg.lambda_space == 0 else cfg.knn_sample)
        self.loop = OptimizationLoop(
            Gaussians(**{**local.tensors(), "features": feats}),
            train={"features": cfg.features_lr},
            views=TargetList(targets),
            render_fn=self.renderer,
            loss_fn=self.loss,
            modules={"classifier": (self.classifier, cfg.classifier_lr)},
            seed=cfg.seed,
        )
        self.timing["knn_and_setup"] = time.perf_counter() - t0

    def loss(self, out, target: Target, step: int):
        """Cross-entropy of the classified features vs the view's labels, plus ``lambda_space`` times
        the spatial (3D kNN) loss; returns (loss, logs)."""
        labels = target.data["labels"].long()
        logits = self.classifier(out.features.reshape(labels.shape[0], -1))
        ce = object_loss(logits, labels)
        loss = ce
        space = 0.0
        if self.cfg.lambda_space > 0:
            sp = spatial_loss(out.gaussian_features, self.neighbours, out.knn_rows)
            loss = ce + self.cfg.lambda_space * sp
            space = sp.item()
        logs = {"ce": ce.item(), "space": space}
        if (step + 1) % self.cfg.log_every == 0:  # the view's pixel accuracy, at logging steps only (argmax costs)
            logs["acc"] = (logits.detach().argmax(-1) == labels).float().mean().item()
        return loss, logs

    def field(self) -> IdentityField:
        """The identity field in the model's own Gaussian order (geometry: the input tensors, untouched)."""
        local = self.loop.params["features"].detach()
        feats = torch.empty_like(local)
        feats[self.order] = local
        return IdentityField(Gaussians(**{**self.model.tensors(), "features": feats}), self.classifier, list(self.labels.class_ids))

    @torch.no_grad()
    def train_view_scores(self) -> dict:
        """Rendered ids (cached weights: the rasterizer's maths) vs the masks on the training views:
        pixel accuracy and per-object IoU pooled over the views."""
        ids = self.labels.class_ids
        q = len(ids)
        inter = torch.zeros(q, dtype=torch.float64)
        union = torch.zeros(q, dtype=torch.float64)
        correct = total = 0
        f = self.loop.params["features"].detach()
        for v, lab in zip(self.labels.views, self.labels.labels):
            pred = self.classifier(self.cache[v.name].matmul(f).to(f)).argmax(-1).cpu()
            lab = lab.long()
            correct += int((pred == lab).sum())
            total += lab.numel()
            inter += torch.bincount(lab[pred == lab], minlength=q).double()
            union += (torch.bincount(pred, minlength=q) + torch.bincount(lab, minlength=q)).double()
        union -= inter
        iou = {str(ids[c]): (round(float(inter[c] / union[c]), 4) if union[c] > 0 else None) for c in range(q)}
        objects = [iou[str(i)] for i in ids[1:] if iou[str(i)] is not None]
        return {"pixel_accuracy": round(correct / max(total, 1), 5), "iou": iou, "mean_object_iou": round(sum(objects) / len(objects), 4) if objects else None}


def distill_stage(
    scene: Scene,
    model: Gaussians | str | Path,
    masks_dir: str | Path,
    objects: Sequence[int] | str | Path,
    out: str | Path | None,
    cfg: DistillConfig | None = None,
    *,
    overwrite: bool = False,
    progress: bool = False,
) -> DistillResult:
    """Distill the masks in ``masks_dir`` (one ``<stem>.png`` id image per training view of ``scene``)
    into identity features of ``model`` (a Gaussians or a PLY path); ``objects`` = the object ids or
    the association's ``objects.json``. Writes ``out`` unless it is None.

    Args: ``cfg`` None = defaults; ``overwrite`` replace a non-empty ``out``; ``progress`` show a progress bar.
    Returns: :class:`DistillResult`.
    Raises: :class:`InputError` for invalid settings, a non-empty ``out``, or masks and model not
    made from this scene (or the association not from this model)."""
    check_stage_call("distill_stage", scene, out, cfg, DistillConfig, overwrite=overwrite, progress=progress, out_optional=True, models={"model": model},
                     folders={"masks_dir": masks_dir, **({"objects": objects} if isinstance(objects, (str, Path)) else {})})
    if not isinstance(objects, (str, Path)) and not (isinstance(objects, (list, tuple)) and all(isinstance(i, int) and not isinstance(i, bool) for i in objects)):
        raise InputError(f"expected object ids (a list of whole numbers) or the association's objects.json, got {objects!r:.40}", setting="distill_stage.objects")
    t_start = time.perf_counter()
    cfg = cfg or DistillConfig()
    cfg.validate()
    out = None if out is None else Path(out)
    if out is not None and out.exists() and not out.is_dir():
        raise InputError("output path exists and is not a folder", out)
    if out is not None and out.exists() and any(out.iterdir()) and not overwrite:
        raise InputError("output folder exists and is not empty (pass --overwrite to replace it)", out)
    inputs: dict = {"scene": str(scene.root), "scene_content_sha256": scene.fingerprint(), "resize": scene.resize}
    # the association and the model must be of this scene, the association made with this model
    # (docs/architecture.md, "Provenance chain")
    made = provenance.read(objects, "associate") if isinstance(objects, (str, Path)) else None
    provenance.check_scene(made, scene, "associate this scene first")
    model_sha = None
    if isinstance(model, (str, Path)):
        model_sha = provenance.check_model(model, scene)
        provenance.check_link(made, "model", model_sha, model, "associate with this model first, or give the model the masks were made with")
        inputs.update(model=str(model), model_sha256=model_sha)
        model = read_ply(model)
    if isinstance(objects, (str, Path)):
        inputs.update(objects=str(objects), objects_sha256=sha256_file(Path(objects)))
        objects = read_objects(objects)
    upstream = made.identity if made is not None and made.identity else inputs.get("objects_sha256")
    labels = load_labels(masks_dir, scene.train_views, objects)
    inputs.update(masks_dir=str(masks_dir), masks_sha256=labels.sha256())
    model = model.map(lambda t: t.detach())

    d = Distiller(model, labels, cfg, inputs.get("model", "model"))
    cache = d.cache

    t0 = time.perf_counter()
    curve, window = [], _Window()
    bar = stage_bar(cfg.iterations, f"distill {scene.name}", progress, dynamic_ncols=True)
    try:
        while d.loop.step_index < cfg.iterations:
            res = d.loop.step()
            window.add(res.loss, res.logs)
            if d.loop.step_index % cfg.log_every == 0 or d.loop.step_index == cfg.iterations:
                curve.append(window.row(d.loop.step_index))
                bar.set_postfix(ce=f"{curve[-1]['ce']:.4f}", refresh=False)
                window = _Window()
            bar.update(1)
    finally:
        bar.close()
    t_train = time.perf_counter() - t0
    field = d.field()
    scores = d.train_view_scores()

    nnz = sum(c.nnz for c in cache.values())
    seen = torch.zeros(len(model), dtype=torch.bool)
    for c in cache.values():
        seen[c.cols.long().cpu()] = True
    pixels = sum(c.width * c.height for c in cache.values())
    dropped = [c.dropped for c in cache.values() if c.dropped is not None]
    cam = labels.views[0].camera
    report = {
        "stage": "distill",
        "inputs": inputs,
        provenance.KEY: provenance.make("distill", scene, {"model": model_sha, "associate": upstream}, cfg.to_dict()),
        "settings": cfg.to_dict(),
        "object_ids": field.object_ids,
        "class_pixel_counts": labels.pixel_counts,
        "num_gaussians": len(model),
        "train_views": [v.name for v in labels.views],
        "resolution": [cam.width, cam.height],
        "weights_cache": {
            "entries": nnz,
            "entries_per_pixel": round(nnz / max(pixels, 1), 2),
            "mib": round(sum(c.nbytes for c in cache.values()) / 2**20, 1),
            "dropped_weight_per_pixel": round(float(sum(x.double().sum() for x in dropped)) / pixels, 6) if dropped else 0.0,
            # no cached weight in any training view: these learn from the spatial loss (Eq. 4) alone
            "gaussians_without_weight": int((~seen).sum()),
        },
        "loss_curve": curve,
        "final": {"loss": curve[-1]["loss"], "ce": curve[-1]["ce"], "space": curve[-1]["space"], "train_views": scores},
        "timing_s": {
            "weights_cache": round(d.timing["weights_cache"], 2),
            "knn_and_setup": round(d.timing["knn_and_setup"], 2),
            "train": round(t_train, 2),
            "steps_per_s": round(cfg.iterations / max(t_train, 1e-9), 2),
        },
        "threads": torch.get_num_threads(),
    }
    if out is not None:
        with atomic_dir(out, overwrite=True) as tmp:
            write_ply(tmp / MODEL_PLY, field.gaussians)
            write_classifier(tmp / CLASSIFIER_JSON, field.classifier, field.object_ids)
            provenance.add_outputs(report, tmp, MODEL_PLY)
            report["timing_s"]["total"] = round(time.perf_counter() - t_start, 2)
            report["peak_rss_mb"] = round(peak_rss_mb(), 1)
            (tmp / DISTILL_JSON).write_text(json.dumps(report, indent=2) + "\n")
    else:
        report["timing_s"]["total"] = round(time.perf_counter() - t_start, 2)
        report["peak_rss_mb"] = round(peak_rss_mb(), 1)
    return DistillResult(field, report, out)
