"""Score a folder of rendered test views against a scene's ground truth (paper Sec. 4 "Metrics").

``evaluate_stage(renders_dir, scene_dir)`` reads one PNG per ``test_`` view from ``renders_dir``
(same stem as the test image, e.g. ``test_0003.png``) and the scene through
:func:`inpaint360gs.io.scene.load_scene`; test pixels are read only through
``Scene.load_image(view, allow_test=True)`` and unseen masks through ``Scene.load_mask``.

It returns a JSON-ready dict (no NaN or inf anywhere; ``json.dumps(..., allow_nan=False)`` works):

- ``per_view[view][metric]`` and ``mean[metric]`` for the full-image, ``masked_*`` and ``roi_*``
  conventions (definitions in ``conventions``; see :mod:`.masked`). ``num_views_mean[metric]``
  says over how many views each mean is taken: full-image metrics over all views, ``masked_*``
  over views with an unseen mask file, ``roi_*`` over views whose mask is non-empty. A view left
  out has ``null`` there and a reason in ``null_reasons["per_view"]``;
- a ``+inf`` PSNR (render equal to the ground truth on every evaluated pixel) is stored as
  ``null`` with a reason, and any mean that includes it is ``null`` with a reason as well;
- ``scene_metrics``: ``fid`` (pytorch-fid protocol, only with the Inception weights file),
  ``fd_vgg16`` and ``kid_vgg16`` (substitutes on VGG16 features, always computed), ``unseen_share``
  (the coverage of the ground-truth unseen masks: mean over views with a mask file of the percentage
  of pixels in the mask), ``amcr`` (paper supp. Eq. 1 over the training views, given as
  ``training_amcr``), ``silhouette_test`` (given as ``removal_masks``) and ``roi_depth_off`` (the
  fill's geometry against the true surface, given as ``depth_off``), each null with the reason
  without its input; definitions in ``definitions``;
- ``weights``: path and sha256 of every weights file used.

A scene without ``test_`` views (built from object-inclusive photos only: there is no object-free
ground truth) is not an error: the result has the same keys, ``"ground_truth": false``, every
metric ``null`` and the reason :data:`~inpaint360gs.core.layout.NO_GROUND_TRUTH` (renders are not
read). Inputs that make the evaluation meaningless raise ``InputError`` naming the file: a missing
render, a render that matches no test view, a render of the wrong size.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np
import torch

from inpaint360gs.core.errors import InputError
from inpaint360gs.core import layout
from inpaint360gs.core.layout import IMAGE_SUFFIXES, NO_GROUND_TRUTH
from inpaint360gs.io import provenance
from inpaint360gs.io.images import read_image, to_float
from inpaint360gs.io.scene import Scene, View, load_scene
from inpaint360gs.metrics.distribution import frechet_distance_features, kernel_inception_distance
from inpaint360gs.metrics.image import psnr, ssim_index_map
from inpaint360gs.metrics.inception import inception_features, load_fid_inception
from inpaint360gs.metrics.lpips import MIN_SIDE, Net, get_lpips_net, lpips_weights_info, reduce_maps, upsample_maps
from inpaint360gs.metrics.masked import (
    CONVENTIONS,
    EMPTY_ROI_REASON,
    INFINITE_PSNR_REASON,
    amcr,
    masked_psnr,
    masked_ssim,
    roi_mean,
    roi_psnr,
)
from inpaint360gs.metrics.weights import INCEPTION_ENV, PYTORCH_FID_SHA256_PREFIX, inception_weights_path, sha256_file

LPIPS_METRIC = {"vgg": "lpips", "alex": "lpips_alex"}
NO_MASK_REASON = "no unseen mask file for this view"
DEFINITIONS = {
    "fid": (
        "FID (pytorch-fid protocol): Frechet distance of Inception-v3 pool3 features (2048-d, 299x299 bilinear, "
        "[-1, 1]) of full rendered vs ground-truth test views; tr sqrt(S1 S2) computed exactly as the nuclear norm "
        "of the centred features' cross product"
    ),
    "fd_vgg16": (
        "substitute for FID: Frechet distance of LPIPS-VGG16 relu5_3 features averaged over space (512-d) "
        "of full rendered vs ground-truth test views"
    ),
    "kid_vgg16": "substitute for KID: unbiased MMD^2, kernel (x.y/512 + 1)^3, on the fd_vgg16 features of all views at once",
    "unseen_share": "coverage of the ground-truth unseen masks: mean over views with an unseen mask file of 100 * mask pixels / image pixels",
    "amcr": ("AMCR (paper supp. Eq. 1) on the run's own removal masks: mean over the training views of 100 * pixels the removal "
             "leaves to fill / image pixels"),
    "silhouette_test": ("the removed silhouette at the test cameras: mean over the test views of 100 * pixels the removal's mask rule "
                        "marks there / image pixels (the removed Gaussians give at least mask_share of the pixel's colour)"),
}
DEFINITIONS["roi_depth_off"] = ("percentage of the test views' unseen-mask pixels that the run's model leaves empty or shows more than "
                                 "5% of the true depth off the object-free surface (gt/depth)")
NO_REMOVAL_REASON = "no removal given (inpaint360gs evaluate --removal REMOVED_DIR)"
NO_MODEL_REASON = "no model given (inpaint360gs evaluate --model PLY renders its depth at the test cameras)"
SCENE_KEYS = ("fid", "fd_vgg16", "kid_vgg16", "unseen_share", "amcr", "silhouette_test", "roi_depth_off")
PIXELS_PER_BATCH = 1 << 20  # images per network call: a bound on activation memory (~1M pixels)


def metric_names(nets: Sequence[Net]) -> list[str]:
    """Per-view metric names, full-image then masked then roi, for the LPIPS networks in ``nets``."""
    base = ["psnr", "ssim", *(LPIPS_METRIC[n] for n in ("vgg", "alex") if n in nets)]
    return base + [f"masked_{m}" for m in base] + [f"roi_{m}" for m in base]


def _match_renders(renders_dir: Path, views: list[View]) -> dict[str, Path]:
    """View name -> render file; InputError for a missing, extra, duplicate or non-PNG render."""
    if not renders_dir.is_dir():
        raise InputError("renders folder not found", renders_dir)
    color = renders_dir / layout.RENDER_COLOR_DIR  # given the output folder of `inpaint360gs render`
    if color.is_dir() and not any(p.suffix.lower() == ".png" for p in renders_dir.iterdir()):
        renders_dir = color
    by_stem = {v.stem: v for v in views}
    found: dict[str, Path] = {}
    for p in sorted(renders_dir.iterdir()):
        if not p.is_file() or p.name.startswith(".") or p.suffix.lower() not in IMAGE_SUFFIXES:
            continue
        if p.suffix.lower() != ".png":
            raise InputError("renders must be PNG files", p)
        view = by_stem.get(p.stem)
        if view is None:
            raise InputError(f"render matches no test view of the scene (test views: {', '.join(sorted(by_stem)[:3])}, ...)", p)
        if view.name in found:
            raise InputError(f"two renders for test view {view.name} ({found[view.name].name} and {p.name})", p)
        found[view.name] = p
    for v in views:
        if v.name not in found:
            raise InputError(f"missing render for test view {v.name}", renders_dir / f"{v.stem}.png")
    return found


def _read_render(path: Path, view: View) -> torch.Tensor:
    img = read_image(path)
    cam = view.camera
    if (img.shape[1], img.shape[0]) != (cam.width, cam.height):
        raise InputError(f"render is {img.shape[1]}x{img.shape[0]} but test view {view.name} is {cam.width}x{cam.height}", path)
    return to_float(img)


def _file_info(path: str | Path) -> dict:
    return {"path": str(path), "sha256": sha256_file(path)}  # hashed once per process and file version


_GREY_MODES = ("1", "L", "LA", "I", "I;16", "I;16B", "I;16L", "F")  # PIL modes of single-channel files


def _check_colour(path: Path, gt: torch.Tensor, view: View) -> None:
    """A grayscale render of a colour test view would be scored as grey: refused."""
    from PIL import Image

    with Image.open(path) as im:
        grey_file = im.mode in _GREY_MODES
    if grey_file and not bool((gt == gt[..., :1]).all()):
        raise InputError(f"render is grayscale but test view {view.name} is in colour: renders must be RGB (a grey render would be scored as grey)", path)


def _view_batches(images: list[torch.Tensor]) -> list[list[int]]:
    """Indices of views in network batches: one image size per batch, at most ~PIXELS_PER_BATCH pixels."""
    groups: dict[tuple[int, ...], list[int]] = {}
    for i, img in enumerate(images):
        groups.setdefault(tuple(img.shape), []).append(i)
    out = []
    for shape, idx in groups.items():
        step = max(1, PIXELS_PER_BATCH // (shape[0] * shape[1]))
        out += [idx[i : i + step] for i in range(0, len(idx), step)]
    return out


def _stack(images: list[torch.Tensor], idx: list[int]) -> torch.Tensor:
    """(H, W, 3) images at ``idx`` -> (n, 3, H, W)."""
    return torch.stack([images[i] for i in idx]).permute(0, 3, 1, 2)


def _pooled(feat: torch.Tensor) -> torch.Tensor:
    """Spatial mean of a feature map (n, C, h, w) -> (n, C) float64 on the CPU."""
    return feat.mean(dim=(2, 3)).double().cpu()


class _Table:
    """Per-view values (float, +inf allowed, or None) with a reason for each None."""

    def __init__(self, views: list[str], metrics: list[str]):
        self.views, self.metrics = views, metrics
        self.values = {v: dict.fromkeys(metrics) for v in views}
        self.reasons: dict[str, dict[str, str]] = {}

    def set(self, view: str, metric: str, value: float | None, reason: str | None = None) -> None:
        self.values[view][metric] = value
        if value is None:
            self.reasons.setdefault(view, {})[metric] = reason or "undefined"

    def rows(self) -> tuple[dict, dict]:
        """JSON-ready per-view values (+inf -> None) and the reason for every None."""
        rows, reasons = {}, {}
        for v in self.views:
            rows[v] = {}
            for k, x in self.values[v].items():
                inf = x is not None and math.isinf(x)
                rows[v][k] = None if inf else x
                if rows[v][k] is None:
                    reasons.setdefault(v, {})[k] = INFINITE_PSNR_REASON if inf else self.reasons[v][k]
        return rows, reasons

    def means(self) -> tuple[dict, dict, dict]:
        """Mean over the views where a metric is defined, that count, and reasons for None means.

        A +inf value is not skipped: it makes the mean None (with a reason)."""
        mean, counts, reasons = {}, {}, {}
        for k in self.metrics:
            vals = [(v, self.values[v][k]) for v in self.views if self.values[v][k] is not None]
            counts[k] = len(vals)
            inf_views = [v for v, x in vals if math.isinf(x)]
            mean[k] = None
            if not vals:
                reasons[k] = "defined for no view (see null_reasons.per_view)"
            elif inf_views:
                reasons[k] = f"includes +inf values ({INFINITE_PSNR_REASON}; view {inf_views[0]})"
            else:
                mean[k] = sum(x for _, x in vals) / len(vals)
        return mean, counts, reasons


@torch.inference_mode()
def _lpips_pass(net: Net, renders: torch.Tensor, gts: torch.Tensor, masks: list[torch.Tensor | None], device: str):
    """One batch through one LPIPS network: full-image values (n,), ROI means (None without a mask
    or ROI), masked-image values (n,) (NaN without a mask) and the spatially averaged last tapped
    features (relu5_3 for VGG) of renders and of ground truths, (n, C) each."""
    model = get_lpips_net(net, device)
    r, g = renders.to(device), gts.to(device)
    fa, fb = model.pair_features(r, g)
    maps = model.layer_maps(fa, fb)
    full = reduce_maps(maps).double().cpu()
    spatial = upsample_maps(maps, tuple(r.shape[-2:]))[:, 0].cpu()
    roi = [None if m is None else roi_mean(spatial[i], m) for i, m in enumerate(masks)]
    masked = torch.full((len(masks),), math.nan, dtype=torch.float64)
    idx = [i for i, m in enumerate(masks) if m is not None]
    if idx:
        mk = torch.stack([masks[i] for i in idx]).to(device)[:, None].to(r.dtype)
        masked[idx] = reduce_maps(model(r[idx] * mk, g[idx] * mk)).double().cpu()
    return full, roi, masked, (_pooled(fa[-1]), _pooled(fb[-1]))


def _scene_distances(
    vgg: tuple[torch.Tensor, torch.Tensor], renders: list[torch.Tensor], gts: list[torch.Tensor], inception: Path | None, device: str
) -> tuple[dict, dict]:
    """fid / fd_vgg16 / kid_vgg16 (None with a reason where undefined)."""
    values: dict[str, float | None] = {}
    reasons: dict[str, str] = {}
    sets = {"fd_vgg16": vgg, "kid_vgg16": vgg}
    if inception is None:
        reasons["fid"] = (
            f"no Inception weights: pass inception_weights= or set {INCEPTION_ENV} to pt_inception-2015-12-05-6726825d.pth"
        )
    else:
        model = load_fid_inception(inception, device)
        batches = _view_batches(renders)
        feats = [torch.cat([inception_features(_stack(imgs, idx), model) for idx in batches]) for imgs in (renders, gts)]
        sets["fid"] = (feats[0], feats[1])
    n = len(renders)
    for name in ("fid", "fd_vgg16", "kid_vgg16"):
        if name not in sets:
            values[name] = None
        elif n < 2:
            values[name], reasons[name] = None, f"needs at least 2 test views, got {n}"
        else:
            fn = kernel_inception_distance if name.startswith("kid") else frechet_distance_features
            values[name] = fn(*sets[name])
    return values, reasons


def _pixel_metrics(table: _Table, renders: list[torch.Tensor], gts: list[torch.Tensor], masks: list[torch.Tensor | None]) -> None:
    """PSNR and SSIM in all three conventions, float64, one view at a time (cheap next to LPIPS)."""
    for name, r, g, m in zip(table.views, renders, gts, masks):
        smap = ssim_index_map(r, g)
        table.set(name, "psnr", psnr(r, g))
        table.set(name, "ssim", float(smap.mean()))
        if m is None or not bool(m.any()):  # no mask, or no unseen pixel in this view: nothing to score in either mask convention
            for k in ("masked_psnr", "masked_ssim", "roi_psnr", "roi_ssim"):
                table.set(name, k, None, NO_MASK_REASON if m is None else EMPTY_ROI_REASON)
            continue
        table.set(name, "masked_psnr", masked_psnr(r, g, m))
        table.set(name, "masked_ssim", masked_ssim(r, g, m))
        table.set(name, "roi_psnr", roi_psnr(r, g, m), EMPTY_ROI_REASON)
        table.set(name, "roi_ssim", roi_mean(smap, m), EMPTY_ROI_REASON)


def _lpips_metrics(
    table: _Table, renders: list[torch.Tensor], gts: list[torch.Tensor], masks: list[torch.Tensor | None], nets: tuple, device: str
) -> tuple[torch.Tensor, torch.Tensor]:
    """LPIPS in all three conventions for each net, in batches of views of one size; returns the
    VGG16 relu5_3 features (spatial means) of renders and of ground truths for fd/kid."""
    vgg_r, vgg_g = [], []
    for idx in _view_batches(renders):
        rb, gb, mb = _stack(renders, idx), _stack(gts, idx), [masks[i] for i in idx]
        for net in nets:
            full, roi, masked, (fr, fg) = _lpips_pass(net, rb, gb, mb, device)
            key = LPIPS_METRIC[net]
            for j, i in enumerate(idx):
                name = table.views[i]
                reason = NO_MASK_REASON if mb[j] is None else EMPTY_ROI_REASON
                table.set(name, key, float(full[j]))
                empty = mb[j] is None or not bool(mb[j].any())
                table.set(name, f"masked_{key}", None if empty else float(masked[j]), reason)
                table.set(name, f"roi_{key}", roi[j], reason)
            if net == "vgg":
                vgg_r.append(fr)
                vgg_g.append(fg)
        if "vgg" not in nets:  # fd/kid still need VGG16 features
            with torch.inference_mode():
                fa, fb = get_lpips_net("vgg", device).pair_features(rb.to(device), gb.to(device))
            vgg_r.append(_pooled(fa[-1]))
            vgg_g.append(_pooled(fb[-1]))
    # rows of both sets follow the same batch order; fd/kid do not depend on the order of views
    return torch.cat(vgg_r), torch.cat(vgg_g)


def _silhouette_share(removal_masks: Mapping[str, np.ndarray] | None, views: list[View]) -> float | None:
    """Mean coverage (percent) of the removal's masks at the test ``views`` (each view needs one of its size)."""
    if removal_masks is None:
        return None
    ordered = []
    for v in views:
        m = removal_masks.get(v.name)
        if m is None:
            raise InputError(f"no removal mask for test view {v.name}", "removal_masks")
        if tuple(np.shape(m)) != (v.camera.height, v.camera.width):
            raise InputError(f"removal mask of {v.name} is {np.shape(m)}, the view {v.camera.height}x{v.camera.width}", "removal_masks")
        ordered.append(torch.from_numpy(np.asarray(m, dtype=bool)))
    return amcr(ordered)


def _weights_info(nets: tuple, inception: Path | None) -> dict:
    weights: dict = {f"lpips_{n}": _file_info(lpips_weights_info(n)) for n in dict.fromkeys((*nets, "vgg"))}
    weights["inception"] = None
    if inception is not None:
        info = _file_info(inception)
        info["matches_pytorch_fid"] = info["sha256"].startswith(PYTORCH_FID_SHA256_PREFIX)
        weights["inception"] = info
    return weights


def _no_ground_truth(scene: Scene, renders_dir: Path, nets: tuple) -> dict:
    """The result for a scene without test_ views: every metric null with the reason."""
    names = metric_names(nets)
    scene_keys = SCENE_KEYS
    return {
        "scene": str(scene.root),
        "renders_dir": str(renders_dir),
        "ground_truth": False,
        "reason": NO_GROUND_TRUTH,
        "num_views": 0,
        "views": [],
        "conventions": dict(CONVENTIONS),
        "definitions": dict(DEFINITIONS),
        "mean": dict.fromkeys(names),
        "num_views_mean": dict.fromkeys((*names, "unseen_share", "amcr", "silhouette_test", "roi_depth_off"), 0),
        "per_view": {},
        "scene_metrics": dict.fromkeys(scene_keys),
        "null_reasons": {"per_view": {}, "mean": dict.fromkeys(names, NO_GROUND_TRUTH),
                         "scene_metrics": dict.fromkeys(scene_keys, NO_GROUND_TRUTH)},
        "weights": {},
    }


def _record(scene: Scene, made: provenance.Record | None, nets: tuple, inception: Path | None) -> dict:
    """The evaluation's provenance: the scene, the renders' stage output and the model they show."""
    inputs = {"renders": made.identity if made else None, "model": made.model if made else None}
    return provenance.make("evaluate", scene, inputs, {"nets": list(nets), "inception": None if inception is None else sha256_file(inception)})


def evaluate_stage(
    renders_dir: str | Path,
    scene_dir: str | Path,
    *,
    nets: Sequence[Net] = ("vgg", "alex"),
    inception_weights: str | Path | None = None,
    device: str = "cpu",
    resize: int = 1,
    removal_masks: Mapping[str, np.ndarray] | None = None,
    training_amcr: float | None = None,
    depth_off: tuple[float | None, str | None] | None = None,
) -> dict:
    """Metrics of the renders in ``renders_dir`` against the test views of ``scene_dir``.

    ``nets`` selects the LPIPS networks (``lpips`` = VGG, ``lpips_alex``); ``fd_vgg16``/``kid_vgg16``
    always use VGG16. ``fid`` needs ``inception_weights`` (or ``INPAINT360GS_INCEPTION_WEIGHTS``).
    ``resize``: the scene's image downscale factor; the renders must have the test views' size at it
    (renders made with ``render --resize R`` are scored with ``resize=R``). Renders whose folder
    records their provenance (``render``'s ``render.json``, an inpainting's ``inpaint.json``) must be
    of this scene at this ``resize`` (docs/architecture.md, "Provenance chain"). A test view without
    an unseen mask file, while others have one, is warned about (its masked and ROI values are null).
    ``removal_masks``: per test view name, the pixels the run's removal marks there (bool, the
    view's size), for ``silhouette_test``; ``training_amcr``: ``amcr`` of the run's removal over the
    training views (:func:`inpaint360gs.evaluate.removal.training_amcr`); ``depth_off``: (value, reason when null) of ``roi_depth_off``,
    computed from the run's model. See the module docstring for the output layout and the handling of nulls.
    """
    nets = tuple(dict.fromkeys(nets))
    unknown = [n for n in nets if n not in LPIPS_METRIC]
    if unknown:
        raise InputError(f"unknown LPIPS network {unknown[0]!r} (expected 'vgg' and/or 'alex')", "nets")
    renders_dir, scene_dir = Path(renders_dir), Path(scene_dir)
    scene: Scene = load_scene(scene_dir, resize=resize, load_masks=["unseen_mask"])
    made = provenance.of_renders(renders_dir)
    provenance.check_scene(made, scene, "evaluate the renders of this scene")
    views = scene.test_views
    if not views:
        return {**_no_ground_truth(scene, renders_dir, nets), "resize": resize, provenance.KEY: _record(scene, made, nets, None)}
    for net in dict.fromkeys((*nets, "vgg")):  # VGG16 features for fd/kid in any case
        small = next((v for v in views if min(v.camera.width, v.camera.height) < MIN_SIDE[net]), None)
        if small is not None:
            hint = " or leave out --nets alex" if net == "alex" else ""
            raise InputError(f"test view {small.name} is {small.camera.width}x{small.camera.height}; LPIPS-{net} needs at least {MIN_SIDE[net]} pixels a side "
                             f"(use a lower --resize{hint})", scene_dir / "images")  # fmt: skip
    paths = _match_renders(renders_dir, views)
    inception = inception_weights_path(inception_weights)  # fails early on a missing file
    names = [v.name for v in views]
    renders, gts, masks = [], [], []
    for v in views:
        renders.append(_read_render(paths[v.name], v))
        gts.append(scene.load_image(v, allow_test=True))
        _check_colour(paths[v.name], gts[-1], v)
        masks.append(torch.from_numpy(scene.load_mask(v, "unseen_mask")) if scene.has_mask(v, "unseen_mask") else None)
    lacking = [v for v, m in zip(views, masks) if m is None]
    if lacking:
        n = len(views) - len(lacking)
        warnings.warn(f"{scene_dir / layout.UNSEEN_MASK_DIR}: no unseen mask for {len(lacking)} of {len(views)} test view(s) (first: {lacking[0].name}); "
                      f"masked_* and roi_* means are over the {n} view(s) with one" if n else
                      f"{scene_dir / layout.UNSEEN_MASK_DIR}: no unseen masks: masked_* and roi_* metrics and the unseen share are null", stacklevel=2)

    table = _Table(names, metric_names(nets))
    _pixel_metrics(table, renders, gts, masks)
    vgg_features = _lpips_metrics(table, renders, gts, masks, nets, device)
    per_view, per_view_reasons = table.rows()
    mean, counts, mean_reasons = table.means()
    scene_values, scene_reasons = _scene_distances(vgg_features, renders, gts, inception, device)
    with_mask = [m for m in masks if m is not None]
    scene_values["unseen_share"] = amcr(with_mask) if with_mask else None
    counts["unseen_share"] = len(with_mask)
    if not with_mask:
        scene_reasons["unseen_share"] = "no test view has an unseen mask file"
    scene_values["silhouette_test"] = _silhouette_share(removal_masks, views)
    counts["silhouette_test"] = len(views) if removal_masks is not None else 0
    if removal_masks is None:
        scene_reasons["silhouette_test"] = NO_REMOVAL_REASON
    scene_values["amcr"], counts["amcr"] = training_amcr, len(scene.train_views) if training_amcr is not None else 0
    if training_amcr is None:
        scene_reasons["amcr"] = NO_REMOVAL_REASON
    scene_values["roi_depth_off"], why = depth_off if depth_off is not None else (None, NO_MODEL_REASON)
    counts["roi_depth_off"] = len(with_mask) if scene_values["roi_depth_off"] is not None else 0
    if scene_values["roi_depth_off"] is None:
        scene_reasons["roi_depth_off"] = why or "undefined"

    return {
        "scene": str(scene_dir),
        "renders_dir": str(renders_dir),
        "resize": resize,
        provenance.KEY: _record(scene, made, nets, inception),
        "ground_truth": True,
        "num_views": len(names),
        "views": names,
        "conventions": dict(CONVENTIONS),
        "definitions": dict(DEFINITIONS),
        "mean": mean,
        "num_views_mean": counts,
        "per_view": per_view,
        "scene_metrics": scene_values,
        "null_reasons": {"per_view": per_view_reasons, "mean": mean_reasons, "scene_metrics": scene_reasons},
        "weights": _weights_info(nets, inception),
    }
