"""The association stage (paper Sec. 3.2): the segment stage's per-view ids in, view-consistent object
masks out (``associate/`` in docs/architecture.md, "Stage outputs"), by Key Object Management
(:mod:`.kom`) or the 2D tracker of ablation a) (:mod:`.tracker`)."""

from __future__ import annotations

import json
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import torch

from inpaint360gs.associate.config import AssociationConfig
from inpaint360gs.associate.kom import kom, segment_ids
from inpaint360gs.associate.tracker import track
from inpaint360gs.core.errors import InputError
from inpaint360gs.core.files import read_json_object
from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.io import provenance
from inpaint360gs.io.arguments import check_stage_call
from inpaint360gs.io.atomic import atomic_dir, check_output_dir
from inpaint360gs.io.images import write_labels
from inpaint360gs.io.ply import read_ply
from inpaint360gs.io.scene import Scene


@dataclass
class Association:
    """What :func:`associate` returns."""

    masks: dict[str, np.ndarray]  # view name -> (H, W) uint8 associated ids
    objects: list[dict]  # per object id: Gaussians in its set, views and pixels labelled
    config: AssociationConfig  # the resolved settings used


def associate(
    segments: dict[str, np.ndarray], scene: Scene, model: Gaussians, cfg: AssociationConfig | None = None, *, where: str | Path | None = None
) -> Association:
    """Associate the raw segments of ``scene``'s training views (name -> (H, W) id image) into
    view-consistent object masks, processing views in capture (name) order. ``where``: the model's
    file, named when the model covers no segment.

    Args: ``segments`` view name -> (H, W) integer id image; ``cfg`` None = defaults.
    Returns: :class:`Association`.
    Raises: :class:`InputError` when a training view has no segments or segments of another size,
    or the model covers no segment."""
    cfg = (cfg or AssociationConfig()).resolved()
    views = scene.train_views
    missing = [v.name for v in views if v.name not in segments]
    if missing:
        raise InputError(f"no segments for training view {missing[0]} ({len(missing)} missing)")
    for v in views:
        if segments[v.name].shape != (v.camera.height, v.camera.width):
            h, w = segments[v.name].shape
            raise InputError(f"segments of view {v.name} are {w}x{h}, the view is {v.camera.width}x{v.camera.height}")
    segs = [segments[v.name] for v in views]
    opac = torch.sigmoid(model.opacity_logits.detach()).cpu().numpy()
    means = model.means.detach().cpu().double().numpy()[opac >= cfg.min_opacity]
    if cfg.method == "tracker":
        masks, sizes = track(segs, cfg), None
    else:
        masks, sizes = kom(segs, [v.camera for v in views], means, cfg)
    objects = []
    n_obj = int(max((m.max() for m in masks), default=0))
    for oid in range(1, n_obj + 1):
        px = [int((m == oid).sum()) for m in masks]
        objects.append({
            "id": oid,
            "views": int(sum(p > 0 for p in px)),
            "pixels": int(sum(px)),
            **({"gaussians": int(sizes[oid - 1])} if sizes is not None else {}),
        })  # fmt: skip
    if cfg.method == "kom" and sum(len(segment_ids(s, cfg.min_segment_pixels)[0]) for s in segs) and not objects:
        raise InputError("no segment covers any Gaussian: is the model from this scene?", where)
    return Association({v.name: m for v, m in zip(views, masks)}, objects, cfg)


def write_association(result: Association, scene: Scene, out: str | Path, *, meta: dict, overwrite: bool = False) -> None:
    """``OUT/object_mask/<stem>.png`` per training view and ``OUT/objects.json`` (docs/architecture.md,
    "Stage outputs"), atomically."""
    by_name = {v.name: v for v in scene.views}
    with atomic_dir(out, overwrite=overwrite) as tmp:
        for name, m in result.masks.items():
            write_labels(tmp / "object_mask" / f"{by_name[name].stem}.png", m)
        info = {**meta, "config": asdict(result.config), "objects": result.objects, "views": list(result.masks)}
        (tmp / "objects.json").write_text(json.dumps(info, indent=1) + "\n")


def associate_stage(
    scene: Scene,
    model: Gaussians | str | Path,
    segment_dir: str | Path,
    out: str | Path,
    cfg: AssociationConfig | None = None,
    *,
    overwrite: bool = False,
    progress: bool = False,
    model_path: str | Path | None = None,
    meta: dict | None = None,
) -> Association:
    """Read the segment stage's output, associate, write ``out``; returns the association.

    The segments must be of this scene and of this model (docs/architecture.md, "Provenance chain"):
    ``segment.json`` records the scene's content hash, ``--resize`` and the model's sha256.

    Args: ``model`` the 3DGS (a :class:`Gaussians` or its PLY); ``segment_dir`` the segment stage's
    folder; ``out`` the folder to write (absent or empty unless ``overwrite``); ``cfg`` None =
    defaults; ``progress`` taken for the stages' common call shape (the association takes seconds
    and shows no bar); ``model_path`` the model's PLY when ``model`` is a :class:`Gaussians`, checked
    against what the segments record; ``meta`` extra keys for ``objects.json``.
    Raises: :class:`InputError` for a non-empty ``out``, a folder that is no segment output, or
    segments of another scene or model."""
    from inpaint360gs.segment.stage import SEGMENT_JSON, read_segments

    check_stage_call("associate_stage", scene, out, cfg, AssociationConfig, overwrite=overwrite, progress=progress, models={"model": model}, folders={"segment_dir": segment_dir})
    t0 = time.perf_counter()
    check_output_dir(out, overwrite)  # before any work
    if isinstance(model, (str, Path)):
        model_path = Path(model)
        model = read_ply(model_path)
    info_path = Path(segment_dir) / SEGMENT_JSON
    if not info_path.is_file():
        raise InputError(f"not a segment stage output (no {SEGMENT_JSON})", segment_dir)
    info = read_json_object(info_path)
    segmenter = info.get("segmenter", "unknown")
    made = provenance.read(info_path, "segment")
    provenance.check_scene(made, scene, "segment this scene first")
    model_sha = None if model_path is None else provenance.check_model(model_path, scene)
    provenance.check_link(made, "model", model_sha, model_path, "segment with this model first, or give the model the segments were made with")
    by_stem = read_segments(segment_dir, scene)
    result = associate({v.name: by_stem[v.stem] for v in scene.train_views}, scene, model, cfg, where=model_path)
    meta = {**(meta or {}), "segmenter": segmenter, "seconds": round(time.perf_counter() - t0, 2),
            provenance.KEY: provenance.make("associate", scene, {"model": model_sha, "segment": made.identity if made else None}, asdict(result.config))}
    write_association(result, scene, out, meta=meta, overwrite=overwrite)
    return result
