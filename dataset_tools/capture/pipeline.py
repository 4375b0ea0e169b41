"""``build``: raw captures -> an Inpaint360GS scene folder (docs/architecture.md, "Scene format"),
written atomically.

Steps (paper supp. Sec. A): check the photos; joint SfM of all of them with one shared camera;
undistort to PINHOLE when the camera model has distortion; remove leaked points (and optionally
points seen inside given unseen masks); write images (object-free ones as ``test_*``), ``sparse/0``,
downscaled copies, ``unseen_mask/`` when given, ``scene.json`` and ``build_report.json``.

Without object-free photos (only photos with the object, the method's real use) the same steps
build a scene with no ``test_`` views and no unseen masks; ``scene.json`` then says
``"ground_truth": false`` with the reason, and evaluation reports that nothing can be scored.
"""

from __future__ import annotations

import shutil
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import pycolmap

from dataset_tools.capture.captures import CaptureConfig, CaptureSet, collect_captures
from dataset_tools.capture.colmap import SfMConfig, needs_undistortion, run_sfm, undistort, undistort_mask
from dataset_tools.capture.layout import copy_images, provenance, read_mask, write_downscaled, write_json
from dataset_tools.capture.leaks import recolor_from_inclusive_views, remove_leaked_points, remove_points_in_masks
from dataset_tools.capture.progress import StageProgress
from inpaint360gs.core.errors import InputError
from inpaint360gs.core.layout import GROUND_TRUTH_KEY, GROUND_TRUTH_REASON_KEY
from inpaint360gs.io.atomic import atomic_dir
from inpaint360gs.io.colmap import to_pinhole
from inpaint360gs.io.images import find_mask, write_mask


@dataclass
class BuildConfig:
    """Everything ``build`` needs besides the two paths."""

    captures: CaptureConfig = field(default_factory=CaptureConfig)
    sfm: SfMConfig = field(default_factory=SfMConfig)
    downscale: tuple[int, ...] = ()  # e.g. (2, 4, 8): writes images_2/, images_4/, images_8/
    unseen_masks: Path | None = None  # folder of unseen masks for the object-free views (optional)
    remove_unseen_points: bool = False  # also delete points observed inside those masks
    min_train_views: int = 2  # keep a point only when this many object-inclusive photos observe it (leaks.py)
    min_train_angle: float = 1.5  # ... and their rays span at least this many degrees (COLMAP mapper's minimum; leaks.py)
    # share of all photos (object-inclusive and object-free) that must register, else the build stops
    # naming the photos it could not place: a model missing a tenth of a walk-around is more often a
    # failed reconstruction than a few bad photos. 1.0: every photo; 0.0: accept a partial model.
    min_registered: float = 0.9
    overwrite: bool = False
    scene_name: str | None = None  # default: OUT's folder name
    progress: bool = True


@dataclass
class BuildReport:
    """What the build did; written to OUT/build_report.json and printed."""

    out: str
    captures: dict
    registration: dict
    points: dict
    output: dict
    timings: dict
    leaked_xyz: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)), repr=False)  # removed points, never written

    def to_dict(self) -> dict:
        return {k: getattr(self, k) for k in ("out", "captures", "registration", "points", "output", "timings")}

    def format(self) -> str:
        c, r, p, o = self.captures, self.registration, self.points, self.output
        lines = [
            f"built {self.out}",
            f"  photos: {c['object_inclusive']} object-inclusive + {c['object_free']} object-free "
            f"({c['width']}x{c['height']}, {c['layout']}); skipped {len(c['skipped'])}",
            f"  registered {r['registered']}/{r['total']} images with one {r['camera']['model']} camera "
            f"(SfM at {r['sfm_size'][0]}x{r['sfm_size'][1]}, matcher {r['matcher']}, {r['pairs']} pairs); "
            f"mean reprojection error {r['mean_reprojection_error_px']:.3f} px at full size "
            f"({r['sfm_reprojection_error_px']:.3f} px at the working size)",
        ]
        for name, src in r["unregistered"].items():
            lines.append(f"  not registered (skipped): {src}")
        for src, why in c["skipped"].items():
            lines.append(f"  skipped: {src}: {why}")
        leak = p["leak_removal"]
        lines.append(
            f"  points: {p['sfm']} from SfM, {p['after_undistortion']} after undistortion, "
            f"{leak['removed']} leaked removed ({leak['removed_unseen']} seen by no object-inclusive photo, "
            f"{leak['removed_single_view']} by fewer than {leak['min_inclusive_views']}, "
            f"{leak['removed_small_angle']} by rays within {leak['min_inclusive_angle_deg']}°), "
            f"{p['unseen_mask_removed']} removed inside unseen masks -> {p['final']}"
        )
        lines.append(
            f"  output: {o['num_train_images']} object-inclusive + {o['num_test_images']} test_ images at "
            f"{o['width']}x{o['height']} PINHOLE{'(undistorted)' if o['undistorted'] else ''}; "
            f"downscaled {sorted(o['downscaled']) or 'none'}; unseen masks {o['unseen_masks']}"
        )
        if not o.get("ground_truth", True):
            lines.append(f"  no ground truth: {NO_OBJECT_FREE_PHOTOS}")
        t = self.timings
        parts = [f"{k[:-2].replace('_', ' ')} {v:.1f}" for k, v in t.items() if k != "total_s"]
        lines.append(f"  time: {t['total_s']:.1f} s ({', '.join(parts)})")
        return "\n".join(lines)


def _load_unseen_masks(cset: CaptureSet, mask_dir: Path) -> dict[str, np.ndarray]:
    """Masks for every object-free photo, keyed by its output name; sizes must match the photos."""
    if not mask_dir.is_dir():
        raise InputError("unseen-mask folder does not exist", mask_dir)
    masks = {}
    for c in cset.object_free:
        path = find_mask(mask_dir, [c.out_name, c.source.name])
        if path is None:
            raise InputError(f"no unseen mask for {c.source.name} (expected {Path(c.out_name).stem}.png)", mask_dir)
        m = read_mask(path)
        if m.shape != (cset.height, cset.width):
            raise InputError(
                f"mask is {m.shape[1]}x{m.shape[0]}, its photo {c.source.name} is {cset.width}x{cset.height}", path
            )
        masks[c.out_name] = m
    return masks


NO_OBJECT_FREE_PHOTOS = (
    "built from object-inclusive photos only (no object-free photos): no test_ views and no unseen masks, "
    "so inpainting cannot be scored against ground truth"
)


def _ground_truth_entry(cset: CaptureSet) -> dict:
    """``scene.json``'s record of whether the scene has object-free ground truth (``core.layout``)."""
    if cset.has_ground_truth:
        return {GROUND_TRUTH_KEY: True}
    return {GROUND_TRUTH_KEY: False, GROUND_TRUTH_REASON_KEY: NO_OBJECT_FREE_PHOTOS}


def _check_registered_share(n_registered: int, unplaced: list[str], min_share: float, captures: str | Path) -> None:
    """Stop with one line naming the photos SfM could not place when fewer than ``min_share`` of all registered."""
    total = n_registered + len(unplaced)
    needed = int(np.ceil(min_share * total - 1e-9))
    if n_registered >= needed:
        return
    root = Path(captures)
    shown = [str(Path(p).relative_to(root)) if Path(p).is_relative_to(root) else str(p) for p in unplaced]
    more = f" and {len(shown) - 20} more" if len(shown) > 20 else ""
    flag = "--require-all-registered" if min_share >= 1.0 else f"--min-registered {min_share:g}"
    raise InputError(
        f"only {n_registered} of {total} photos registered ({flag} needs {needed}); could not place "
        f"{', '.join(shown[:20])}{more} (--allow-partial or a lower --min-registered keeps a partial model)",
        captures,
    )


def _camera_dict(cam: pycolmap.Camera) -> dict:
    return {"model": cam.model_name, "width": cam.width, "height": cam.height, "params": [float(v) for v in cam.params]}


def build_dataset(captures: str | Path, out: str | Path, config: BuildConfig | None = None) -> BuildReport:
    """Build a scene folder at ``out`` from the photos under ``captures``; returns the report.

    Nothing is written under ``out`` unless the whole build succeeds.
    """
    cfg = config or BuildConfig()
    if cfg.min_train_views < 1:
        raise InputError(f"must be >= 1, got {cfg.min_train_views}", "--min-train-views")
    if not 0.0 <= cfg.min_train_angle < 90.0:
        raise InputError(f"must be in [0, 90) degrees, got {cfg.min_train_angle}", "--min-train-angle")
    if not 0.0 <= cfg.min_registered <= 1.0:
        raise InputError(f"must be a fraction in [0, 1], got {cfg.min_registered}", "--min-registered")
    t_start = time.perf_counter()
    out = Path(out)
    cset = collect_captures(captures, cfg.captures)
    if cfg.unseen_masks is not None and not cset.has_ground_truth:
        raise InputError("unseen masks belong to object-free photos, and the captures hold none", "--unseen-masks")
    masks = _load_unseen_masks(cset, Path(cfg.unseen_masks)) if cfg.unseen_masks is not None else None
    if cfg.remove_unseen_points and masks is None:
        raise InputError("removing points inside unseen masks needs --unseen-masks", "--remove-unseen-points")
    source_of = {c.out_name: str(c.source) for c in cset.captures}
    free_names = {c.out_name for c in cset.object_free}
    names = sorted(source_of)

    with atomic_dir(out, overwrite=cfg.overwrite) as tmp, StageProgress(cfg.progress) as progress:
        work = tmp / ".work"
        staged = work / "images"
        staged.mkdir(parents=True)
        for c in cset.captures:
            shutil.copyfile(c.source, staged / c.out_name)

        try:
            sfm = run_sfm(staged, names, free_names, work, cfg.sfm, progress)
        except InputError as e:  # it names the staged copies, a temporary folder the user never sees
            raise InputError(e.message, captures) from None
        rec = sfm.reconstruction
        registered = {rec.image(i).name for i in rec.reg_image_ids()}
        reg_free = registered & free_names
        if free_names and not reg_free:
            raise InputError(f"none of the {len(free_names)} object-free photos could be registered", captures)
        if len(registered - free_names) < 2:
            raise InputError("fewer than 2 object-inclusive photos could be registered", captures)
        _check_registered_share(len(registered), [source_of[n] for n in sfm.unregistered], cfg.min_registered, captures)
        c0 = next(iter(rec.cameras.values()))
        sfm_camera = pycolmap.Camera(  # a copy: rec is replaced after undistortion
            model=c0.model_name, width=c0.width, height=c0.height, params=list(c0.params), camera_id=c0.camera_id
        )
        registration = {
            "registered": len(registered),
            "total": len(names),
            "min_registered": cfg.min_registered,
            "unregistered": {n: source_of[n] for n in sfm.unregistered},
            "models": sfm.model_sizes,
            "matcher": sfm.matcher,
            "pairs": sfm.num_pairs,
            "mean_reprojection_error_px": float(rec.compute_mean_reprojection_error()),  # in full-size pixels
            "sfm_size": list(sfm.sfm_size),  # the working size SfM ran at (SfMConfig.sfm_max_size)
            "sfm_reprojection_error_px": sfm.working_reprojection_error_px,  # in pixels of the working size
            "mean_track_length": float(rec.compute_mean_track_length()),
            "camera": _camera_dict(sfm_camera),
        }
        n_sfm = rec.num_points3D()

        # Undistort to PINHOLE (paper supp. Sec. A) when the model has distortion.
        t0 = time.perf_counter()
        undistorted = needs_undistortion(rec)
        if undistorted:
            raw = work / "sparse_raw"
            raw.mkdir()
            rec.write(raw)
            undistort(raw, staged, work / "undistorted", cfg.sfm.num_threads, cfg.sfm.verbose, progress)
            rec = pycolmap.Reconstruction(work / "undistorted" / "sparse")
            image_src = work / "undistorted" / "images"
            if masks is not None:
                masks = {n: undistort_mask(m, sfm_camera) for n, m in masks.items()}
        else:
            to_pinhole(rec)
            image_src = staged
        n_undist = rec.num_points3D()
        undistort_s = time.perf_counter() - t0

        leak = remove_leaked_points(rec, min_inclusive_views=cfg.min_train_views, min_inclusive_angle_deg=cfg.min_train_angle)
        masked_removed = 0
        if masks is not None:
            masks = {n: m for n, m in masks.items() if n in registered}
            if cfg.remove_unseen_points:
                masked_removed = remove_points_in_masks(rec, masks)
        # point colours from object-inclusive photos only (COLMAP averaged the object-free ones in too)
        recolored = recolor_from_inclusive_views(rec, image_src)

        cam = next(iter(rec.cameras.values()))
        out_names = sorted(registered)
        t0 = time.perf_counter()
        progress("writing", 0, len(out_names))
        copy_images(image_src, out_names, tmp / "images")
        (tmp / "sparse" / "0").mkdir(parents=True)
        rec.write(tmp / "sparse" / "0")
        if masks is not None:
            for name, m in masks.items():
                write_mask(tmp / "unseen_mask" / f"{Path(name).stem}.png", m)
        downscaled = write_downscaled(tmp / "images", out_names, tmp, cfg.downscale,
                                      on_image=lambda k: progress("writing", k, len(out_names)))
        progress("writing", len(out_names), len(out_names))
        shutil.rmtree(work)
        write_s = time.perf_counter() - t0

        n_test = len(reg_free)
        report = BuildReport(
            out=str(out),
            captures={
                "root": str(Path(captures).resolve()),
                "layout": cset.layout,
                "object_inclusive": len(cset.object_inclusive),
                "object_free": len(cset.object_free),
                "width": cset.width,
                "height": cset.height,
                "skipped": cset.skipped,
            },
            registration=registration,
            points={
                "sfm": n_sfm,
                "after_undistortion": n_undist,
                "leak_removal": leak.to_dict(),
                "unseen_mask_removed": masked_removed,
                "recolored_from_object_inclusive": recolored,
                "final": rec.num_points3D(),
                "mean_reprojection_error_px": float(rec.compute_mean_reprojection_error()),
            },
            output={
                "undistorted": undistorted,
                "camera": _camera_dict(cam),
                "width": cam.width,
                "height": cam.height,
                "num_train_images": len(out_names) - n_test,
                "num_test_images": n_test,
                "downscaled": downscaled,
                "unseen_masks": len(masks) if masks is not None else 0,
                "ground_truth": cset.has_ground_truth,
            },
            timings={**{k: round(v, 2) for k, v in sfm.timings.items()}, "undistort_s": round(undistort_s, 2),
                     "write_s": round(write_s, 2), "total_s": time.perf_counter() - t_start},
            leaked_xyz=leak.removed_xyz,
        )
        sfm_cfg = asdict(cfg.sfm)
        write_json(
            tmp / "scene.json",
            {
                "name": cfg.scene_name or out.name,
                "objects": [],
                "removal_targets": [],
                **_ground_truth_entry(cset),
                "source": "captures",
                "provenance": provenance(
                    "inpaint360gs-dataset build",
                    {
                        "captures": asdict(cfg.captures),
                        "sfm": sfm_cfg,
                        "downscale": list(cfg.downscale),
                        "unseen_masks": str(cfg.unseen_masks) if cfg.unseen_masks else None,
                        "remove_unseen_points": cfg.remove_unseen_points,
                    },
                    captures=str(Path(captures).resolve()),
                    colmap=pycolmap.COLMAP_version,
                ),
            },
        )
        report.timings["total_s"] = round(time.perf_counter() - t_start, 2)
        write_json(tmp / "build_report.json", report.to_dict())
    return report
