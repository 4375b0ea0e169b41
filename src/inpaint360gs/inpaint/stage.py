"""The inpainting stage: from the scene after removal to the inpainted scene (paper Sec. 3.4–3.5,
Alg. 1 second half).

1. Virtual cameras around the removed objects (:mod:`inpaint360gs.views.virtual`), or the training
   cameras (ablation c, "w/o virtual camera pose").
2. Occluders of the removed objects in those views, found by object id, taken out for inpainting.
3. Geometric unseen masks per view (:mod:`inpaint360gs.views.unseen`).
4. Recursive conditional RGB-D 2D inpainting along the views (:mod:`.conditioned`; ablation d off).
5. Depth-guided initialisation of new Gaussians (:mod:`.init`; ablation b: naive).
6. 3D inpainting with hybrid supervision (:mod:`.refine`; ablation e: mask-only), then the
   occluders are put back.
7. What people look at: renders at the ``test_`` cameras (cameras only; their pixels are never
   read), a before/after grid, a GIF along the virtual trajectory. A scene without ``test_`` views
   (photos with the object only, no ground truth) gets an empty ``renders/test/`` and a grid over
   views spread along the inpainting cameras (virtual or training) instead.
"""

from __future__ import annotations

import json
import time
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np
import torch

from inpaint360gs.core.errors import InputError
from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.core.progress import stage_bar
from inpaint360gs.core.support import STANDING
from inpaint360gs.distill.field import IdentityField
from inpaint360gs.inpaint.conditioned import inpaint_views, reprojection_error
from inpaint360gs.inpaint.init import depth_guided_init, naive_init
from inpaint360gs.inpaint.inpainters import make_inpainter
from inpaint360gs.inpaint.config import InpaintConfig, check_inpaint_config  # InpaintConfig: defined with the other settings, importable here
from inpaint360gs.inpaint.refine import refine
from inpaint360gs.io import provenance
from inpaint360gs.io.arguments import check_stage_call
from inpaint360gs.io.atomic import atomic_dir
from inpaint360gs.io.images import write_image, write_mask
from inpaint360gs.io.ply import write_ply
from inpaint360gs.io.scene import Scene
from inpaint360gs.render.api import render
from inpaint360gs.views.unseen import TrainingVisibility, clean_mask, footprint, occluders, unseen_mask
from inpaint360gs.views.virtual import cameras_to_json, choose_trajectory, plane_depth, support_camera


def _nothing_to_fill(model: Gaussians, removed: torch.Tensor, cameras: list, cfg: InpaintConfig, kind: str, removal) -> InputError:
    """Why the region to fill is empty in every view: the removed Gaussians cover no pixel of any of
    ``cameras`` (off-screen, hidden or transparent), or the surface they hid was seen in training."""
    if any(footprint(model, removed, c, cfg.unseen.footprint_share, cfg.backend).any() for c in cameras):
        return InputError(f"the unseen masks are empty in every {kind} view: the training views saw all the surface the removal reveals (nothing to inpaint)", removal)
    return InputError(f"the removed Gaussians cover no pixel of any {kind} view (off-screen, hidden or transparent): nothing to inpaint", removal)


def _per_gaussian_ids(field_: IdentityField) -> np.ndarray:
    probs = field_.gaussian_probs()
    return np.asarray(field_.object_ids)[probs.argmax(dim=1).numpy()]


def _support_views(footprints: list, like, edited: Gaussians, backend: str, min_agree: float = 0.5, tolerance: float = 0.25) -> list:
    """A camera straight above each footprint whose support it sees: where the edited scene renders
    a surface around the footprint, at least ``min_agree`` of it must lie within ``tolerance`` x the
    object's height (or 2 % of the depth, if more) of the support plane; a view whose support is
    hidden (the object stood under a table top) is left out. The tolerance is in object heights: a
    3DGS floor trained from low photos renders a few per cent of the depth off its plane from above,
    while what hides a support stands about an object's height over it."""
    out = []
    for i, fp in enumerate(footprints):
        cam = support_camera(fp, like, name=f"support_{i:02d}")
        z = plane_depth(cam, fp.normal, fp.offset)
        with torch.no_grad():
            o = render(edited, cam, backend=backend)
        a = o.alpha.numpy()
        d = (o.depth / o.alpha.clamp_min(1e-6)).numpy()
        ring = (a >= 0.5) & np.isfinite(z)
        if ring.any() and float(np.mean(np.abs(d[ring] - z[ring]) <= np.maximum(tolerance * fp.height, 0.02 * z[ring]))) >= min_agree:
            out.append(cam)
    return out


def in_columns(points: np.ndarray, footprints: list, margin: float, low: float = -1.0, high: float = 2.0) -> np.ndarray:
    """Which ``points`` (N, 3) lie in any footprint's column grown by ``margin`` x its size, between
    ``low`` and ``high`` x the object's height above the support (default: from one height below
    to twice above)."""
    out = np.zeros(len(points), dtype=bool)
    for fp in footprints:
        h = fp.heights(points)
        out |= (fp.distance(points) <= margin * fp.size) & (h > low * fp.height) & (h < high * fp.height)
    return out


def fill_rows(points: np.ndarray, footprints: list, cfg: "InpaintConfig") -> np.ndarray:
    """Which new Gaussians (centres ``points``) the fill keeps: those in the footprints' columns
    grown by ``reveal_margin``, except those standing (higher than STANDING x the object's height
    over the support) in the columns grown by ``footprint_margin``. After the removal that space
    is empty air over the support; a fill point there comes from a depth the 2D inpainter made up
    (a plane through a ring of support and backdrop) and shows as haze from other views."""
    return in_columns(points, footprints, cfg.reveal_margin) & ~in_columns(points, footprints, cfg.footprint_margin, STANDING, 2.0)


def support_depth(camera, footprints: list, margin: float) -> np.ndarray:
    """(H, W) camera z of the support plane where a pixel's ray meets it inside a footprint grown by
    ``margin`` x its size (looking down into the space the removal emptied; the nearest such plane),
    inf elsewhere."""
    from inpaint360gs.views.unseen import backproject

    out = np.full((camera.height, camera.width), np.inf)
    for fp in footprints:
        z = plane_depth(camera, fp.normal, fp.offset)
        rows, cols = np.nonzero(np.isfinite(z))
        if len(rows):
            inside = fp.distance(backproject(camera, z[rows, cols], rows, cols)) <= margin * fp.size
            r, c = rows[inside], cols[inside]
            out[r, c] = np.minimum(out[r, c], z[r, c])
    return out


def footprint_rows(model: Gaussians, footprints: list, margin: float) -> torch.Tensor:
    """Gaussians of ``model`` on the support around the hole: in the footprints' columns grown by
    ``margin`` x their size, within STANDING x the object's height of the support plane. They are
    what the 3D inpainting may adjust besides the new Gaussians (the seams of paper Sec. 3.5). The
    rest of the scene, which the photos explain, stays as it was. That includes what stands near
    the hole, such as another object or a backdrop: adjusted to the fill's targets, it hazes."""
    return torch.from_numpy(in_columns(model.means.detach().cpu().double().numpy(), footprints, margin, -STANDING, STANDING))


@dataclass
class RevealedGeometry:
    """Where a view looks into what the removal emptied (:func:`revealed_geometry`)."""

    support: np.ndarray  # (H, W) depth of the support plane where the removal emptied it, inf elsewhere
    surface: np.ndarray  # (H, W) depth of the surface the edited scene shows, nan where it shows none
    near: np.ndarray  # (H, W) bool: that surface lies in the footprints' columns grown by the reveal margin


@torch.no_grad()
def revealed_geometry(camera, edited: Gaussians, footprints: list, cfg: "InpaintConfig") -> RevealedGeometry:
    """The support's depth where ``camera``'s ray meets it inside a footprint grown by
    ``footprint_margin`` and no surface of the edited scene stands in front of it (an object behind
    the removed one, a backdrop), and the edited scene's own surface with whether it lies near the
    removed object (inside the columns grown by ``reveal_margin``). Something stands in front where
    Gaussians nearer than the support give at least ``unseen.min_alpha`` of the pixel's colour
    (:func:`~inpaint360gs.views.unseen.share_in_front`): a faint haze left over the hole does not
    hide the support, although its alpha-normalised depth lies in front of it."""
    from inpaint360gs.views.unseen import backproject, normalised_depth, share_in_front

    z = support_depth(camera, footprints, cfg.footprint_margin)
    o = render(edited, camera, backend=cfg.backend)
    alpha = o.alpha.numpy()
    d = normalised_depth(o).numpy().astype(np.float64)
    surface = np.where(alpha >= cfg.unseen.min_alpha, d, np.nan)
    has = np.isfinite(surface)
    if np.isfinite(z).any():
        planes = [(fp.normal, fp.offset) for fp in footprints]
        z = np.where(share_in_front(edited, camera, planes, backend=cfg.backend) >= cfg.unseen.min_alpha, np.inf, z)
    near = np.zeros(alpha.shape, dtype=bool)
    rows, cols = np.nonzero(has)
    if len(rows):
        near[rows, cols] = in_columns(backproject(camera, surface[rows, cols], rows, cols), footprints, cfg.reveal_margin)
    return RevealedGeometry(z, surface, near)


def _surface_fill(g: RevealedGeometry, fallback):
    """A depth inpainter for a view into what the removal emptied: the support plane's depth where it
    was emptied, the revealed surface's own depth where the edited scene shows one, ``fallback``
    (a plane through the ring) where neither."""

    def fill(depth, mask):
        out = depth.copy()
        plane = mask & np.isfinite(g.support)
        out[plane] = g.support[plane]
        own = mask & ~plane & np.isfinite(g.surface)
        out[own] = g.surface[own]
        rest = mask & ~plane & ~own
        return fallback(out, rest) if rest.any() else out

    return fill


def inpaint_scene(
    field_: IdentityField,
    removed_mask: torch.Tensor,
    removed_ids: list[int],
    scene: Scene,
    cfg: InpaintConfig | None = None,
    *,
    progress: bool = False,
    removal: str | Path | None = None,
    footprints: list | None = None,
) -> tuple[Gaussians, dict, list]:
    """Run steps 1–6 (see the module docstring); returns (final model, record, inpainted views).
    ``removal`` (the removal stage's folder) is what errors about the selection name; ``footprints``
    (:class:`inpaint360gs.core.support.Footprint`, from the removal) place the support views."""
    cfg = cfg or InpaintConfig()
    check_inpaint_config(cfg)
    t = {}
    t0 = time.perf_counter()
    original = field_.gaussians.map(lambda x: x.detach())
    if not bool(removed_mask.any()):
        raise InputError("nothing was removed: no Gaussian is marked in the removal", removal)
    # the 2D inpainters load their checkpoints now, so that a bad one fails before any work
    opts = {"seed": cfg.refine.seed, **({"lama_onnx": cfg.lama_onnx} if cfg.lama_onnx else {})}
    rgb, dep = make_inpainter(cfg.rgb_inpainter, **opts), make_inpainter(cfg.depth_inpainter, **opts)
    train_cams = [v.camera for v in scene.train_views]
    visibility = TrainingVisibility(original, train_cams, backend=cfg.backend, removed=removed_mask, object_share=cfg.unseen.seen_object_share)
    edited = original.subset(~removed_mask)
    t["visibility_s"] = time.perf_counter() - t0

    # 1. cameras
    t0 = time.perf_counter()
    centre = original.means[removed_mask].detach().double().median(dim=0).values.numpy()

    tried: list[tuple[list, list]] = []  # (candidate cameras, their fill shares)

    def fill_mask(model, removed, edited_model, c):
        """The view's unseen mask; with footprints, only where the removal emptied the support or
        revealed a surface near the object (the 3DGS's uncertain depth far away is no part of it)."""
        m = unseen_mask(model, removed, edited_model, c, visibility, cfg.unseen, cfg.backend)[0]
        if not footprints:
            return m
        g = revealed_geometry(c, edited_model, footprints, cfg)
        return m & (np.isfinite(g.support) | g.near)

    def shares(cams):
        s = [fill_mask(original, removed_mask, edited, c).mean() for c in cams]
        tried.append((cams, s))
        return s

    if cfg.views == "virtual":
        try:
            cameras, trajectory = choose_trajectory(train_cams, centre, shares, cfg.virtual)
        except InputError:
            if not tried or any(max(s) > 0 for _, s in tried):
                raise
            raise _nothing_to_fill(original, removed_mask, [c for cams, _ in tried for c in cams], cfg, "virtual", removal) from None
    else:
        cameras, trajectory = train_cams, {"training_views": [v.name for v in scene.train_views]}
    supports = _support_views(footprints, train_cams[0], edited, cfg.backend) if (cfg.support_view and footprints and cfg.views == "virtual") else []
    cameras = supports + list(cameras)
    trajectory["support_views"] = len(supports)
    t["cameras_s"] = time.perf_counter() - t0

    # 2. occluders out
    t0 = time.perf_counter()
    ids = _per_gaussian_ids(field_)
    occ = occluders(original, removed_mask, ids, cameras, set(removed_ids) | {0}, cfg.occluder_min_pixels, backend=cfg.backend) if cfg.occluders else {}
    occ_mask = torch.from_numpy(np.isin(ids, list(occ))) & ~removed_mask
    base = original.subset(~occ_mask)  # the original without occluders
    base_removed = removed_mask[~occ_mask]
    edited = base.subset(~base_removed)
    t["occluders_s"] = time.perf_counter() - t0

    # 3. masks of the region to fill
    t0 = time.perf_counter()
    if cfg.masks == "unseen":
        masks = [fill_mask(base, base_removed, edited, c) for c in cameras]
    else:  # "footprint": the whole rendered footprint, dilated (what per-view 2D pipelines inpaint)
        masks = [clean_mask(footprint(base, base_removed, c, cfg.unseen.footprint_share, cfg.backend), cfg.unseen.min_component, cfg.unseen.dilate) for c in cameras]
    if not any(m.any() for m in masks):
        raise _nothing_to_fill(base, base_removed, cameras, cfg, cfg.views, removal)
    t["unseen_masks_s"] = time.perf_counter() - t0

    # 4. 2D inpainting
    t0 = time.perf_counter()
    fills, planes = {}, {}
    if footprints:  # what the removal emptied is filled on its support: the plane's depth where a ray meets it there
        sup = make_inpainter(cfg.support_inpainter, **opts) if supports else None
        for i, c in enumerate(cameras):
            geo = revealed_geometry(c, edited, footprints, cfg)
            planes[i] = geo.support
            fills[i] = (sup.rgb if i < len(supports) else None, _surface_fill(geo, dep.depth))
    views = inpaint_views(edited, cameras, masks, rgb.rgb, dep.depth, condition=cfg.condition, backend=cfg.backend, fills=fills, planes=planes)
    consistency = reprojection_error(views)
    t["inpaint_2d_s"] = time.perf_counter() - t0

    # 5. initialisation
    t0 = time.perf_counter()
    if cfg.init == "depth":
        new = depth_guided_init(views, sh_degree=edited.sh_degree)
        if footprints:  # the fill lies where the removal emptied or revealed something
            new = new.subset(torch.from_numpy(fill_rows(new.means.detach().double().numpy(), footprints, cfg)))
    elif cfg.init == "naive":
        box = original.means[removed_mask].detach().numpy()
        new = naive_init(views, box.min(0), box.max(0), max(1, len(depth_guided_init(views, sh_degree=0))), seed=cfg.refine.seed, sh_degree=edited.sh_degree)
    else:  # "none"
        new = edited.subset(torch.zeros(len(edited), dtype=torch.bool))
    t["init_s"] = time.perf_counter() - t0

    # 6. 3D inpainting, occluders back
    t0 = time.perf_counter()
    bar = stage_bar(cfg.refine.resolved().iterations, "3D inpainting", progress, dynamic_ncols=True)
    removed_points = original.means[removed_mask].detach().double().numpy()
    active = footprint_rows(edited, footprints, cfg.footprint_margin) if footprints else None
    refined, log = refine(edited, new, views, cfg.refine, region=removed_points, extent=scene.extent, progress=bar.update, active=active)
    bar.close()
    occ_g = original.subset(occ_mask)
    final = Gaussians(**{k: torch.cat([getattr(refined, k), getattr(occ_g, k).detach()], 0) for k in ("means", "log_scales", "quats", "opacity_logits", "sh0", "shN")})
    t["refine_3d_s"] = time.perf_counter() - t0

    record = {
        "config": asdict(cfg),
        "views": cfg.views,
        "num_views": len(cameras),
        "trajectory": trajectory,
        "occluders": {str(k): v for k, v in occ.items()},
        "occluder_gaussians": int(occ_mask.sum()),
        "fill_share_per_view": [float(m.mean()) for m in masks],
        "filled_from_earlier_views": float(sum(v.from_condition.sum() for v in views) / max(sum(v.mask.sum() for v in views), 1)),
        "reprojection_error": consistency,
        "new_gaussians": len(new),
        "final_gaussians": len(final),
        "refine_log": log,
        "seconds": {k: round(v, 2) for k, v in t.items()},
    }
    return final, record, views


GRID_COLUMNS = 4  # views in grid.png


def _spread(n: int, k: int) -> list[int]:
    """``min(n, k)`` indices spread evenly over ``range(n)``, first and last included."""
    if n <= k:
        return list(range(n))
    return [round(i * (n - 1) / (k - 1)) for i in range(k)]


@torch.no_grad()
def _grid(before: list[np.ndarray], after: list[np.ndarray]) -> np.ndarray:
    """Rows: before (top) and after (bottom); columns: views."""
    return np.concatenate([np.concatenate(before, axis=1), np.concatenate(after, axis=1)], axis=0)


@torch.no_grad()
def write_inpainting(
    final: Gaussians,
    original: Gaussians,
    record: dict,
    views: list,
    scene: Scene,
    out: str | Path,
    *,
    backend: str = "auto",
    overwrite: bool = False,
) -> None:
    """``out``: point_cloud.ply, virtual_cameras.json, views/ (2D inpainting results), renders/test/
    (the final scene at the test_ cameras; empty when the scene has none), grid.png (before/after at
    the first test_ cameras, or without test_ views at cameras spread along ``views``),
    trajectory.gif, inpaint.json (``grid`` names the grid's cameras)."""
    from PIL import Image

    out = Path(out)
    test_views = scene.test_views
    with atomic_dir(out, overwrite=overwrite) as tmp:
        write_ply(tmp / "point_cloud.ply", final)
        (tmp / "virtual_cameras.json").write_text(json.dumps({"cameras": cameras_to_json([v.camera for v in views])}, indent=1) + "\n")
        frames = []
        for v in views:
            write_image(tmp / "views" / f"{v.camera.name}.png", v.color)
            write_mask(tmp / "views" / f"{v.camera.name}_mask.png", v.mask)
            frames.append(render(final, v.camera, backend=backend).color.clamp(0, 1).numpy())
        if frames:
            imgs = [Image.fromarray((f * 255 + 0.5).astype(np.uint8)) for f in frames]
            imgs[0].save(tmp / "trajectory.gif", save_all=True, append_images=imgs[1:], duration=80, loop=0)
        before, after = [], []
        renders = tmp / "renders" / "test"
        renders.mkdir(parents=True)  # stays empty without test_ views (no ground truth)
        for v in test_views:
            a = render(final, v.camera, backend=backend).color.clamp(0, 1)
            write_image(renders / f"{v.stem}.png", a)
            if len(before) < GRID_COLUMNS:
                before.append(render(original, v.camera, backend=backend).color.clamp(0, 1).numpy())
                after.append(a.numpy())
        grid = {"cameras": "test", "views": [v.name for v in test_views[:GRID_COLUMNS]]}
        if not test_views:  # no ground truth: the cameras the inpainting used (virtual or training)
            picked = _spread(len(views), GRID_COLUMNS)
            for i in picked:
                before.append(render(original, views[i].camera, backend=backend).color.clamp(0, 1).numpy())
                after.append(frames[i])
            grid = {"cameras": record.get("views", "inpainting"), "views": [views[i].camera.name for i in picked]}
        record["grid"] = grid
        if before:
            write_image(tmp / "grid.png", _grid(before, after))
        provenance.add_outputs(record, tmp, "point_cloud.ply")
        (tmp / "inpaint.json").write_text(json.dumps(record, indent=1, default=float) + "\n")


def read_removal(removed_dir: str | Path, n: int) -> tuple[torch.Tensor, list[int]]:
    """The removal stage's (removed mask over the distilled model's ``n`` Gaussians, object ids)."""
    removed_dir = Path(removed_dir)
    info_path, index_path = removed_dir / "removal.json", removed_dir / "removed_index.npy"
    for p in (info_path, index_path):
        if not p.is_file():
            raise InputError("not a removal stage output (missing file)", p)
    try:
        info = json.loads(info_path.read_text())
        index = np.load(index_path)
    except (ValueError, OSError) as e:
        raise InputError(f"unreadable removal output ({type(e).__name__})", removed_dir) from None
    if index.ndim != 1 or not np.issubdtype(index.dtype, np.integer):
        raise InputError(f"not a list of Gaussian indices ({index.dtype}, shape {index.shape})", index_path)
    if not index.size:
        raise InputError("the removal selected no Gaussian: nothing to inpaint", index_path)
    if index.min() < 0 or index.max() >= n:
        raise InputError(f"removed indices do not fit a model of {n} Gaussians: removal made from another model?", index_path)
    mask = torch.zeros(n, dtype=torch.bool)
    mask[torch.from_numpy(index.astype(np.int64))] = True
    return mask, [int(i) for i in info.get("objects", [])]


def read_footprints(removed_dir: str | Path) -> list:
    """The footprints the removal recorded (``removal.json``: ``footprints``; none from an older removal)."""
    from inpaint360gs.core.support import Footprint

    try:
        info = json.loads((Path(removed_dir) / "removal.json").read_text())
        return [Footprint.from_json(d) for d in info.get("footprints", [])]
    except (OSError, ValueError, KeyError, TypeError) as e:
        raise InputError(f"unreadable footprints in the removal record ({type(e).__name__})", Path(removed_dir) / "removal.json") from None


def inpaint_stage(scene: Scene, field_: IdentityField, removed_dir: str | Path, out: str | Path, cfg: InpaintConfig | None = None, *, overwrite: bool = False, progress: bool = False) -> dict:
    """The stage as ``inpaint360gs inpaint`` runs it: read the removal, inpaint, write ``out``.

    Args: ``field_`` the distillation output the removal was made from; ``removed_dir`` the removal
    stage's folder; ``cfg`` None = defaults; ``overwrite`` replace a non-empty ``out``.
    Returns: what ``inpaint.json`` holds.
    Raises: :class:`InputError` for a non-empty ``out``, a removal or distillation of another scene
    (or not linked), or nothing to fill."""
    check_stage_call("inpaint_stage", scene, out, cfg, InpaintConfig, overwrite=overwrite, progress=progress, folders={"removed_dir": removed_dir})
    if not isinstance(field_, IdentityField):
        raise InputError(f"expected an IdentityField (the distillation output), got {type(field_).__name__}", setting="inpaint_stage.field_")
    cfg = cfg or InpaintConfig()
    check_inpaint_config(cfg)
    t0 = time.perf_counter()
    out = Path(out)
    if out.is_dir() and any(out.iterdir()) and not overwrite:  # before any work (atomic_dir checks again at the end)
        raise InputError("output folder exists and is not empty (pass --overwrite to replace it)", out)
    removal, made = provenance.of_stage(removed_dir, "remove"), field_.record  # docs/architecture.md, "Provenance chain"
    provenance.check_scene(made, scene, "distill this scene first")
    provenance.check_scene(removal, scene, "remove from this scene's distillation first")
    provenance.check_link(removal, "distill", made and made.identity, made and made.path.parent, "give the distillation the removal was made from")
    mask, ids = read_removal(removed_dir, len(field_.gaussians))
    final, record, views = inpaint_scene(field_, mask, ids, scene, cfg, progress=progress, removal=removed_dir, footprints=read_footprints(removed_dir))
    record["seconds"]["total_s"] = round(time.perf_counter() - t0, 2)
    record[provenance.KEY] = provenance.make("inpaint", scene, {"distill": made and made.identity, "removal": removal and removal.identity}, asdict(cfg))
    write_inpainting(final, field_.gaussians, record, views, scene, out, backend=cfg.backend, overwrite=overwrite)
    return record
