"""What a run's removal took (docs/architecture.md, "Ground-truth removal scores"):
``inpaint360gs evaluate --removal`` and ``inpaint360gs score-removal``.

- **AMCR** (paper supp. Eq. 1) — "the proportion of empty regions in the image after object removal,
  averaged over the N training images": the mean over the scene's training views of the percentage
  of pixels in the removal stage's own masks (``removed/masks/<stem>.png``,
  :func:`inpaint360gs.remove.objects.fill_masks`). The exact pixel rule of those masks: a pixel is
  to be filled when the removed Gaussians give at least ``mask_share`` (0.5) of its colour in the
  model before the removal, i.e. their share Σ αᵢTᵢ of the pixel's compositing weights (Eq. 1) over
  a black background. :func:`training_amcr`. Needs no ground truth.
- **removed silhouette at the test cameras** (``silhouette_test``): the same rule applied at the
  test cameras, by rendering the removal's footprint there with the rasterizer ``backend`` the
  removal used. The model the removal started from (the distilled field) is put back together from
  the removal's output: its kept Gaussians (``point_cloud.ply``), its removed ones (``removed.ply``)
  and their indices (``removed_index.npy``) — exact subsets of it, so every Gaussian is where it
  was. It covers the object's whole silhouette in each test view, most of which other views saw:
  a property of the removal, not of the task (that is the unseen share).
- **ground-truth scores** of a synthetic scene (``gt/``): residual, collateral and the true
  footprint's share of the training views (:mod:`inpaint360gs.metrics.removal`), with the edited and
  the original model rendered at the training cameras. The rules compare images pixel for pixel
  (the photos are the generator's), the edited model's depths with the original model's, and the
  true depths with each other, so a scene posed by structure from motion (its cameras and models
  in the reconstruction's frame) needs no alignment. ``scale_to_truth`` (the scale of the
  similarity mapping the scene's camera centres onto ``gt/cameras.json``'s, least squares, Umeyama
  1991) is reported beside the scores as a diagnostic of the frame. :func:`removal_scores`.

Each is a property of each run's own removal (a method with another association, or another seed,
has another one).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import torch

from inpaint360gs.core.errors import InputError
from inpaint360gs.core.files import check_readable, read_json_object
from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.io import provenance
from inpaint360gs.io.images import read_mask
from inpaint360gs.io.ply import read_ply
from inpaint360gs.io.scene import Scene, View
from inpaint360gs.metrics import removal as scores
from inpaint360gs.metrics.masked import amcr
from inpaint360gs.remove.config import RemovalConfig
from inpaint360gs.remove.objects import fill_masks
from inpaint360gs.render.api import render
from inpaint360gs.views.unseen import normalised_depth

NO_TRUTH = "no ground truth: gt/ of a synthetic scene (gt/cameras.json, gt/objects.json) is needed"
NO_FREE_DEPTH = ("no gt/depth_free: the scene was generated before the generator wrote the object-free depth of its photos "
                 "(regenerate it: inpaint360gs-dataset synth --overwrite)")
DEFINITIONS = {
    "amcr": ("AMCR (paper supp. Eq. 1): mean over the training views of 100 * pixels in the removal's masks / image pixels; a "
             "pixel is in the mask when the removed Gaussians give at least mask_share of its colour (compositing weight) in the "
             "model before the removal"),
    "residual": (f"percentage of the targets' true footprint pixels (gt/instance) where the edited model shows a surface "
                 f"(alpha >= 0.5) within {scores.DEPTH_TOLERANCE:.0%} of the true depth with the object (gt/depth) while that depth lies "
                 f"more than {scores.DEPTH_TOLERANCE:.0%} in front of the object-free surface (gt/depth_free)"),
    "collateral": (f"percentage of the pixels outside the true footprint grown by max({scores.GROW_MIN_PX} px, "
                   f"{scores.GROW_SHARE:g} x sqrt(footprint pixels)) whose colour changes by more than {scores.COLOUR_CHANGE:g} "
                   "(largest channel) between the model before and after the removal"),
    "gt_footprint_share": "mean over the training views of 100 * the targets' true footprint pixels / image pixels",
    "amcr_ratio": "amcr / gt_footprint_share (same training views)",
}


def _removal_info(removed_dir: Path) -> dict:
    path = removed_dir / "removal.json"
    check_readable(path, "the removal stage's record (inpaint360gs remove)", missing="not a removal stage output (no removal.json)")
    try:
        info = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise InputError(f"not valid JSON ({e})", path) from None
    if not isinstance(info, dict):
        raise InputError("not a removal record (expected a JSON object)", path)
    return info


def original_model(removed_dir: str | Path) -> tuple[Gaussians, torch.Tensor]:
    """The model the removal in ``removed_dir`` started from and the mask of what it removed."""
    removed_dir = Path(removed_dir)
    kept, removed = read_ply(removed_dir / "point_cloud.ply"), read_ply(removed_dir / "removed.ply")
    index_path = removed_dir / "removed_index.npy"
    check_readable(index_path, "the removal's removed_index.npy", missing="not a removal stage output (no removed_index.npy)")
    try:
        index = np.load(index_path)
    except (ValueError, OSError) as e:
        raise InputError(f"unreadable index file ({type(e).__name__})", index_path) from None
    n = len(kept) + len(removed)
    if index.ndim != 1 or not np.issubdtype(index.dtype, np.integer) or index.size != len(removed):
        raise InputError(f"expected the {len(removed)} indices of removed.ply's Gaussians, got dtype {index.dtype}, shape {index.shape}", index_path)
    if index.size and (index.min() < 0 or index.max() >= n or np.unique(index).size != index.size):
        raise InputError(f"indices outside 0..{n - 1} or repeated: not this removal's index", index_path)
    a, b = kept.tensors(), removed.tensors()
    if set(a) != set(b) or any(a[k].shape[1:] != b[k].shape[1:] for k in a):
        raise InputError("point_cloud.ply and removed.ply hold different Gaussian properties: not one removal's output", removed_dir / "removed.ply")
    mask = torch.zeros(n, dtype=torch.bool)
    mask[torch.from_numpy(index.astype(np.int64))] = True
    parts = {}
    for k in a:
        t = torch.empty((n, *a[k].shape[1:]), dtype=a[k].dtype)
        t[~mask], t[mask] = a[k], b[k]
        parts[k] = t
    return Gaussians(**parts), mask


def removal_masks(removed_dir: str | Path, views: list[View], backend: str = "auto") -> dict[str, np.ndarray]:
    """Per view in ``views``: the pixels the removal in ``removed_dir`` leaves to fill (bool) — at
    the training cameras exactly the removal stage's own ``masks/``."""
    removed_dir = Path(removed_dir)
    info = _removal_info(removed_dir)
    config = info.get("config") if isinstance(info.get("config"), dict) else {}
    share = config.get("mask_share", RemovalConfig.mask_share)
    if isinstance(share, bool) or not isinstance(share, (int, float)) or not 0 < share <= 1:
        raise InputError(f"config.mask_share must be a number in (0, 1], got {share!r}", removed_dir / "removal.json")
    model, mask = original_model(removed_dir)
    return fill_masks(model, mask, views, float(share), backend)


def masks_in_test_views(removed_dir: str | Path, scene: Scene, backend: str = "auto") -> dict[str, np.ndarray]:
    """:func:`removal_masks` at ``scene``'s test cameras; the removal must be of ``scene``."""
    removed_dir = Path(removed_dir)
    _removal_info(removed_dir)  # a folder without removal.json is named as such first
    provenance.check_scene(provenance.read(removed_dir / "removal.json", "remove"), scene, "give the removal of this scene", same_resize=False)
    return removal_masks(removed_dir, scene.test_views, backend)


def silhouette_share(removed_dir: str | Path, scene: Scene, backend: str = "auto") -> float | None:
    """The removed silhouette at the test cameras, in percent: mean over ``scene``'s test views of
    the share of pixels the removal's mask rule marks there (None without test views)."""
    masks = masks_in_test_views(removed_dir, scene, backend)
    return amcr([torch.from_numpy(m) for m in masks.values()]) if masks else None


def training_masks(removed_dir: str | Path, scene: Scene) -> dict[str, np.ndarray]:
    """The removal stage's own masks (bool) of ``scene``'s training views; the removal must be of
    ``scene`` at its ``--resize`` and have one mask of the view's size per training view."""
    removed_dir = Path(removed_dir)
    _removal_info(removed_dir)
    provenance.check_scene(provenance.read(removed_dir / "removal.json", "remove"), scene, "give the removal of this scene")
    out = {}
    for v in scene.train_views:
        path = removed_dir / "masks" / f"{v.stem}.png"
        if not path.is_file():
            raise InputError(f"no removal mask for training view {v.name}: not a removal of this scene's training views", path)
        m = read_mask(path) > 0
        if m.shape != (v.camera.height, v.camera.width):
            raise InputError(f"mask is {m.shape[1]}x{m.shape[0]}, training view {v.name} {v.camera.width}x{v.camera.height} (another --resize?)", path)
        out[v.name] = m
    return out


def training_amcr(removed_dir: str | Path, scene: Scene) -> float | None:
    """AMCR (paper supp. Eq. 1) of the removal in ``removed_dir``: over ``scene``'s training views, in
    percent (module docstring); None for a scene without training views."""
    masks = training_masks(removed_dir, scene)
    return amcr([torch.from_numpy(m) for m in masks.values()]) if masks else None


# --- ground truth ------------------------------------------------------------------------------


def true_poses(scene_root: str | Path) -> dict[str, tuple[np.ndarray, np.ndarray]]:
    """Image name -> (R, t) world->camera of the generator's exact pose (``gt/cameras.json``)."""
    path = Path(scene_root) / "gt" / "cameras.json"
    data = read_json_object(path)
    try:
        return {im["name"]: (np.asarray(im["R"], dtype=np.float64).reshape(3, 3), np.asarray(im["t"], dtype=np.float64).reshape(3))
                for im in data["images"]}
    except (KeyError, TypeError, ValueError) as e:
        raise InputError(f"not the generator's camera list (images with name, R, t): {type(e).__name__}", path) from None


def scale_to_truth(scene: Scene, truth: dict[str, tuple[np.ndarray, np.ndarray]]) -> float:
    """Ground-truth units per scene unit: the scale of the least-squares similarity (Umeyama 1991)
    mapping the scene's camera centres onto the true ones (views present in both, by image name)."""
    names = sorted(v.name for v in scene.views if v.name in truth)
    if len(names) < 3:
        raise InputError(f"only {len(names)} of the scene's images are in gt/cameras.json: not the generator's scene", Path(scene.root) / "gt" / "cameras.json")
    est = np.array([scene.view(n).camera.center.detach().cpu().double().numpy() for n in names])
    true = np.array([-truth[n][0].T @ truth[n][1] for n in names])
    a, b = est - est.mean(0), true - true.mean(0)
    var = (a**2).sum() / len(names)
    if var <= 0:
        raise InputError("the scene's cameras all sit at one point: no frame to align", Path(scene.root) / "sparse")
    u, d, vt = np.linalg.svd(b.T @ a / len(names))
    sign = np.ones(3)
    if np.linalg.det(u) * np.linalg.det(vt) < 0:
        sign[-1] = -1.0
    return float((d * sign).sum() / var)


def target_ids(scene_root: str | Path) -> list[int]:
    """The removal targets' object ids (``gt/objects.json``)."""
    path = Path(scene_root) / "gt" / "objects.json"
    check_readable(path, "the generator's object list", missing="no gt/objects.json")
    try:
        objs = json.loads(path.read_text())
        return [int(o["id"]) for o in objs if o["removal_target"]]
    except (ValueError, KeyError, TypeError) as e:
        raise InputError(f"not the generator's object list (id, removal_target per object): {type(e).__name__}", path) from None


def _truth_array(path: Path, shape: tuple[int, int], what: str) -> np.ndarray:
    check_readable(path, what, missing=f"no {what}")
    a = read_mask(path) if path.suffix == ".png" else _load_npy(path)
    if a.shape != shape:
        raise InputError(f"{what} is {a.shape[1]}x{a.shape[0]}, the view {shape[1]}x{shape[0]} (scores need the scene at its generated size, --resize 1)", path)
    return a


def _load_npy(path: Path) -> np.ndarray:
    try:
        return np.load(path).astype(np.float64)
    except (ValueError, OSError) as e:
        raise InputError(f"unreadable depth array ({type(e).__name__})", path) from None


@torch.no_grad()
def removal_scores(removed_dir: str | Path, scene: Scene, backend: str = "auto") -> dict:
    """Every score of the removal in ``removed_dir`` over ``scene``'s training views (module docstring):
    ``scores`` (``amcr``, ``residual``, ``collateral``, ``gt_footprint_share``, ``amcr_ratio``; percent,
    the ratio a multiple), ``null_reasons`` for those that are None, ``limits`` and ``above_limits``
    (:func:`inpaint360gs.metrics.removal.limits_exceeded`), per-view counts, ``definitions`` and the
    frame's scale against the truth (a diagnostic; no score uses it). AMCR needs no ground truth; the others are None with the
    reason without ``gt/``, and residual alone without ``gt/depth_free``."""
    removed_dir = Path(removed_dir)
    root = Path(scene.root)
    masks = training_masks(removed_dir, scene)
    out: dict = {"amcr": amcr([torch.from_numpy(m) for m in masks.values()]) if masks else None}
    reasons: dict[str, str] = {} if masks else {"amcr": "the scene has no training views"}
    per_view: dict[str, dict] = {}
    scale = None
    if not (root / "gt" / "cameras.json").is_file() or not (root / "gt" / "objects.json").is_file():
        for k in ("residual", "collateral", "gt_footprint_share"):
            out[k], reasons[k] = None, NO_TRUTH
    else:
        targets = target_ids(root)
        scale = scale_to_truth(scene, true_poses(root))
        edited = read_ply(removed_dir / "point_cloud.ply")
        original, _ = original_model(removed_dir)
        has_free = (root / "gt" / "depth_free").is_dir()
        total = scores.Counts()
        for v in scene.train_views:
            shape = (v.camera.height, v.camera.width)
            fp = np.isin(_truth_array(root / "gt" / "instance" / f"{v.stem}.png", shape, f"gt/instance of {v.name}"), targets)
            d_with = _truth_array(root / "gt" / "depth" / f"{v.stem}.npy", shape, f"gt/depth of {v.name}")
            d_free = _truth_array(root / "gt" / "depth_free" / f"{v.stem}.npy", shape, f"gt/depth_free of {v.name}") if has_free else np.full(shape, np.inf)
            o_edit = render(edited, v.camera, backend=backend)
            o_orig = render(original, v.camera, backend=backend)
            c = scores.view_counts(fp, d_with, d_free, normalised_depth(o_orig).double().numpy(), normalised_depth(o_edit).double().numpy(), o_edit.alpha.double().numpy(),
                                   o_orig.color.double().numpy(), o_edit.color.double().numpy())
            per_view[v.name] = {k: getattr(c, k) for k in ("footprint", "residual", "outside", "collateral", "pixels")}
            total = total + c
        out.update(total.scores())
        for k in ("residual", "collateral", "gt_footprint_share"):
            if out[k] is None:
                reasons[k] = "the targets cover no pixel of the training views" if k != "collateral" else "no pixel lies outside the grown footprint"
        if not has_free:
            out["residual"], reasons["residual"] = None, NO_FREE_DEPTH
    out["amcr_ratio"] = scores.amcr_ratio(out["amcr"], out.get("gt_footprint_share"))
    if out["amcr_ratio"] is None:
        reasons["amcr_ratio"] = reasons.get("gt_footprint_share") or reasons.get("amcr") or "the ground-truth footprint share is 0"
    return {
        "scores": out,
        "null_reasons": reasons,
        "limits": dict(scores.LIMITS),
        "above_limits": [{"limit": k, "value": v, "max": m} for k, v, m in scores.limits_exceeded(out)],
        "num_views": len(masks),
        "scale_to_truth": scale,
        "per_view": per_view,
        "definitions": dict(DEFINITIONS),
    }


def score_removal_stage(scene_dir: str | Path, removed_dir: str | Path, *, backend: str = "auto") -> dict:
    """:func:`removal_scores` of the removal in ``removed_dir`` on the scene folder ``scene_dir`` (at
    its own size), with the scene and the removal's provenance: what ``inpaint360gs score-removal`` writes."""
    from inpaint360gs.io.scene import load_scene

    scene = load_scene(scene_dir, load_masks=False)
    res = removal_scores(removed_dir, scene, backend)
    rec = provenance.read(Path(removed_dir) / "removal.json", "remove")
    return {"scene": str(scene_dir), "removal": str(removed_dir), **res,
            provenance.KEY: provenance.make("score-removal", scene, {"removal": rec.identity if rec else None}, {"backend": backend})}
