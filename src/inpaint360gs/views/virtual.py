"""Virtual cameras around the removed object (paper Sec. 3.4 "Virtual Camera Views for Inpainting",
Eq. 5's trajectory P; supp. B "Virtual Camera Views").

The training poses are aligned by PCA: their centres' direction of least variance is the normal of
the capture orbit (oriented like the cameras' mean up vector). A circle of L views (default 30) is
laid around the centre of the removed Gaussians, at the training cameras' median elevation angle
as seen from that centre, every camera looking at it with the training intrinsics. Its radius is
chosen so that the region to fill covers 1%–50% of each image (supp. B): candidates from the
training cameras' median distance to the centre inwards are tried in order and the first whose
every view lies in the band is taken (else the candidate closest to it), because a closer camera
sees a larger hole and a hole too large defeats a 2D inpainter.
"""

from __future__ import annotations

import json
import math
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import torch

from inpaint360gs.core.camera import Camera
from inpaint360gs.core.errors import InputError
from inpaint360gs.views.config import VirtualViewsConfig


def camera_up(cameras: Sequence[Camera]) -> np.ndarray:
    """Mean world up vector of the cameras (image y points down: up is minus the camera's y axis)."""
    up = -np.mean([c.R.detach().cpu().double().numpy()[1] for c in cameras], axis=0)
    return up / np.linalg.norm(up)


def pca_frame(cameras: Sequence[Camera]) -> np.ndarray:
    """Rows u, v, n: PCA axes of the camera centres, n (least variance: the orbit normal) oriented
    with the cameras' up vector, u, v spanning the orbit plane (right-handed)."""
    centres = np.array([c.center.detach().cpu().double().numpy() for c in cameras])
    if len(centres) < 3:
        raise InputError(f"PCA alignment needs at least 3 training cameras, got {len(centres)}")
    _, _, vt = np.linalg.svd(centres - centres.mean(0), full_matrices=True)
    n = vt[2] * (1.0 if vt[2] @ camera_up(cameras) >= 0 else -1.0)
    u = vt[0]
    v = np.cross(n, u)
    return np.stack([u, v, n])


def orbit_cameras(centre: np.ndarray, frame: np.ndarray, distance: float, elevation: float, n: int, like: Camera, phase: float = 0.0) -> list[Camera]:
    """``n`` cameras on a circle around ``centre`` at ``distance`` and ``elevation`` (radians) in
    ``frame`` (rows u, v, n), looking at ``centre`` with ``like``'s intrinsics."""
    u, v, up = frame
    cams = []
    for i in range(n):
        a = phase + 2.0 * math.pi * i / n
        d = math.cos(elevation) * (math.cos(a) * u + math.sin(a) * v) + math.sin(elevation) * up
        eye = centre + distance * d
        cams.append(Camera.look_at(eye, centre, up, like.fx, like.fy, like.cx, like.cy, like.width, like.height, name=f"virtual_{i:03d}"))
    return cams


def trajectory_geometry(cameras: Sequence[Camera], centre: np.ndarray) -> tuple[np.ndarray, float, float, float]:
    """(PCA frame, median elevation angle, median distance, phase of the first camera) of the
    training cameras as seen from ``centre``."""
    frame = pca_frame(cameras)
    rel = np.array([c.center.detach().cpu().double().numpy() for c in cameras]) - centre
    dist = np.linalg.norm(rel, axis=1)
    elev = np.arcsin(np.clip(rel @ frame[2] / np.maximum(dist, 1e-12), -1.0, 1.0))
    phase = math.atan2(rel[0] @ frame[1], rel[0] @ frame[0])
    return frame, float(np.median(elev)), float(np.median(dist)), phase


def choose_trajectory(
    cameras: Sequence[Camera],
    centre: np.ndarray,
    fill_share: Callable[[list[Camera]], np.ndarray],
    cfg: VirtualViewsConfig | None = None,
) -> tuple[list[Camera], dict]:
    """The virtual cameras (see the module docstring). ``fill_share(cams)`` returns, per camera, the
    share of its image the region to fill covers. Returns the cameras and a record of the choice."""
    cfg = cfg or VirtualViewsConfig()
    if cfg.num_views < 2:
        raise InputError(f"a virtual trajectory needs at least 2 views, got {cfg.num_views}", setting="VirtualViewsConfig.num_views")
    frame, elevation, distance, phase = trajectory_geometry(cameras, centre)
    tried = []
    best = None
    for f in cfg.radius_factors:
        cams = orbit_cameras(centre, frame, f * distance, elevation, cfg.num_views, cameras[0], phase)
        share = np.asarray(fill_share(cams), dtype=np.float64)
        lo, hi = float(share.min()), float(share.max())
        miss = max(cfg.min_fill - lo, 0.0) + max(hi - cfg.max_fill, 0.0)  # distance to the band
        tried.append({"radius_factor": f, "radius": f * distance, "fill_min": lo, "fill_max": hi, "fill_mean": float(share.mean())})
        if best is None or miss < best[0]:
            best = (miss, cams, f)
        if miss == 0.0:
            break
    if all(t["fill_max"] == 0.0 for t in tried):
        raise InputError("the removed region is not visible from any virtual camera (nothing to inpaint around the object centre)")
    info = {
        "centre": centre.tolist(), "frame": frame.tolist(), "elevation_deg": math.degrees(elevation),
        "training_distance": distance, "radius": best[2] * distance, "radius_factor": best[2],
        "in_band": best[0] == 0.0, "candidates": tried,
    }  # fmt: skip
    return best[1], info


def support_camera(footprint, like: Camera, fill: float = 0.5, name: str = "support") -> Camera:
    """A camera straight above an object's footprint (:class:`inpaint360gs.core.support.Footprint`),
    looking down the support plane's normal at the footprint's centre, with ``like``'s intrinsics,
    at the height where the footprint's diameter spans ``fill`` of the image's shorter side; the
    image's up is ``like``'s viewing direction laid onto the plane.

    An image plane parallel to a plane maps it by a similarity: in this view the support is seen
    rectified, its textures stationary and its straight edges straight, the case where an exemplar
    fill continues them (the first view of the recursive inpainting, :mod:`inpaint360gs.inpaint.stage`)."""
    n = np.asarray(footprint.normal, dtype=np.float64)
    centre = footprint.centre
    f = max(like.fx, like.fy)
    height = footprint.diameter * f / (fill * min(like.width, like.height))
    fwd = like.R.detach().cpu().double().numpy()[2]
    fwd = fwd - (fwd @ n) * n
    if np.linalg.norm(fwd) < 1e-6:  # ``like`` looks straight down: any direction in the plane
        fwd = np.cross(n, [1.0, 0.0, 0.0] if abs(n[0]) < 0.9 else [0.0, 1.0, 0.0])
    fwd /= np.linalg.norm(fwd)
    return Camera.look_at(centre + height * n, centre, fwd, like.fx, like.fy, like.width / 2.0, like.height / 2.0, like.width, like.height, name=name)


def plane_depth(camera: Camera, normal: np.ndarray, offset: float) -> np.ndarray:
    """(H, W) camera z of the plane ``normal . x = offset`` along each pixel centre's ray (inf where
    the ray misses it or meets it behind the camera)."""
    R = camera.R.detach().cpu().double().numpy()
    c = camera.center.detach().cpu().double().numpy()
    cols, rows = np.meshgrid(np.arange(camera.width) + 0.5, np.arange(camera.height) + 0.5)
    rays = np.stack([(cols - camera.cx) / camera.fx, (rows - camera.cy) / camera.fy, np.ones_like(cols)], axis=-1) @ R  # world, z = 1 in camera
    denom = rays @ np.asarray(normal, dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        z = (offset - float(np.asarray(normal) @ c)) / denom
    return np.where(np.isfinite(z) & (z > 0), z, np.inf)


def cameras_to_json(cameras: Sequence[Camera]) -> list[dict]:
    """COLMAP-compatible records: PINHOLE intrinsics, world-to-camera quaternion (w, x, y, z) and translation."""
    from scipy.spatial.transform import Rotation

    out = []
    for c in cameras:
        R = c.R.detach().cpu().double().numpy()
        x, y, z, w = Rotation.from_matrix(R).as_quat()
        out.append({
            "name": c.name, "model": "PINHOLE", "width": c.width, "height": c.height,
            "params": [c.fx, c.fy, c.cx, c.cy], "qvec": [w, x, y, z],
            "tvec": c.t.detach().cpu().double().tolist(), "R": R.tolist(),
        })  # fmt: skip
    return out


def cameras_from_json(path: str | Path) -> list[Camera]:
    """Cameras saved by :func:`cameras_to_json` (rotation from ``R``)."""
    path = Path(path)
    try:
        records = json.loads(path.read_text())["cameras"]
        return [
            Camera(R=torch.tensor(r["R"], dtype=torch.float32), t=torch.tensor(r["tvec"], dtype=torch.float32),
                   fx=r["params"][0], fy=r["params"][1], cx=r["params"][2], cy=r["params"][3], width=r["width"], height=r["height"], name=r["name"])
            for r in records
        ]  # fmt: skip
    except (OSError, ValueError, KeyError, TypeError, IndexError) as e:
        raise InputError(f"not a virtual-camera file ({type(e).__name__})", path) from None
