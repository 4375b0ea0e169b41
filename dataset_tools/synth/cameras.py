"""Capture poses of a synthetic scene: one shared PINHOLE intrinsic, a 360° orbit and object-free views near it.

Poses follow COLMAP/OpenCV (``x_cam = R x_world + t``; x right, y down, z forward), like
:class:`inpaint360gs.core.camera.Camera`, but in float64 numpy so that GT is exact.
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass

import numpy as np

from dataset_tools.synth.shapes import rows_times
from dataset_tools.synth.spec import SceneSpec

HFOV_DEG = 60.0  # horizontal field of view shared by all captures


@dataclass(frozen=True)
class View:
    """One capture: name, world->camera pose, intrinsics, and whether the removal targets are absent."""

    name: str
    R: np.ndarray  # (3, 3) float64
    t: np.ndarray  # (3,) float64
    fx: float
    fy: float
    cx: float
    cy: float
    width: int
    height: int
    object_free: bool = False

    @property
    def center(self) -> np.ndarray:
        return -self.R.T @ self.t

    @property
    def stem(self) -> str:
        return self.name.rsplit(".", 1)[0]

    def project(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pixel coordinates (n, 2) (pixel (i, j) centre at (j+0.5, i+0.5)) and camera z (n,) of world points."""
        xc = rows_times(x, self.R) + self.t
        z = xc[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            uv = np.stack([self.fx * xc[:, 0] / z + self.cx, self.fy * xc[:, 1] / z + self.cy], -1)
        return uv, z

    def in_view(self, x: np.ndarray) -> np.ndarray:
        """In front of the camera and inside the image rectangle [0, W) x [0, H)."""
        uv, z = self.project(x)
        return (z > 0) & (uv[:, 0] >= 0) & (uv[:, 0] < self.width) & (uv[:, 1] >= 0) & (uv[:, 1] < self.height)

    def rays(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """World ray directions with camera-z component 1 (so the hit ``t`` is the z-depth) through pixel coords."""
        dc = np.stack([(u - self.cx) / self.fx, (v - self.cy) / self.fy, np.ones_like(u)], -1)
        return rows_times(dc, self.R.T)

    def to_json(self) -> dict:
        return {
            "name": self.name,
            "object_free": self.object_free,
            "R": self.R.tolist(),
            "t": self.t.tolist(),
            "center": self.center.tolist(),
        }

    def to_camera(self):
        """The same view as an :class:`inpaint360gs.core.camera.Camera` (float64 tensors)."""
        import torch

        from inpaint360gs.core.camera import Camera

        return Camera(
            R=torch.from_numpy(self.R.copy()), t=torch.from_numpy(self.t.copy()), fx=self.fx, fy=self.fy,
            cx=self.cx, cy=self.cy, width=self.width, height=self.height, name=self.name,
        )

    @staticmethod
    def from_camera(cam, object_free: bool = False) -> "View":
        """Accept an :class:`inpaint360gs.core.camera.Camera` (any dtype/device)."""
        R = np.asarray(cam.R.detach().cpu().double().numpy(), dtype=np.float64)
        t = np.asarray(cam.t.detach().cpu().double().numpy(), dtype=np.float64)
        return View(cam.name or "view", R, t, float(cam.fx), float(cam.fy), float(cam.cx), float(cam.cy),
                    int(cam.width), int(cam.height), object_free)


def intrinsics(width: int, height: int) -> tuple[float, float, float, float]:
    """(fx, fy, cx, cy) for square pixels and :data:`HFOV_DEG` horizontal field of view."""
    f = 0.5 * width / np.tan(np.radians(HFOV_DEG) / 2.0)
    return float(f), float(f), 0.5 * width, 0.5 * height


def look_at(eye: np.ndarray, target: np.ndarray, up=(0.0, 0.0, 1.0)) -> tuple[np.ndarray, np.ndarray]:
    """World->camera (R, t) for a camera at ``eye`` looking at ``target`` with image y pointing away from ``up``."""
    eye = np.asarray(eye, dtype=np.float64)
    z = np.asarray(target, dtype=np.float64) - eye
    z /= np.linalg.norm(z)
    x = np.cross(z, np.asarray(up, dtype=np.float64))
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    R = np.stack([x, y, z])
    return R, -R @ eye


def orbit_geometry(spec: SceneSpec, width: int, height: int) -> tuple[np.ndarray, float]:
    """Look-at target and orbit radius (explicit in the spec, or from the objects' bounding sphere)."""
    centre, rad = spec.objects_bounds()
    target = np.asarray(spec.orbit.target, dtype=np.float64) if spec.orbit.target is not None else centre
    if spec.orbit.radius is not None:
        return target, float(spec.orbit.radius)
    fx, fy, cx, cy = intrinsics(width, height)
    half_vfov = np.arctan(0.5 * height / fy)
    return target, float(rad / np.sin(spec.orbit.fill * half_vfov))


def _rng(spec: SceneSpec, seed: int, stream: int) -> np.random.Generator:
    return np.random.default_rng([int(seed), zlib.crc32(spec.name.encode()), stream])


def capture_views(spec: SceneSpec, n_views: int, n_test: int, width: int, height: int, seed: int) -> list[View]:
    """``IMG_%04d.png`` object-inclusive views in orbit order, then ``test_%04d.png`` object-free views.

    Orbit: azimuth steps evenly round the target while the elevation oscillates between the spec's
    bounds (``cycles`` times per turn); the seed adds small azimuth/elevation/radius/aim jitter.
    Object-free views sit between orbit positions, inside the orbit's elevation band, radii within +-4%.
    """
    fx, fy, cx, cy = intrinsics(width, height)
    target, radius = orbit_geometry(spec, width, height)
    lo, hi = spec.orbit.elevation
    mid, amp = 0.5 * (lo + hi), 0.5 * (hi - lo)
    j = spec.orbit.jitter
    _, obj_r = spec.objects_bounds()
    views = []

    def make(name, az, el, r, aim, free):
        eye = target + r * np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
        R, t = look_at(eye, target + aim)
        views.append(View(name, R, t, fx, fy, cx, cy, width, height, free))

    rng = _rng(spec, seed, 0)
    step = 2.0 * np.pi / n_views
    for k in range(n_views):
        az = k * step + j * rng.uniform(-0.15, 0.15) * step
        el_deg = mid + amp * np.sin(spec.orbit.cycles * k * step) + j * rng.uniform(-1.0, 1.0)
        el = np.radians(np.clip(el_deg, lo, hi))
        r = radius * (1.0 + j * rng.uniform(-0.03, 0.03))
        aim = j * rng.normal(0.0, 0.03 * obj_r, 3)
        make(f"IMG_{k:04d}.png", az, el, r, aim, False)
    rng = _rng(spec, seed, 1)
    tstep = 2.0 * np.pi / n_test
    for k in range(n_test):
        az = (k + 0.5) * tstep + rng.uniform(-0.2, 0.2) * tstep + 0.5 * step
        el = np.radians(rng.uniform(lo + 4.0, hi - 4.0))
        r = radius * rng.uniform(0.96, 1.04)
        aim = rng.normal(0.0, 0.02 * obj_r, 3)
        make(f"test_{k:04d}.png", az, el, r, aim, True)
    return views
