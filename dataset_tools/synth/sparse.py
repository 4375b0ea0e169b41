"""The true-pose sparse model: surface points sampled from object-inclusive views, written with pycolmap.

Points come only from object-inclusive captures (docs/architecture.md, "Scene format": no point that
only a test view sees): each is the centre-ray hit of a random pixel of an object-inclusive view,
coloured with that pixel's rendered colour, with a track in every object-inclusive view that sees it
(exact ray-cast visibility); points seen by fewer than two views are dropped, as SfM could not
triangulate them.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dataset_tools.synth.cameras import View
from dataset_tools.synth.visibility import visibility_matrix
from inpaint360gs.io.colmap import write_model


@dataclass
class SparsePoints:
    xyz: np.ndarray  # (P, 3) float64
    rgb: np.ndarray  # (P, 3) uint8
    vis: np.ndarray  # (V, P) bool over the object-inclusive views
    uv: np.ndarray  # (V, P, 2) projections (meaningful where vis)


def sample_points(scene, renders: dict, n_points: int, seed: int, images: dict | None = None) -> SparsePoints:
    """Sample ~``n_points`` pixels evenly over the object-inclusive views and build their tracks.

    Colours come from ``images`` (name -> the written 8-bit image) when given, else from the renders.
    """
    views = scene.inclusive_views
    rng = np.random.default_rng([int(seed), 0x5EED])
    per_view = int(np.ceil(n_points / max(1, len(views))))
    xyz, rgb = [], []
    for v in views:
        r = renders[v.name]
        n_pix = v.camera.width * v.camera.height
        pick = np.sort(rng.choice(n_pix, size=min(per_view, n_pix), replace=False))
        xyz.append(r.points.reshape(-1, 3)[pick])
        rgb.append((r.rgb8() if images is None else images[v.name]).reshape(-1, 3)[pick])
    xyz = np.concatenate(xyz)
    rgb = np.concatenate(rgb)
    vis = visibility_matrix(scene.world_full, views, xyz)
    keep = vis.sum(axis=0) >= 2
    xyz, rgb, vis = xyz[keep], rgb[keep], vis[:, keep]
    uv = np.stack([v.project(xyz)[0] for v in views]) if views else np.zeros((0, len(xyz), 2))
    return SparsePoints(xyz, rgb, vis, uv)


def write_sparse_model(path: str | Path, views: list[View], points: SparsePoints) -> None:
    """Write ``sparse/0`` (COLMAP binary) with one PINHOLE camera, every view registered at its true pose.

    Image ids follow sorted names; object-free views are registered without observations; each
    point's track lists the object-inclusive views that see it, in orbit order.
    """
    ordered = sorted(views, key=lambda v: v.name)
    index = {v.name: i for i, v in enumerate(ordered)}
    inclusive = [v for v in views if not v.object_free]
    row = {v.name: k for k, v in enumerate(inclusive)}
    obs_index = np.full(points.vis.shape, -1, dtype=np.int64)  # keypoint index of point p in inclusive view k
    keypoints = []
    for v in ordered:
        if v.name in row:
            k = row[v.name]
            cols = np.nonzero(points.vis[k])[0]
            obs_index[k, cols] = np.arange(cols.size)
            keypoints.append(points.uv[k, cols])
        else:
            keypoints.append(np.zeros((0, 2)))
    cam_of = np.array([index[v.name] for v in inclusive], dtype=np.int64)
    tracks = [[(int(cam_of[k]), int(obs_index[k, p])) for k in np.nonzero(points.vis[:, p])[0]]
              for p in range(len(points.xyz))]
    write_model(path, [v.camera for v in ordered], points.xyz, points.rgb, tracks=tracks, keypoints=keypoints)
