"""The true-pose sparse model: surface points sampled from object-inclusive views, written with pycolmap.

Points come only from object-inclusive captures (DESIGN.md §3: no point that only a test view sees):
each is the centre-ray hit of a random pixel of an object-inclusive view, coloured with that pixel's
rendered colour, with a track in every object-inclusive view that sees it (exact ray-cast
visibility); points seen by fewer than two views are dropped, as SfM could not triangulate them.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from dataset_tools.synth.cameras import View
from dataset_tools.synth.visibility import visibility_matrix


@dataclass
class SparsePoints:
    xyz: np.ndarray  # (P, 3) float64
    rgb: np.ndarray  # (P, 3) uint8
    vis: np.ndarray  # (V, P) bool over the object-inclusive views
    uv: np.ndarray  # (V, P, 2) projections (meaningful where vis)


def sample_points(scene, renders: dict, n_points: int, seed: int) -> SparsePoints:
    """Sample ~``n_points`` pixels evenly over the object-inclusive views and build their tracks."""
    views = scene.inclusive_views
    rng = np.random.default_rng([int(seed), 0x5EED])
    per_view = int(np.ceil(n_points / max(1, len(views))))
    xyz, rgb = [], []
    for v in views:
        r = renders[v.name]
        pick = np.sort(rng.choice(v.width * v.height, size=min(per_view, v.width * v.height), replace=False))
        xyz.append(r.points.reshape(-1, 3)[pick])
        rgb.append(r.rgb8().reshape(-1, 3)[pick])
    xyz = np.concatenate(xyz)
    rgb = np.concatenate(rgb)
    vis = visibility_matrix(scene.world_full, views, xyz)
    keep = vis.sum(axis=0) >= 2
    xyz, rgb, vis = xyz[keep], rgb[keep], vis[:, keep]
    uv = np.stack([v.project(xyz)[0] for v in views]) if views else np.zeros((0, len(xyz), 2))
    return SparsePoints(xyz, rgb, vis, uv)


def write_sparse_model(path: str | Path, views: list[View], points: SparsePoints) -> None:
    """Write ``sparse/0`` (COLMAP binary) with one PINHOLE camera, every view registered at its true pose.

    pycolmap 4.x models rigs and frames: each image gets the camera's trivial rig and its own frame
    carrying the pose (``add_camera_with_trivial_rig`` / ``add_image_with_trivial_frame``). Image ids
    follow sorted names; object-free views are registered without observations.
    """
    import pycolmap

    v0 = views[0]
    rec = pycolmap.Reconstruction()
    cam = pycolmap.Camera(model="PINHOLE", width=v0.width, height=v0.height, params=[v0.fx, v0.fy, v0.cx, v0.cy], camera_id=1)
    rec.add_camera_with_trivial_rig(cam)
    inclusive = [v for v in views if not v.object_free]
    row = {v.name: k for k, v in enumerate(inclusive)}
    P = len(points.xyz)
    obs_index = np.full((len(inclusive), P), -1, dtype=np.int64)  # point2D index of point p in view k
    image_id = {}
    for iid, v in enumerate(sorted(views, key=lambda v: v.name), start=1):
        image_id[v.name] = iid
        if v.name in row:
            k = row[v.name]
            cols = np.nonzero(points.vis[k])[0]
            obs_index[k, cols] = np.arange(cols.size)
            kp = points.uv[k, cols]
        else:
            kp = np.zeros((0, 2))
        img = pycolmap.Image(name=v.name, keypoints=np.ascontiguousarray(kp, dtype=np.float64), camera_id=1, image_id=iid)
        pose = pycolmap.Rigid3d(pycolmap.Rotation3d(np.ascontiguousarray(v.R)), np.ascontiguousarray(v.t))
        rec.add_image_with_trivial_frame(img, pose)
    ids = np.array([image_id[v.name] for v in inclusive], dtype=np.int64)
    for p in range(P):
        ks = np.nonzero(points.vis[:, p])[0]
        track = pycolmap.Track([pycolmap.TrackElement(int(ids[k]), int(obs_index[k, p])) for k in ks])
        rec.add_point3D(np.ascontiguousarray(points.xyz[p]), track, np.ascontiguousarray(points.rgb[p], dtype=np.uint8))
    rec.update_point_3d_errors()
    path = Path(path)
    path.mkdir(parents=True, exist_ok=True)
    rec.write_binary(str(path))
