"""Turn a generated synthetic scene back into raw captures (images only, no poses), and score a build of it.

This is how the COLMAP path is tested end to end: export -> ``build`` -> compare with the
generator's ground truth (poses after Sim(3) alignment, leaked points via the visibility oracle).
"""

from __future__ import annotations

import json
import shutil
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from dataset_tools.capture.posecheck import Pose, PoseAccuracy, pose_accuracy, reconstruction_poses, similarity_to_true
from inpaint360gs.core.errors import InputError
from inpaint360gs.core.layout import TEST_PREFIX, is_test_name
from inpaint360gs.io.atomic import atomic_dir
from inpaint360gs.io.colmap import read_model
from inpaint360gs.io.images import read_binary_mask, read_mask, write_mask


def export_raw_captures(
    scene_dir: str | Path,
    out: str | Path,
    *,
    object_masks: bool = False,
    unseen_masks: bool = False,
    overwrite: bool = False,
) -> Path:
    """Write ``out/with_objects/IMG_*.png`` and ``out/without_objects/*.png`` (``test_`` prefix dropped).

    ``object_masks`` adds ``out/object_masks/<stem>.png`` (255 = removal targets, from gt/instance) for
    the object-inclusive photos; ``unseen_masks`` adds ``out/unseen_masks/`` (the generator's exact
    masks, named like the exported object-free photos). No pose, intrinsics or depth is exported.
    """
    scene_dir = Path(scene_dir)
    images = scene_dir / "images"
    if not images.is_dir():
        raise InputError("images/ missing (not a scene folder?)", scene_dir)
    targets: list[int] = []
    if object_masks:
        meta = json.loads((scene_dir / "scene.json").read_text())
        targets = [int(i) for i in meta.get("removal_targets", [])]
    with atomic_dir(out, overwrite=overwrite) as tmp:
        for p in sorted(images.iterdir()):
            if not p.is_file():
                continue
            if is_test_name(p.name):
                raw = p.name.removeprefix(TEST_PREFIX)
                (tmp / "without_objects").mkdir(exist_ok=True)
                shutil.copyfile(p, tmp / "without_objects" / raw)
                if unseen_masks:
                    shutil.copyfile(scene_dir / "unseen_mask" / f"{p.stem}.png", _mkdir(tmp / "unseen_masks") / f"{Path(raw).stem}.png")
            else:
                (tmp / "with_objects").mkdir(exist_ok=True)
                shutil.copyfile(p, tmp / "with_objects" / p.name)
                if object_masks:
                    inst = read_mask(scene_dir / "gt" / "instance" / f"{p.stem}.png")  # object ids
                    write_mask(tmp / "object_masks" / f"{p.stem}.png", np.isin(inst, targets))
    return Path(out)


def _mkdir(p: Path) -> Path:
    p.mkdir(parents=True, exist_ok=True)
    return p


def true_poses(scene_dir: str | Path) -> dict[str, Pose]:
    """name -> (R, t) world->camera from a generated scene's gt/cameras.json."""
    cams = json.loads((Path(scene_dir) / "gt" / "cameras.json").read_text())
    return {c["name"]: (np.asarray(c["R"], float), np.asarray(c["t"], float)) for c in cams["images"]}


def orbit_radius(scene_dir: str | Path) -> float:
    """The generator's orbit radius for the scene (cameras lie within a few % of it)."""
    from dataset_tools.synth.cameras import orbit_geometry
    from dataset_tools.synth.scene import load_scene

    sc = load_scene(scene_dir)
    return orbit_geometry(sc.spec, sc.width, sc.height)[1]


@dataclass
class LeakCheck:
    """Which points lie only on surfaces no object-inclusive capture sees (see :func:`leak_check`)."""

    tolerance: float  # metres
    noise_median: float  # median distance of the points to the nearest seen surface (metres)
    leaked: np.ndarray  # (P,) bool
    off_surface: np.ndarray  # (P,) bool: farther than the tolerance from every surface sample

    def summary(self) -> dict:
        return {"tolerance_m": self.tolerance, "noise_median_m": self.noise_median,
                "leaked": int(self.leaked.sum()), "off_surface": int(self.off_surface.sum()), "points": len(self.leaked)}


def surface_samples(truth: str | Path) -> tuple[np.ndarray, np.ndarray]:
    """Dense ground-truth surface points: (seen, unseen).

    Seen: every pixel's surface point of every object-inclusive capture (visible from it by
    definition). Unseen: the object-free captures' surface points under their unseen masks.
    """
    truth = Path(truth)
    cams = json.loads((truth / "gt" / "cameras.json").read_text())
    K = np.array([[cams["fx"], 0, cams["cx"]], [0, cams["fy"], cams["cy"]], [0, 0, 1.0]])
    jj, ii = np.meshgrid(np.arange(cams["width"]) + 0.5, np.arange(cams["height"]) + 0.5)
    rays = np.stack([jj, ii, np.ones_like(jj)], -1).reshape(-1, 3) @ np.linalg.inv(K).T
    seen, unseen = [], []
    for c in cams["images"]:
        stem = Path(c["name"]).stem
        R, t = np.asarray(c["R"], float), np.asarray(c["t"], float)
        d = np.load(truth / "gt" / "depth" / f"{stem}.npy").reshape(-1).astype(np.float64)
        ok = np.isfinite(d) & (d > 0)
        if c["object_free"]:
            ok &= read_binary_mask(truth / "unseen_mask" / f"{stem}.png").reshape(-1)
        P = (rays[ok] * d[ok, None] - t) @ R
        (unseen if c["object_free"] else seen).append(P)
    return np.concatenate(seen), (np.concatenate(unseen) if unseen else np.zeros((0, 3)))


def leak_check(truth: str | Path, points: np.ndarray, tolerance: float | None = None) -> LeakCheck:
    """Flag points (in the generator's frame) that lie only on surfaces no object-inclusive capture sees.

    A point is leaked when it is farther than ``tolerance`` from every seen surface sample, within
    ``tolerance`` of an unseen one, and the generator's visibility oracle, given the same tolerance,
    finds no object-inclusive capture that sees it. The default tolerance is 3x the median distance
    of the points to the nearest seen surface: the SfM noise level measured on the points themselves.
    """
    from scipy.spatial import cKDTree

    from dataset_tools.synth import seen_by_object_inclusive_views

    points = np.asarray(points, float).reshape(-1, 3)
    seen_pts, unseen_pts = surface_samples(truth)
    d_seen, _ = cKDTree(seen_pts).query(points, workers=2)
    noise = float(np.median(d_seen)) if len(points) else 0.0
    tol = 3.0 * noise if tolerance is None else float(tolerance)
    far = d_seen > tol
    near_unseen = np.zeros(len(points), bool)
    if far.any() and len(unseen_pts):
        d_unseen, _ = cKDTree(unseen_pts).query(points[far], distance_upper_bound=tol, workers=2)
        near_unseen[np.flatnonzero(far)] = np.isfinite(d_unseen)
    leaked = np.zeros(len(points), bool)
    cand = np.flatnonzero(near_unseen)
    if cand.size:
        leaked[cand] = ~seen_by_object_inclusive_views(truth, points[cand], tol=tol)
    return LeakCheck(tolerance=tol, noise_median=noise, leaked=leaked, off_surface=far & ~near_unseen)


def object_free_observations(rec, point_ids) -> np.ndarray:
    """Per point id: how many distinct object-free (``test_*``) images observe it."""
    return np.array([len({el.image_id for el in rec.point3D(pid).track.elements if is_test_name(rec.image(el.image_id).name)})
                     for pid in point_ids], int)


def to_truth_frame(rec, truth: str | Path, points: np.ndarray | None = None) -> np.ndarray:
    """``points`` (default: all of ``rec``'s) mapped by the Sim(3) that aligns ``rec``'s cameras to the true ones."""
    M = similarity_to_true(reconstruction_poses(rec), true_poses(truth))
    X = np.array([p.xyz for p in rec.points3D.values()]) if points is None else np.asarray(points, float)
    return X.reshape(-1, 3) @ M[:, :3].T + M[:, 3]


@dataclass
class BuildScore:
    """How a build of exported captures compares with the generator's truth."""

    registered: int
    total: int
    poses: PoseAccuracy
    leaks: dict  # LeakCheck.summary() of the remaining points

    def to_dict(self) -> dict:
        d = asdict(self)
        d["poses"] = self.poses.to_dict()
        return d


def score_build(built: str | Path, truth: str | Path, leak_tolerance: float | None = None) -> BuildScore:
    """Pose accuracy (after Sim(3) alignment) and leak check of ``built``'s sparse model against ``truth``."""
    built, truth = Path(built), Path(truth)
    rec = read_model(built / "sparse" / "0")
    est = reconstruction_poses(rec)
    acc = pose_accuracy(est, true_poses(truth), orbit_radius(truth))
    check = leak_check(truth, to_truth_frame(rec, truth), leak_tolerance)
    n_files = len([p for p in (truth / "images").iterdir() if p.is_file()])
    return BuildScore(registered=len(est), total=n_files, poses=acc, leaks=check.summary())
