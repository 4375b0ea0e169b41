"""The frame of a 360° capture, from its training cameras and a trained 3DGS: up direction, look-at
point, orbit radius and the support (ground) plane.

* **up**: the mean of the cameras' "up in the image" axes. Camera y points down in the image
  (``core.camera``), so world up ≈ −(row 1 of R), averaged over the training cameras: around an
  orbit the horizontal parts cancel. Cameras do not need the scene's ``"up"`` (real scenes may lack it).
* **look-at**: the least-squares point nearest all optical axes.
* **R**: the median horizontal distance of the camera centres from the look-at point. Every length
  of the geometric segmenter is a fraction of R, so it does not depend on the scene's units.
* **ground plane**: RANSAC over the centres of opaque Gaussians; a candidate plane must be within
  ``max_tilt_deg`` of up and have the cameras above it (this rejects walls and the ceiling of a room);
  inliers lie within ``tol`` of it; the best one is refitted by least squares on its inliers.
  Heights are signed distances from it along its normal (oriented with up).

Limits: a capture that is not an orbit around something (a forward-facing one) gives a poor up and
look-at; a support that is not one plane (stairs, a lawn on a slope, a round table smaller than
the objects' spread) gives wrong heights.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from inpaint360gs.core.camera import Camera, camera_up, nearest_point_to_axes
from inpaint360gs.core.errors import InputError
from inpaint360gs.core.support import plane_candidates


@dataclass(frozen=True)
class SceneFrame:
    up: np.ndarray  # (3,) unit, the ground plane's normal (oriented with the cameras' up)
    look_at: np.ndarray  # (3,) least-squares point nearest all optical axes
    radius: float  # R: median horizontal camera distance from the look-at point
    camera_distance: float  # median 3D camera distance from the look-at point
    plane_offset: float  # the plane is {x : up . x = plane_offset}
    plane_inliers: int  # Gaussians within the RANSAC tolerance of the refitted plane

    def heights(self, x: np.ndarray) -> np.ndarray:
        """Signed height of points (N, 3) above the ground plane."""
        return x @ self.up - self.plane_offset

    def horizontal_distance(self, x: np.ndarray) -> np.ndarray:
        """Distance of points (N, 3) from the vertical line through the look-at point."""
        d = x - self.look_at
        return np.linalg.norm(d - np.outer(d @ self.up, self.up), axis=1)

    def to_json(self) -> dict:
        """JSON-ready dict of the frame (rounded)."""
        return {
            "up": [round(float(v), 6) for v in self.up],
            "look_at": [round(float(v), 6) for v in self.look_at],
            "radius": round(self.radius, 6),
            "camera_distance": round(self.camera_distance, 6),
            "plane_offset": round(self.plane_offset, 6),
            "plane_inliers": self.plane_inliers,
        }


def _fit_plane(points: np.ndarray) -> tuple[np.ndarray, float]:
    """Least-squares plane (unit normal n, offset d with n.x = d) through ``points``."""
    c = points.mean(0)
    _, _, vt = np.linalg.svd(points - c, full_matrices=False)
    n = vt[2]
    return n, float(n @ c)


def ground_plane(
    points: np.ndarray,
    up: np.ndarray,
    camera_centers: np.ndarray,
    tol: float,
    *,
    tries: int = 400,
    max_tilt_deg: float = 30.0,
    rng: np.random.Generator,
) -> tuple[np.ndarray, float, int]:
    """RANSAC plane (normal, offset, inlier count) over ``points`` (see the module docstring)."""
    if len(points) < 3:
        raise InputError(f"only {len(points)} opaque Gaussians: too few to find the ground plane")
    n, d, ok = plane_candidates(points, up, tries, max_tilt_deg, rng)
    # the cameras look down at the support: their median height above a candidate must be positive
    ok &= np.median(camera_centers @ n.T - d, axis=0) > 0
    best, best_count = -1, 0
    for start in range(0, tries, 50):  # (chunk, points) distance blocks bound the memory
        sel = np.flatnonzero(ok[start : start + 50]) + start
        if not len(sel):
            continue
        counts = (np.abs(points @ n[sel].T - d[sel]) <= tol).sum(0)
        k = int(np.argmax(counts))
        if counts[k] > best_count:
            best, best_count = int(sel[k]), int(counts[k])
    if best < 0 or best_count < 3:
        raise InputError(f"no ground plane within {max_tilt_deg:g}° of the cameras' up direction below the cameras")
    normal, offset = n[best], d[best]
    for _ in range(2):  # refit on the inliers (twice: the first refit can gain inliers)
        inl = np.abs(points @ normal - offset) <= tol
        normal, offset = _fit_plane(points[inl])
        if normal @ up < 0:
            normal, offset = -normal, -offset
    count = int((np.abs(points @ normal - offset) <= tol).sum())
    return normal, offset, count


def scene_frame(
    cameras: Sequence[Camera],
    means: np.ndarray,
    opacities: np.ndarray,
    *,
    min_opacity: float = 0.3,
    tol_frac: float = 0.005,
    tries: int = 400,
    max_tilt_deg: float = 30.0,
    seed: int = 0,
) -> SceneFrame:
    """The frame of a scene from its training ``cameras`` and the trained Gaussians' centres and
    opacities; the plane tolerance is ``tol_frac`` × the median camera distance."""
    if len(cameras) < 2:
        raise InputError(f"the geometric segmenter needs at least 2 training cameras, got {len(cameras)}")
    up = camera_up(cameras)
    look = nearest_point_to_axes(cameras)
    centers = np.stack([c.center.double().numpy() for c in cameras])
    rel = centers - look
    horiz = np.linalg.norm(rel - np.outer(rel @ up, up), axis=1)
    radius = float(np.median(horiz))
    cam_dist = float(np.median(np.linalg.norm(rel, axis=1)))
    if radius <= 0:
        raise InputError("the training cameras do not surround the look-at point (zero orbit radius)")
    pts = means[opacities > min_opacity].astype(np.float64)
    normal, offset, count = ground_plane(pts, up, centers, tol_frac * cam_dist, tries=tries, max_tilt_deg=max_tilt_deg, rng=np.random.default_rng(seed))
    return SceneFrame(up=normal, look_at=look, radius=radius, camera_distance=cam_dist, plane_offset=offset, plane_inliers=count)
