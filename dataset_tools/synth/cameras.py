"""Capture poses of a synthetic scene: one shared PINHOLE intrinsic, a 360° orbit and object-free views near it.

A :class:`View` is a core :class:`~inpaint360gs.core.camera.Camera` (float64 tensors, COLMAP/OpenCV
convention) plus whether the removal targets are absent; the ray casting reads its pose as float64
numpy so that the ground truth is exact and bit-reproducible.
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass

import numpy as np
import torch

from dataset_tools.synth.shapes import rows_times
from dataset_tools.synth.spec import SceneSpec
from inpaint360gs.core.camera import Camera

HFOV_DEG = 60.0  # horizontal field of view shared by all captures


def _f64(x: torch.Tensor) -> np.ndarray:
    return x.detach().cpu().to(torch.float64).numpy()  # no copy for a float64 CPU tensor


@dataclass(frozen=True)
class View:
    """One capture: its camera and whether the removal targets are absent from it."""

    camera: Camera
    object_free: bool = False

    @staticmethod
    def at(name: str, R: np.ndarray, t: np.ndarray, intrinsics: tuple[float, float, float, float], width: int,
           height: int, object_free: bool = False) -> "View":
        """A view at the float64 pose (R, t) with intrinsics (fx, fy, cx, cy)."""
        fx, fy, cx, cy = intrinsics
        R = torch.as_tensor(np.asarray(R, dtype=np.float64))
        t = torch.as_tensor(np.asarray(t, dtype=np.float64))
        return View(Camera(R=R, t=t, fx=fx, fy=fy, cx=cx, cy=cy, width=width, height=height, name=name), object_free)

    @property
    def name(self) -> str:
        return self.camera.name

    @property
    def stem(self) -> str:
        return self.name.rsplit(".", 1)[0]

    @property
    def R(self) -> np.ndarray:
        """(3, 3) float64 world -> camera rotation."""
        return _f64(self.camera.R)

    @property
    def t(self) -> np.ndarray:
        """(3,) float64 world -> camera translation."""
        return _f64(self.camera.t)

    @property
    def center(self) -> np.ndarray:
        """Camera centre ``-R^T t`` in float64 numpy (torch's matmul rounds differently: GT must not change)."""
        return -self.R.T @ self.t

    def project(self, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Pixel coordinates (n, 2) (pixel (i, j) centre at (j+0.5, i+0.5)) and camera z (n,) of world points."""
        c = self.camera
        xc = rows_times(x, self.R) + self.t
        z = xc[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            uv = np.stack([c.fx * xc[:, 0] / z + c.cx, c.fy * xc[:, 1] / z + c.cy], -1)
        return uv, z

    def in_view(self, x: np.ndarray) -> np.ndarray:
        """In front of the camera and inside the image rectangle [0, W) x [0, H)."""
        uv, z = self.project(x)
        return (z > 0) & (uv[:, 0] >= 0) & (uv[:, 0] < self.camera.width) & (uv[:, 1] >= 0) & (uv[:, 1] < self.camera.height)

    def rays(self, u: np.ndarray, v: np.ndarray) -> np.ndarray:
        """World ray directions with camera-z component 1 (so the hit ``t`` is the z-depth) through pixel coords."""
        c = self.camera
        dc = np.stack([(u - c.cx) / c.fx, (v - c.cy) / c.fy, np.ones_like(u)], -1)
        return rows_times(dc, self.R.T)

    def to_json(self) -> dict:
        return {
            "name": self.name,
            "object_free": self.object_free,
            "R": self.R.tolist(),
            "t": self.t.tolist(),
            "center": self.center.tolist(),
        }


def intrinsics(width: int, height: int) -> tuple[float, float, float, float]:
    """(fx, fy, cx, cy) for square pixels and :data:`HFOV_DEG` horizontal field of view."""
    f = 0.5 * width / np.tan(np.radians(HFOV_DEG) / 2.0)
    return float(f), float(f), 0.5 * width, 0.5 * height


def look_at(eye: np.ndarray, target: np.ndarray, up=(0.0, 0.0, 1.0)) -> tuple[np.ndarray, np.ndarray]:
    """World->camera (R, t) for a camera at ``eye`` looking at ``target`` with image y pointing away from ``up``.

    :meth:`Camera.look_at <inpaint360gs.core.camera.Camera.look_at>` in float64 numpy: the generator's
    poses must stay bit-identical, and torch's float64 matmul rounds ``t`` differently.
    """
    eye = np.asarray(eye, dtype=np.float64)
    z = np.asarray(target, dtype=np.float64) - eye
    z /= np.linalg.norm(z)
    x = np.cross(z, np.asarray(up, dtype=np.float64))
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    R = np.stack([x, y, z])
    return R, -R @ eye


def orbit_geometry(spec: SceneSpec, width: int, height: int) -> tuple[np.ndarray, float]:
    """Look-at target and orbit radius (explicit in the spec, or from the bounding sphere of the
    objects, or of those the orbit's ``frame`` names)."""
    if spec.orbit.frame:
        bs = [o.bounds() for o in spec.objects if o.id in spec.orbit.frame]
        cs = np.asarray([c for c, _ in bs])
        centre = 0.5 * (cs.min(0) + cs.max(0))
        rad = float(max(np.linalg.norm(c - centre) + r for c, r in bs))
    else:
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
    K = intrinsics(width, height)
    target, radius = orbit_geometry(spec, width, height)
    lo, hi = spec.orbit.elevation
    mid, amp = 0.5 * (lo + hi), 0.5 * (hi - lo)
    j = spec.orbit.jitter
    _, obj_r = spec.objects_bounds()
    views = []

    def make(name, az, el, r, aim, free):
        eye = target + r * np.array([np.cos(el) * np.cos(az), np.cos(el) * np.sin(az), np.sin(el)])
        R, t = look_at(eye, target + aim)
        views.append(View.at(name, R, t, K, width, height, free))

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
