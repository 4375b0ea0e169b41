"""Point-leak removal: keep only sparse points that object-inclusive (training) images triangulate.

The joint SfM triangulates points from all images, including the object-free ground-truth views. A
point that only object-free views observe (typically the floor under a removed object) tells a
method what the hidden region looks like, so it must go (paper Sec. 4 "test-view point clouds are
excluded from training" and supp. Sec. A; DESIGN.md §3). By default a point also goes when only ONE
object-inclusive image observes it: one ray does not fix a depth, so its position came from the
object-free views (measured on the synthetic benchmark: 34-132 such points per scene).
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import pycolmap

from dataset_tools.build.captures import is_test_name


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
    min_inclusive_views: int = 1
    reason: str = "track observed by fewer than min_inclusive_views object-inclusive images (its position comes from object-free test_ views)"
    removed_xyz: np.ndarray = field(default_factory=lambda: np.zeros((0, 3)), repr=False)  # in memory only

    def to_dict(self) -> dict:
        keys = ("points_before", "removed", "removed_unseen", "removed_single_view", "min_inclusive_views", "points_after", "removed_by_test_views", "reason")
        return {k: getattr(self, k) for k in keys}


def inclusive_view_counts(rec: pycolmap.Reconstruction, is_inclusive: Callable[[str], bool] = default_is_inclusive) -> dict[int, int]:
    """Point id -> number of distinct object-inclusive images in its track."""
    inclusive = {iid for iid, im in rec.images.items() if is_inclusive(im.name)}
    return {pid: len({el.image_id for el in pt.track.elements} & inclusive) for pid, pt in rec.points3D.items()}


def leaked_point_ids(
    rec: pycolmap.Reconstruction, is_inclusive: Callable[[str], bool] = default_is_inclusive, min_inclusive_views: int = 1
) -> list[int]:
    """Ids of 3D points observed by fewer than ``min_inclusive_views`` object-inclusive images
    (1: the points that only object-free views see)."""
    return [pid for pid, n in inclusive_view_counts(rec, is_inclusive).items() if n < min_inclusive_views]


def remove_leaked_points(
    rec: pycolmap.Reconstruction, is_inclusive: Callable[[str], bool] = default_is_inclusive, min_inclusive_views: int = 2
) -> LeakRemoval:
    """Delete (in place) every point fewer than ``min_inclusive_views`` object-inclusive images observe; report the counts."""
    if min_inclusive_views < 1:
        raise ValueError(f"min_inclusive_views must be >= 1, got {min_inclusive_views}")
    before = rec.num_points3D()
    counts = inclusive_view_counts(rec, is_inclusive)
    leaked = [pid for pid, n in counts.items() if n < min_inclusive_views]
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
        removed_single_view=len(leaked) - unseen,
        min_inclusive_views=min_inclusive_views,
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
