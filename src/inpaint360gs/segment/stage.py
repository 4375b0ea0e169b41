"""The segment stage: raw 2D masks for every training view (paper Sec. 3.2, first step).

Writes ``OUT/<stem>.png`` (16-bit id image, 0 = no segment, ids per view) for every training view and
``OUT/segment.json`` (segmenter name, settings, what its preparation found, per-view segment counts,
timings, inputs with sha256), atomically (docs/architecture.md, "Stage outputs"). Inputs are checked
before the expensive part: every training image is decoded first, the segmenter's ``prepare``
checks its own inputs (gt/ files, ONNX files), and a model the segmenter renders must reproduce the
scene's training views (a model trained on another scene is refused). Never reads ``test_`` pixels.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import numpy as np
import torch

from inpaint360gs.core.errors import InputError
from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.core.progress import track
from inpaint360gs.io import provenance
from inpaint360gs.io.arguments import check_stage_call
from inpaint360gs.io.atomic import atomic_dir, check_output_dir
from inpaint360gs.io.images import write_labels
from inpaint360gs.io.ply import read_ply
from inpaint360gs.io.scene import Scene
from inpaint360gs.metrics import psnr
from inpaint360gs.render.api import render
from inpaint360gs.segment.base import DEFAULT_SEGMENTER, Segmenter, check_id_image, get_segmenter

SEGMENT_JSON = "segment.json"
# A trained model reproduces its own training views far better than this (results/README.md,
# "3DGS reconstruction"); another scene's model at these cameras scores well below it.
MIN_MODEL_PSNR = 16.0
MODEL_CHECK_VIEWS = 3




@torch.no_grad()
def check_model_fits_scene(scene: Scene, model: Gaussians, images: dict[str, torch.Tensor], where: str | Path = "MODEL") -> float:
    """Mean PSNR of ``model`` at a few training views; :class:`InputError` when it does not
    reproduce them (a model of another scene, an empty or untrained one)."""
    views = scene.train_views
    pick = [views[round(i * (len(views) - 1) / max(MODEL_CHECK_VIEWS - 1, 1))] for i in range(min(MODEL_CHECK_VIEWS, len(views)))]
    scores = []
    for v in pick:
        out = render(model, v.camera)
        scores.append(psnr(out.color.clamp(0, 1), images[v.name]))
    mean = float(np.mean(scores))
    if not mean >= MIN_MODEL_PSNR:
        raise InputError(
            f"the model does not reproduce the training views of {scene.name} (PSNR {mean:.1f} dB < {MIN_MODEL_PSNR:g} dB "
            f"on {len(pick)} views): trained on another scene, at another --resize, or not trained?",
            where,
        )
    return mean


def segment_stage(
    scene: Scene,
    model: Gaussians | str | Path | None,
    out: str | Path,
    cfg: Segmenter | None = None,
    *,
    model_path: str | Path | None = None,
    overwrite: bool = False,
    progress: bool = False,
    check_model: bool = True,
) -> dict:
    """Segment every training view of ``scene`` into ``out`` (see the module docstring); returns
    what segment.json holds.

    Args: ``model`` the 3DGS (a :class:`Gaussians` or its PLY; None for a segmenter that does not use
    it); ``cfg`` the segmenter (a configured :class:`Segmenter`; None: the default one);
    ``model_path`` the model's PLY when ``model`` is a :class:`Gaussians`, checked to be of this scene
    and recorded; ``overwrite`` replace a non-empty ``out``; ``progress`` show a progress bar;
    ``check_model`` refuse a model that does not reproduce the views.
    Raises: :class:`InputError` for a non-empty ``out``, a missing or mismatched model, or a segmenter
    returning an id image of the wrong shape or type."""
    check_stage_call("segment_stage", scene, out, cfg, Segmenter, overwrite=overwrite, progress=progress, models={} if model is None else {"model": model})
    segmenter = get_segmenter(DEFAULT_SEGMENTER) if cfg is None else cfg
    check_output_dir(out, overwrite)  # before any work
    if isinstance(model, (str, Path)):
        model_path = Path(model)
        model = read_ply(model_path) if segmenter.uses_model else None
    views = scene.train_views
    t0 = time.perf_counter()
    images = {v.name: scene.load_image(v) for v in views}  # decode every input before the work
    # a model another stage recorded as made from another scene is refused (docs/architecture.md, "Provenance chain")
    model_sha = None if model_path is None else provenance.check_model(model_path, scene, "segment with the model trained on this scene")
    if segmenter.uses_model:
        if model is None:
            raise InputError(f"segmenter {segmenter.name} needs the trained model", "MODEL")
        model = model.map(lambda t: t.detach().float().cpu())
        model_psnr = check_model_fits_scene(scene, model, images, model_path or "MODEL") if check_model else None
    else:
        model_psnr = None
    read_files = segmenter.input_digests(scene)
    t_load = time.perf_counter() - t0
    t0 = time.perf_counter()
    segmenter.prepare(scene, model if segmenter.uses_model else None)
    t_prepare = time.perf_counter() - t0
    per_view: dict[str, dict] = {}
    seconds = []
    with atomic_dir(out, overwrite=overwrite) as tmp:
        for v in track(views, f"segment ({segmenter.name})", progress):
            t = time.perf_counter()
            ids = check_id_image(segmenter.segment(v, images[v.name]), v, segmenter.name)
            seconds.append(time.perf_counter() - t)
            write_labels(tmp / f"{v.stem}.png", ids)
            present = np.unique(ids[ids > 0])
            per_view[v.stem] = {"segments": int(len(present)), "covered_fraction": round(float((ids > 0).mean()), 4)}
        inputs = {"scene": str(scene.root), "scene_content_sha256": scene.fingerprint(), "resize": scene.resize}
        if model_path is not None:
            inputs.update(model=str(model_path), model_sha256=model_sha)
        info = {
            "segmenter": segmenter.name,
            "reads_ground_truth": segmenter.reads_ground_truth,
            "settings": segmenter.settings(),
            "prepared": segmenter.summary(),
            "inputs": inputs,
            provenance.KEY: provenance.make("segment", scene, {"model": model_sha}, {"segmenter": segmenter.name, "settings": segmenter.settings(), "views": [v.name for v in views],
                                                                        "files": read_files}),
            "model_check_psnr": None if model_psnr is None else round(model_psnr, 2),
            "num_views": len(views),
            "views": per_view,
            "timings": {
                "load_seconds": round(t_load, 3),
                "prepare_seconds": round(t_prepare, 3),
                "segment_seconds": round(float(np.sum(seconds)), 3),
                "ms_per_view": round(1000 * float(np.mean(seconds)), 1) if seconds else None,
            },
        }
        (tmp / SEGMENT_JSON).write_text(json.dumps(info, indent=2) + "\n")
    return info


def read_segments(folder: str | Path, scene: Scene) -> dict[str, np.ndarray]:
    """The id images of a segment/ folder for ``scene``'s training views (for later stages and tests)."""
    from inpaint360gs.io.images import read_mask

    folder = Path(folder)
    if not (folder / SEGMENT_JSON).is_file():
        raise InputError(f"not a segment stage output (no {SEGMENT_JSON})", folder)
    out = {}
    for v in scene.train_views:
        ids = read_mask(folder / f"{v.stem}.png")
        if ids.shape != (v.camera.height, v.camera.width):
            raise InputError(f"id image is {ids.shape[1]}x{ids.shape[0]} but view {v.name} is {v.camera.width}x{v.camera.height}", folder / f"{v.stem}.png")
        out[v.stem] = ids
    return out
