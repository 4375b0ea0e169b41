"""Scoring a removal on a capture without ground truth (docs/architecture.md, "Real captures"): the
no-reference scores of :mod:`inpaint360gs.metrics.capture` applied to a run's models at the scene's
training and held-out cameras, and a before / removed / inpainted figure.

Inputs are the stage outputs a run leaves: the trained 3DGS, the distilled model (the removal's
indices refer to it), the removal folder and, when there is one, the inpainting folder.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch
from scipy.spatial import cKDTree

from inpaint360gs.core.errors import InputError
from inpaint360gs.core.files import read_json_object
from inpaint360gs.core.support import Footprint, object_footprint
from inpaint360gs.evaluate.limits import CheckLimits
from inpaint360gs.io.ply import read_ply
from inpaint360gs.io.scene import Scene
from inpaint360gs.metrics.capture import neighbour_gaussians, object_beside, object_in_fill, psnr_outside, standing_mass, standing_share, texture_ratios
from inpaint360gs.render.api import render
from inpaint360gs.views.unseen import footprint



@dataclass
class CaptureRun:
    """The stage outputs a score reads (``inpainted`` may be None: removal only)."""

    model: Path  # trained 3DGS PLY
    distill: Path  # distillation folder (point_cloud.ply with the Gaussians the removal indexes)
    removed: Path  # removal folder (point_cloud.ply, removed_index.npy)
    inpainted: Path | None = None  # inpainting folder (point_cloud.ply)

    @staticmethod
    def of_run(run: str | Path) -> "CaptureRun":
        """The folders of ``inpaint360gs run``'s OUT; the model is its ``3dgs/`` PLY, or the one the
        distillation was made from when the run was given ``--model``. Raises :class:`InputError`
        when the run has no distillation to read that from."""
        run = Path(run)
        inp = run / "inpainted"
        model = run / "3dgs" / "point_cloud.ply"
        if not model.is_file():
            record = run / "distill" / "distill.json"
            if not record.is_file():
                raise InputError("not a finished run of inpaint360gs run (no 3dgs/point_cloud.ply and no distill/distill.json)", run)
            model = Path(read_json_object(record)["inputs"]["model"])
        return CaptureRun(model, run / "distill", run / "removed", inp if (inp / "point_cloud.ply").is_file() else None)


def check_run(scene: Scene, run: CaptureRun) -> None:
    """The run's outputs must be this scene's and follow from each other (docs/architecture.md,
    "Provenance chain"): the model, the distillation, the removal made from it, the inpainting made
    from that removal."""
    from inpaint360gs.io import provenance

    provenance.check_model(run.model, scene)
    made = provenance.of_stage(run.distill, "distill")
    removal = provenance.of_stage(run.removed, "remove")
    provenance.check_scene(made, scene, "give this scene's distillation")
    provenance.check_scene(removal, scene, "give this scene's removal")
    provenance.check_link(removal, "distill", made and made.identity, run.distill, "give the distillation the removal was made from")
    if run.inpainted is not None:
        inp = provenance.of_stage(run.inpainted, "inpaint")
        provenance.check_link(inp, "removal", removal and removal.identity, run.removed, "give the removal the inpainting was made from")


NEAR_CAMERA = 0.5  # the footprint leaves out what lies nearer to a camera than this x the removed Gaussians' median depth


def score_capture(scene: Scene, run: CaptureRun, *, grow_px: int = 15, ring_px: int = 20) -> tuple[dict, dict]:
    """(scores, renders): PSNR outside the footprint grown by ``grow_px`` per split and model, the
    share standing in the footprint column after removal and after inpainting, the fill's texture
    ratios against a ``ring_px`` ring at the training cameras; ``renders[model][view name]``.
    :class:`InputError` when the run's outputs do not belong together (:func:`check_run`)."""
    from inpaint360gs.segment.frame import camera_up

    check_run(scene, run)
    distilled = read_ply(run.distill / "point_cloud.ply")
    index = np.load(run.removed / "removed_index.npy")
    removed = torch.zeros(len(distilled), dtype=torch.bool)
    removed[torch.from_numpy(index.astype(np.int64))] = True
    models = {"3dgs": read_ply(run.model), "removed": read_ply(run.removed / "point_cloud.ply")}
    if run.inpainted is not None:
        models["inpainted"] = read_ply(run.inpainted / "point_cloud.ply")
    splits = {"train": scene.train_views, "held-out": scene.holdout_views}
    views = splits["train"] + splits["held-out"]
    # the removed Gaussians' footprint, floaters hanging near a camera left out (views/unseen.footprint):
    # a haze in front of a held-out view would leave it empty and score the whole object as "outside"
    fps = {v.name: footprint(distilled, removed, v.camera, near=NEAR_CAMERA) for v in views}
    photos = {v.name: scene.load_image(v).numpy() for v in views}  # read once: every model is scored against them
    scores: dict = {"psnr_outside": {}, "texture": {}, "standing": {}, "beside": {}, "in_fill": {}}
    renders: dict[str, dict[str, np.ndarray]] = {k: {} for k in models}
    with torch.no_grad():
        for split, vs in splits.items():
            for name, g in models.items():
                vals = []
                for v in vs:
                    img = render(g, v.camera).color.clamp(0, 1).numpy()
                    renders[name][v.name] = img
                    vals.append(psnr_outside(img, photos[v.name], fps[v.name], grow_px))
                scores["psnr_outside"].setdefault(split, {})[name] = float(np.nanmean(vals)) if np.isfinite(vals).any() else None  # None: no view has a pixel outside
    for name in models:
        if name == "3dgs":
            continue
        ratios = [r for v in splits["train"] if (r := texture_ratios(renders[name][v.name], fps[v.name], ring_px)) is not None]
        scores["texture"][name] = {
            "laplacian": float(np.nanmean([r.laplacian for r in ratios])) if ratios else None,
            "luminance": float(np.nanmean([r.luminance for r in ratios])) if ratios else None,
            "ring_laplacian": float(np.nanmean([r.ring_laplacian for r in ratios])) if ratios else None,
            "views": len(ratios),
        }
        shares = [b for v in splits["train"] if (b := object_beside(renders[name][v.name], photos[v.name], fps[v.name])) is not None]
        scores["beside"][name] = {"share": float(np.mean(shares)) if shares else None, "worst_view": float(np.max(shares)) if shares else None,
                                  "views": len(shares)}  # fmt: skip
        if name == "inpainted":  # before the inpainting the hole shows what lies behind the object
            shares = [b for v in splits["train"] if (b := object_in_fill(renders[name][v.name], photos[v.name], fps[v.name])) is not None]
            scores["in_fill"][name] = {"share": float(np.mean(shares)) if shares else None, "worst_view": float(np.max(shares)) if shares else None,
                                       "views": len(shares)}  # fmt: skip
    means = distilled.means.detach().double().numpy()
    opac = distilled.opacities.detach().double().numpy()
    rm = removed.numpy()
    try:
        fp: Footprint = object_footprint(means[rm], opac[rm], means[~rm], opac[~rm], camera_up([v.camera for v in scene.train_views]))
    except ValueError as e:  # too few Gaussians, or nothing to stand on: the standing score does not apply
        scores["object_height"] = None
        scores["standing_note"] = str(e)
        return scores, renders
    scores["object_height"] = fp.height
    neighbours = _neighbours(run.distill, distilled, opac, rm, fp)
    scores["standing_neighbours"] = int(neighbours.sum())
    before = standing_mass(means, opac, fp, exclude=neighbours)  # the object: what stood in the column before the removal
    for name in ("removed", "inpainted"):
        if name in models:
            m = models[name]
            mm = m.means.detach().double().numpy()
            # a neighbour's Gaussians in the evaluated model: those nearest to one in the distilled model
            exclude = neighbours[cKDTree(means).query(mm)[1]] if neighbours.any() else None
            share, count = standing_share(mm, m.opacities.detach().double().numpy(), fp, reference=before, exclude=exclude)
            scores["standing"][name] = {"share": share, "count": count}
    return scores, renders


def _neighbours(distill: Path, distilled, opac: np.ndarray, removed: np.ndarray, fp: Footprint) -> np.ndarray:
    """(N,) bool over the ``distilled`` Gaussians: those of other objects reaching into the
    footprint column (:func:`~inpaint360gs.metrics.capture.neighbour_gaussians`), by the distilled
    field's labels (probability > 0.5, as the removal protects other objects); none when the
    folder has no classifier. Objects the removal took half or more of are the removed ones."""
    from inpaint360gs.distill.field import CLASSIFIER_JSON, IdentityField, read_classifier

    means = distilled.means.detach().double().numpy()
    if not (distill / CLASSIFIER_JSON).is_file():
        return np.zeros(len(means), dtype=bool)
    classifier, ids = read_classifier(distill / CLASSIFIER_JSON)  # a broken one: InputError naming it
    with torch.no_grad():
        probs = IdentityField(distilled, classifier, ids).gaussian_probs().numpy()
    members = probs > 0.5
    others = [k for k, oid in enumerate(ids) if oid != 0 and (members[:, k] & removed).sum() < 0.5 * members[:, k].sum()]
    if not others:
        return np.zeros(len(means), dtype=bool)
    return neighbour_gaussians(means, opac, fp, members[:, others])


def figure(renders: dict[str, dict[str, np.ndarray]], names: list[str]) -> np.ndarray:
    """Rows 3DGS / removed / inpainted (those present), columns the views ``names``."""
    rows = [np.concatenate([renders[k][n] for n in names], axis=1) for k in ("3dgs", "removed", "inpainted") if k in renders]
    return np.concatenate(rows, axis=0)


def format_scores(scores: dict, limits: CheckLimits | None = None) -> str:
    """The scores as the lines ``bench_capture.py`` and ``inpaint360gs capture-scores`` print, with
    the ``limits`` (the run check's) as targets."""
    lim = limits or CheckLimits()
    t = {"outside_drop_db": lim.outside_drop_db, "standing": lim.standing}
    lines = ["PSNR outside the footprint grown by the margin (dB), mean over views:", f"  {'split':10s} {'3dgs':>8s} {'removed':>8s} {'inpainted':>10s} {'inp-rem':>8s}"]
    for split, row in scores["psnr_outside"].items():
        inp = row.get("inpainted")
        diff = f"{inp - row['removed']:+8.2f}" if inp is not None else "     n/a"
        inp_s = f"{inp:10.2f}" if inp is not None else "       n/a"
        lines.append(f"  {split:10s} {row['3dgs']:8.2f} {row['removed']:8.2f} {inp_s} {diff}   (target >= -{t['outside_drop_db']})")
    if scores["object_height"] is None:
        lines.append(f"Standing in the footprint column: not scored ({scores.get('standing_note')})")
    else:
        lines.append(f"Standing in the footprint column (> 10% of the object's height {scores['object_height']:.4g} above the support), opacity-weighted, as a share of what stood there before the removal:")
    for name, s in scores["standing"].items():
        lines.append(f"  {name:10s} {100 * s['share']:6.2f} %  ({s['count']} Gaussians)   (target <= {100 * t['standing']:.0f} %)")
    lines.append("Fill texture at the training cameras, inside the footprint / ring:")
    for name, x in scores["texture"].items():
        lap = "n/a" if x["laplacian"] is None else f"{x['laplacian']:.2f}"
        lum = "n/a" if x["luminance"] is None else f"{x['luminance']:.2f}"
        lines.append(f"  {name:10s} |Laplacian| {lap:>5s} (target {lim.laplacian[0]}-{lim.laplacian[1]})   luminance {lum:>5s} (target 1 +- {lim.luminance})   over {x['views']} views")
    if scores.get("beside"):
        lines.append("The object's colours just outside the footprint (10 px), none of the colours 20-40 px around it, as a share of the footprint's area, at the training cameras:")
        for name, b in scores["beside"].items():
            share = "n/a" if b["share"] is None else f"{100 * b['share']:.2f} %"
            worst = "" if b["worst_view"] is None else f", worst view {100 * b['worst_view']:.2f} %"
            target = f"   (target <= {100 * lim.beside:g} %)" if name == "inpainted" and lim.beside is not None else ""
            lines.append(f"  {name:10s} {share:>8s}{worst} over {b['views']} views{target}")
    if scores.get("in_fill"):
        lines.append("The object's colours inside the footprint after inpainting, none of the colours 20-40 px around it, as a share of the footprint's area:")
        for name, b in scores["in_fill"].items():
            share = "n/a" if b["share"] is None else f"{100 * b['share']:.2f} %"
            worst = "" if b["worst_view"] is None else f", worst view {100 * b['worst_view']:.2f} %"
            target = f"   (target <= {100 * lim.in_fill:g} %)" if lim.in_fill is not None else "   (reported)"
            lines.append(f"  {name:10s} {share:>8s}{worst} over {b['views']} views{target}")
    return "\n".join(lines)


def worst_case(scores: list[dict], limits: CheckLimits | None = None) -> dict:
    """Median and worst over runs (seeds) of each score of :func:`score_capture`, and whether the
    worst meets ``limits``: a method is judged by its worst run, not its best. Each entry:
    ``{"values": [...], "median": m, "worst": w, "limit": text, "passed": bool}`` (None where no run
    has the score); the drops are the PSNR lost outside the grown footprint (3DGS to removed,
    removed to inpainted) per split, the texture ratio's worst is the farthest from 1."""
    lim = limits or CheckLimits()
    lo, hi = lim.laplacian

    def collect(get) -> list[float]:
        vals = []
        for s in scores:
            try:
                v = get(s)
            except (KeyError, TypeError):
                v = None
            if v is not None and np.isfinite(v):
                vals.append(float(v))
        return vals

    rows = {}
    for split in ("train", "held-out"):
        for before, after in (("3dgs", "removed"), ("removed", "inpainted")):
            rows[f"drop_{after}_{split}"] = (collect(lambda s: s["psnr_outside"][split][before] - s["psnr_outside"][split][after]), max,
                                             lambda w: w <= lim.outside_drop_db, f"<= {lim.outside_drop_db} dB")  # fmt: skip
    for name in ("removed", "inpainted"):
        rows[f"standing_{name}"] = (collect(lambda s: s["standing"][name]["share"]), max, lambda w: w <= lim.standing, f"<= {lim.standing}")
    rows["beside_inpainted"] = (collect(lambda s: s["beside"]["inpainted"]["share"]), max,
                                lambda w: lim.beside is None or w <= lim.beside, f"<= {lim.beside}")  # fmt: skip
    rows["in_fill_inpainted"] = (collect(lambda s: s["in_fill"]["inpainted"]["share"]), max,
                                 lambda w: lim.in_fill is None or w <= lim.in_fill, f"<= {lim.in_fill}")  # fmt: skip
    rows["fill_laplacian"] = (collect(lambda s: s["texture"]["inpainted"]["laplacian"]), lambda v: max(v, key=lambda x: abs(np.log(max(x, 1e-9)))),
                              lambda w: lo <= w <= hi, f"{lo}-{hi}")  # fmt: skip
    rows["fill_luminance"] = (collect(lambda s: s["texture"]["inpainted"]["luminance"]), lambda v: max(v, key=lambda x: abs(x - 1.0)),
                              lambda w: abs(w - 1.0) <= lim.luminance, f"1 +- {lim.luminance}")  # fmt: skip
    out = {}
    for key, (vals, worst_of, ok, limit) in rows.items():
        if not vals:
            out[key] = {"values": [], "median": None, "worst": None, "limit": limit, "passed": None}
            continue
        w = worst_of(vals)
        out[key] = {"values": vals, "median": float(np.median(vals)), "worst": float(w), "limit": limit, "passed": bool(ok(w))}
    return out


def format_worst_case(summary: dict, runs: int) -> str:
    """:func:`worst_case` as the table ``bench_capture.py`` prints for several runs."""
    lines = [f"Over {runs} runs: median and worst (the targets are on the worst)", f"  {'score':26s} {'median':>8s} {'worst':>8s}  target      verdict"]
    for key, r in summary.items():
        if r["worst"] is None:
            lines.append(f"  {key:26s} {'n/a':>8s} {'n/a':>8s}  {r['limit']:11s} not scored")
            continue
        lines.append(f"  {key:26s} {r['median']:8.3f} {r['worst']:8.3f}  {r['limit']:11s} {'ok' if r['passed'] else 'FAILED'}")
    return "\n".join(lines)
