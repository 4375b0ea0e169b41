"""Point-leak removal: keep only sparse points that object-inclusive (training) images triangulate.

The joint SfM triangulates points from all images, including the object-free ground-truth views. A
point that only object-free views observe (typically the floor under a removed object) tells a
method what the hidden region looks like, so it must go (paper Sec. 4 "test-view point clouds are
excluded from training" and supp. Sec. A; docs/architecture.md, "Scene format"). By default a point
also goes when only ONE object-inclusive image observes it: one ray does not fix a depth, so its
position came from the object-free views; and when the object-inclusive rays meet at less than ``min_inclusive_angle_deg`` (1.5°,
the minimum triangulation angle of COLMAP's mapper): nearly parallel rays do not fix it either, so a
training-only reconstruction would not have that point (how many of each: results/README.md,
"Building datasets through COLMAP").
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pycolmap

from inpaint360gs.core.layout import is_test_name
from inpaint360gs.io.images import read_image


def default_is_inclusive(name: str) -> bool:
    """Object-inclusive images are all images not named ``test_*``."""
    return not is_test_name(name)


@dataclass
class LeakRemoval:
    """What point-leak removal did and why."""

    points_before: int
    removed: int  # all removed points (the two reasons below)
    points_after: int
    removed_by_test_views: dict[str, int]  # object-free image -> removed points it observed
    removed_unseen: int = 0  # no observation in any object-inclusive image
    removed_single_view: int = 0  # observed by fewer than ``min_inclusive_views`` (but >= 1) object-inclusive images
    removed_small_angle: int = 0  # enough object-inclusive images, but their rays meet at < ``min_inclusive_angle_deg``
    min_inclusive_views: int = 1
    min_inclusive_angle_deg: float = 0.0
    reason: str = ("object-inclusive observations alone do not triangulate the point (fewer than min_inclusive_views "
                   "of them, or rays within min_inclusive_angle_deg): its position comes from object-free test_ views")
    removed_xyz: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)), repr=False)  # in memory only

    def to_dict(self) -> dict:
        keys = ("points_before", "removed", "removed_unseen", "removed_single_view", "removed_small_angle", "min_inclusive_views",
                "min_inclusive_angle_deg", "points_after", "removed_by_test_views", "reason")
        return {k: getattr(self, k) for k in keys}


def inclusive_view_counts(rec: pycolmap.Reconstruction, is_inclusive: Callable[[str], bool] = default_is_inclusive) -> dict[int, int]:
    """Point id -> number of distinct object-inclusive images in its track."""
    inclusive = {iid for iid, im in rec.images.items() if is_inclusive(im.name)}
    return {pid: len({el.image_id for el in pt.track.elements} & inclusive) for pid, pt in rec.points3D.items()}


def inclusive_triangulation_angles(rec: pycolmap.Reconstruction, is_inclusive: Callable[[str], bool] = default_is_inclusive) -> dict[int, float]:
    """Point id -> largest angle (degrees) between the rays from its object-inclusive observers'
    camera centres to it (0 with fewer than two such observers)."""
    centres = {iid: im.projection_center() for iid, im in rec.images.items() if is_inclusive(im.name)}
    out = {}
    for pid, pt in rec.points3D.items():
        ids = sorted({el.image_id for el in pt.track.elements} & centres.keys())
        if len(ids) < 2:
            out[pid] = 0.0
            continue
        rays = pt.xyz - np.array([centres[i] for i in ids])
        rays /= np.linalg.norm(rays, axis=1, keepdims=True)
        out[pid] = float(np.degrees(np.arccos(np.clip((rays @ rays.T).min(), -1.0, 1.0))))
    return out


def leaked_point_ids(
    rec: pycolmap.Reconstruction, is_inclusive: Callable[[str], bool] = default_is_inclusive, min_inclusive_views: int = 1
) -> list[int]:
    """Ids of 3D points observed by fewer than ``min_inclusive_views`` object-inclusive images
    (1: the points that only object-free views see)."""
    return [pid for pid, n in inclusive_view_counts(rec, is_inclusive).items() if n < min_inclusive_views]


def remove_leaked_points(
    rec: pycolmap.Reconstruction,
    is_inclusive: Callable[[str], bool] = default_is_inclusive,
    min_inclusive_views: int = 2,
    min_inclusive_angle_deg: float = 1.5,
) -> LeakRemoval:
    """Delete (in place) every point that its object-inclusive observations alone do not triangulate:
    fewer than ``min_inclusive_views`` of them, or their rays all within ``min_inclusive_angle_deg``
    of each other. Reports the counts per reason."""
    if min_inclusive_views < 1:
        raise ValueError(f"min_inclusive_views must be >= 1, got {min_inclusive_views}")
    if not 0.0 <= min_inclusive_angle_deg < 90.0:
        raise ValueError(f"min_inclusive_angle_deg must be in [0, 90), got {min_inclusive_angle_deg}")
    before = rec.num_points3D()
    counts = inclusive_view_counts(rec, is_inclusive)
    angles = inclusive_triangulation_angles(rec, is_inclusive) if min_inclusive_angle_deg > 0 else {}
    few = {pid for pid, n in counts.items() if n < min_inclusive_views}
    narrow = {pid for pid, a in angles.items() if pid not in few and counts[pid] >= 2 and a < min_inclusive_angle_deg}
    leaked = sorted(few | narrow)
    unseen = sum(counts[pid] == 0 for pid in leaked)
    per_view: dict[str, int] = {}
    xyz = np.array([rec.point3D(pid).xyz for pid in leaked], float).reshape(-1, 3)
    for pid in leaked:
        for el in rec.point3D(pid).track.elements:
            name = rec.image(el.image_id).name
            per_view[name] = per_view.get(name, 0) + 1
        rec.delete_point3D(pid)
    return LeakRemoval(
        points_before=before,
        removed=len(leaked),
        points_after=rec.num_points3D(),
        removed_by_test_views=dict(sorted(per_view.items())),
        removed_unseen=unseen,
        removed_single_view=len(few) - unseen,
        removed_small_angle=len(narrow),
        min_inclusive_views=min_inclusive_views,
        min_inclusive_angle_deg=min_inclusive_angle_deg,
        removed_xyz=xyz,
    )


def remove_points_in_masks(rec: pycolmap.Reconstruction, masks: Mapping[str, np.ndarray]) -> int:
    """Delete (in place) every point observed inside a given mask; returns how many went.

    ``masks`` maps an image name (e.g. a test_ view) to a boolean (H, W) unseen mask. A point counts
    when one of its observations in that image falls on a True pixel (COLMAP keypoints have the
    top-left pixel's centre at (0.5, 0.5), so the pixel is (floor(y), floor(x))). Using observations
    rather than projections keeps points that merely lie in front of the masked region in that view,
    e.g. on the objects themselves.
    """
    by_name = {im.name: im for im in rec.images.values()}
    doomed: set[int] = set()
    for name, mask in masks.items():
        im = by_name.get(name) or by_name.get(Path(name).name)
        if im is None:
            continue
        h, w = mask.shape
        for p2d in im.points2D:
            if not p2d.has_point3D():
                continue
            x, y = int(np.floor(p2d.xy[0])), int(np.floor(p2d.xy[1]))
            if 0 <= x < w and 0 <= y < h and mask[y, x]:
                doomed.add(p2d.point3D_id)
    for pid in doomed:
        rec.delete_point3D(pid)
    return len(doomed)


def object_free_influence(
    rec: pycolmap.Reconstruction,
    point_ids: list[int] | None = None,
    is_inclusive: Callable[[str], bool] = default_is_inclusive,
    relative: bool = False,
) -> np.ndarray:
    """How far the object-free views move each point: distance between the multi-view triangulation
    from its object-inclusive observations alone and from all its observations.

    Model units, or with ``relative`` a fraction of the point's distance to the nearest
    object-inclusive camera (scale-free: depth noise grows with distance). 0 for points no object-free
    view observes; NaN where the object-inclusive observations alone cannot triangulate the point.
    A kept point the object-free views move far got part of its position from the ground truth
    (``benchmarks/bench_build.py`` reports the distribution; joint SfM cannot avoid it entirely).
    """
    ids = list(rec.points3D) if point_ids is None else list(point_ids)
    centres = np.array([im.projection_center() for im in rec.images.values() if is_inclusive(im.name)]).reshape(-1, 3)
    out = np.zeros(len(ids))
    for k, pid in enumerate(ids):
        mats, rays, inclusive = [], [], []
        for el in rec.point3D(pid).track.elements:
            im = rec.image(el.image_id)
            mats.append(im.cam_from_world().matrix())
            rays.append(rec.camera(im.camera_id).cam_ray_from_img(im.points2D[el.point2D_idx].xy))
            inclusive.append(is_inclusive(im.name))
        if all(inclusive):
            continue
        inc = np.flatnonzero(inclusive)
        x_all = pycolmap.triangulate_multi_view_point(mats, np.array(rays))
        x_inc = pycolmap.triangulate_multi_view_point([mats[i] for i in inc], np.array(rays)[inc]) if len(inc) >= 2 else None
        out[k] = np.nan if x_all is None or x_inc is None else float(np.linalg.norm(np.ravel(x_all) - np.ravel(x_inc)))
        if relative and np.isfinite(out[k]):
            out[k] /= np.linalg.norm(centres - rec.point3D(pid).xyz, axis=1).min()
    return out


def recolor_from_inclusive_views(
    rec: pycolmap.Reconstruction, image_dir: str | Path, is_inclusive: Callable[[str], bool] = default_is_inclusive
) -> int:
    """Set each point's colour (in place) to the mean of its object-inclusive observations' pixels.

    COLMAP averages over the whole track, object-free views included, so a kept point's colour would
    still carry ground-truth pixels into the 3DGS initialisation. Pixel of a keypoint: (floor(y),
    floor(x)) (COLMAP puts the top-left pixel's centre at (0.5, 0.5)). Returns how many points
    changed colour. Every kept point has an object-inclusive observation (``remove_leaked_points``);
    one without keeps its colour.
    """
    pids = np.array(sorted(rec.points3D), dtype=np.int64)
    sums = np.zeros((len(pids), 3))
    counts = np.zeros(len(pids))
    for im in rec.images.values():
        obs = [(p.point3D_id, p.xy) for p in im.points2D if p.has_point3D()] if is_inclusive(im.name) else []
        if not obs:
            continue
        img = read_image(Path(image_dir) / im.name)  # RGB
        if img.dtype == np.uint16:
            img = img >> 8  # 8-bit colours, as COLMAP reads 16-bit images
        h, w = img.shape[:2]
        row = np.searchsorted(pids, [pid for pid, _ in obs])
        xy = np.floor(np.array([xy for _, xy in obs])).astype(int)
        np.add.at(sums, row, img[np.clip(xy[:, 1], 0, h - 1), np.clip(xy[:, 0], 0, w - 1)])
        np.add.at(counts, row, 1)
    changed = 0
    for k in np.flatnonzero(counts):
        color = np.clip(np.round(sums[k] / counts[k]), 0, 255).astype(np.uint8)
        pt = rec.point3D(int(pids[k]))
        changed += int(np.any(pt.color != color))
        pt.color = color
    return changed
