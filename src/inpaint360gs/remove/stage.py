"""The removal stage (paper Sec. 3.4 first paragraph; supp. Eq. 1 AMCR): a distillation output and
clicks or ids in, ``removed/`` out (docs/architecture.md, "Stage outputs"): selection
(:mod:`.select`), removal (:mod:`.objects`), the fill masks. The removed Gaussians are kept in
``removed.ply`` with their features, so that they can be put back (occluders around the inpainting)."""

from __future__ import annotations

import json
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from inpaint360gs.core.errors import InputError
from inpaint360gs.core.files import read_json_object
from inpaint360gs.distill.field import IdentityField
from inpaint360gs.io import provenance
from inpaint360gs.io.arguments import check_stage_call
from inpaint360gs.io.atomic import atomic_dir, check_output_dir
from inpaint360gs.io.images import write_mask
from inpaint360gs.io.ply import write_ply
from inpaint360gs.io.scene import Scene
from inpaint360gs.remove.check import SelectionCheck, assess_selection
from inpaint360gs.remove.config import RemovalConfig
from inpaint360gs.remove.objects import Removal, fill_masks, remove_objects
from inpaint360gs.remove.select import Click, ClickSelection, check_selection, select, support_heights
from inpaint360gs.render.feature_cache import FeatureRenders


def load_field(folder: str | Path, scene: Scene) -> IdentityField:
    """The distillation output ``folder`` (:meth:`IdentityField.load`), checked against its
    ``distill.json`` when there is one: the Gaussian count it records, and the scene it was
    distilled from, which must be ``scene`` (content hash and ``--resize``)."""
    from inpaint360gs.distill.field import DISTILL_JSON, MODEL_PLY  # not distill.stage: it imports the trainer and the metrics (seconds)

    folder = Path(folder)
    field_ = IdentityField.load(folder)
    path = folder / DISTILL_JSON
    if not path.is_file():
        return field_
    report = read_json_object(path)
    n = report.get("num_gaussians")
    if n is not None and n != len(field_.gaussians):
        raise InputError(f"holds {len(field_.gaussians)} Gaussians but {DISTILL_JSON} records {n}: files of two runs?", folder / MODEL_PLY)
    provenance.check_scene(field_.record, scene, "distill this scene first")  # docs/architecture.md, "Provenance chain"
    return field_


@dataclass
class RemovalPlan:
    """What a removal will take, before anything is written: the clicks' selections, the object ids,
    the removal itself and the check that it is an object (:mod:`.check`)."""

    picked: list[ClickSelection]
    targets: list[int]
    removal: Removal
    check: SelectionCheck
    support_note: str
    masks: dict[str, np.ndarray]  # per training view: the pixels to fill (the removed Gaussians' rendered footprint)


@dataclass
class Selected:
    """The first half of a :class:`RemovalPlan` (:func:`select_removal`): what the clicks and ids
    select and what the removal takes, before the fill masks and the check."""

    clicks: list[Click]
    picked: list[ClickSelection]
    targets: list[int]
    removal: Removal
    support_note: str
    heights: np.ndarray | None
    radius: float


def support_plane(field_: IdentityField, scene: Scene, cfg: RemovalConfig | None = None) -> tuple[np.ndarray | None, float, str, np.ndarray | None]:
    """What :func:`.select.support_heights` gives when ``cfg`` uses the support plane, else (None, 0,
    "support guard off", None); the same for every selection on one field (the viewer keeps it)."""
    cfg = cfg or RemovalConfig()
    needs_plane = cfg.protect_support is not None or cfg.support_column is not None or cfg.footprint_margin is not None
    return support_heights(field_, scene) if needs_plane else (None, 0.0, "support guard off", None)


def select_removal(field_: IdentityField, scene: Scene, *, clicks: list[Click] | None = None, ids: list[int] | None = None,
                   cfg: RemovalConfig | None = None, backend: str = "auto", support=None, renders: FeatureRenders | None = None,
                   picked: list[ClickSelection] | None = None) -> Selected:  # fmt: skip
    """Select (clicks and/or ids) and remove in memory: :func:`plan_removal` up to its fill masks.
    ``support``: :func:`support_plane` of this field when already found; ``renders``: the training
    views' projections of the field's Gaussians kept between calls (the same result, faster);
    ``picked``: :func:`.select.select` of these clicks when already done (each click's is its own)."""
    cfg = cfg or RemovalConfig()
    clicks = list(clicks or [])
    picked = select(field_, scene, clicks, backend=backend) if picked is None else list(picked)
    if len(picked) != len(clicks):
        raise ValueError("picked must hold one selection per click")
    targets = [p.object_id for p in picked if p.object_id is not None] + list(ids or [])
    targets = list(dict.fromkeys(targets))  # keep order, drop repeats
    grown = [p.gaussians for p in picked if p.gaussians is not None]
    heights, radius, support_note, up = support_plane(field_, scene, cfg) if support is None else support
    res = remove_objects(field_, targets, cfg, heights=heights, radius=radius, up=up, grown=grown, views=scene.train_views, backend=backend,
                         renders=renders)  # fmt: skip
    return Selected(clicks, picked, targets, res, support_note, heights, radius)


def complete_plan(field_: IdentityField, scene: Scene, sel: Selected, *, cfg: RemovalConfig | None = None, backend: str = "auto",
                  renders: FeatureRenders | None = None, masks: dict[str, np.ndarray] | None = None) -> RemovalPlan:  # fmt: skip
    """The rest of :func:`plan_removal` after :func:`select_removal`: the fill masks of the training
    views (those in ``masks`` already drawn for this selection are kept) and the selection check."""
    cfg = cfg or RemovalConfig()
    masks = dict(masks or {})
    todo = [v for v in scene.train_views if v.name not in masks]
    masks.update(fill_masks(field_.gaussians, sel.removal.removed_mask, todo, cfg.mask_share, backend, renders))
    masks = {v.name: masks[v.name] for v in scene.train_views}
    # ids only: no click to place the selection by; its size, support and backdrop tests still hold
    check = assess_selection(field_, scene, sel.removal.removed_mask.numpy(), sel.clicks, heights=sel.heights, radius=sel.radius, masks=masks)
    return RemovalPlan(sel.picked, sel.targets, sel.removal, check, sel.support_note, masks)


def plan_removal(field_: IdentityField, scene: Scene, *, clicks: list[Click] | None = None, ids: list[int] | None = None,
                 cfg: RemovalConfig | None = None, backend: str = "auto", support=None, renders: FeatureRenders | None = None) -> RemovalPlan:  # fmt: skip
    """Select (clicks and/or ids), remove in memory and check the selection; writes nothing (the
    viewer and :func:`remove_stage` share it). Raises :class:`InputError` for a click that selects
    nothing or an unknown id. ``support`` and ``renders``: as :func:`select_removal` (the viewer's
    clicks keep them; the same plan, faster)."""
    sel = select_removal(field_, scene, clicks=clicks, ids=ids, cfg=cfg, backend=backend, support=support, renders=renders)
    return complete_plan(field_, scene, sel, cfg=cfg, backend=backend, renders=renders)


def over_removal(field_: IdentityField, res, views, stack: np.ndarray, cfg: RemovalConfig, backend: str = "auto",
                 renders: FeatureRenders | None = None) -> dict:  # fmt: skip
    """How much more the removal's masks cover than the object as it stands: the masks' pixels over
    the pixels of the standing part of what the selection took (steps 1-2 of
    :func:`.objects.remove_objects`, higher than a tenth of the object's height over its support; the
    same mask rule), summed over the training views. Support taken beyond the object (large support
    Gaussians in the footprint column, or support the field labelled as the object) shows as a
    ratio well above 1; the footprint column's margin and contact rim, which are meant to go, add a
    little. The run's check judges it (``CheckLimits.over_removal``; docs/architecture.md, "A run
    checks itself")."""
    from inpaint360gs.remove.objects import fill_masks

    if res.standing_mask is None or not bool(res.standing_mask.any()):
        return {"ratio": None, "note": "nothing of the selection stands above the support"}
    standing = fill_masks(field_.gaussians, res.standing_mask, views, cfg.mask_share, backend, renders)
    px_standing = int(sum(int(standing[v.name].sum()) for v in views))
    px_removed = int(stack.sum())
    return {"ratio": px_removed / px_standing if px_standing else None, "removed_pixels": px_removed, "standing_pixels": px_standing}


def remove_stage(
    scene: Scene,
    field_: IdentityField,
    out: str | Path,
    cfg: RemovalConfig | None = None,
    *,
    clicks: list[Click] | None = None,
    ids: list[int] | None = None,
    backend: str = "auto",
    overwrite: bool = False,
    progress: bool = False,
    meta: dict | None = None,
) -> dict:
    """Select (clicks and/or ids), remove, write ``out`` (docs/architecture.md, "Stage outputs").

    Args: ``field_`` the distillation output; ``cfg`` None = defaults; ``clicks`` on the object, in
    ``images/`` pixels; ``ids`` object ids to remove besides; ``backend`` the rasterizer
    (:func:`render`); ``overwrite`` replace a non-empty ``out``; ``progress`` taken for the stages'
    common call shape (the removal takes seconds and shows no bar); ``meta`` extra keys for
    ``removal.json``.
    Returns: what ``removal.json`` holds; its ``selection_check`` says whether the selection is an
    object (:mod:`.check`; the stage records it, ``inpaint360gs run`` acts on it).
    Raises: :class:`InputError` for a non-empty ``out`` or a click that selects nothing."""
    from inpaint360gs.metrics import amcr  # here: torchmetrics and scipy.stats take seconds to import (the viewer's page waits for plan_removal's imports)

    check_stage_call("remove_stage", scene, out, cfg, RemovalConfig, overwrite=overwrite, progress=progress)
    if not isinstance(field_, IdentityField):
        raise InputError(f"expected an IdentityField (load_field), got {type(field_).__name__}", setting="remove_stage.field_")
    check_selection(clicks, ids)
    cfg = (cfg or RemovalConfig()).validate()
    check_output_dir(out, overwrite)  # before any work
    t0 = time.perf_counter()
    clicks = list(clicks or [])
    renders = FeatureRenders(field_.gaussians, backend)  # each view projected once: the plan's masks and over_removal's
    plan = plan_removal(field_, scene, clicks=clicks, ids=ids, cfg=cfg, backend=backend, renders=renders)
    picked, targets, res = plan.picked, plan.targets, plan.removal
    views, masks = scene.train_views, plan.masks
    stack = np.stack([masks[v.name] for v in views])
    over = over_removal(field_, res, views, stack, cfg, backend, renders)
    info = {
        **(meta or {}),
        "clicks": [str(c) for c in clicks],
        "objects": targets,
        "selected_by": {str(p.click): p.how for p in picked},
        "removed_gaussians": int(res.removed_mask.sum()),
        "kept_gaussians": len(res.kept),
        "counts": res.counts,
        "selection_check": plan.check.to_json(),
        "amcr_percent": amcr(stack),
        "over_removal": over,
        "mask_rule": f"a pixel is to be filled when removed Gaussians gave at least {cfg.mask_share:g} of its colour in the original model",
        "config": asdict(cfg),
        "support": plan.support_note,
        "footprints": [fp.to_json() for fp in res.footprints],
        "seconds": round(time.perf_counter() - t0, 2),
        provenance.KEY: provenance.make("remove", scene, {"distill": field_.record.identity if field_.record else None},
                                        {"clicks": [str(c) for c in clicks], "objects": targets, "config": asdict(cfg), "backend": backend}),
    }
    with atomic_dir(out, overwrite=overwrite) as tmp:
        write_ply(tmp / "point_cloud.ply", res.kept)
        write_ply(tmp / "removed.ply", res.removed)
        np.save(tmp / "removed_index.npy", np.flatnonzero(res.removed_mask.numpy()))
        for v in views:
            write_mask(tmp / "masks" / f"{v.stem}.png", masks[v.name])
        provenance.add_outputs(info, tmp, "point_cloud.ply")
        (tmp / "removal.json").write_text(json.dumps(info, indent=1) + "\n")
    return info
