"""Declarative scene description: primitives with materials, objects made of primitives, orbit and light.

A :class:`SceneSpec` fixes the geometry of a scene completely; the generator's seed only changes
texture noise and small camera jitter, so a scene folder's GT can always be recomputed from its
``scene.json`` (name + seed) and ``gt/cameras.json``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from dataset_tools.synth.shapes import N_PARAMS, SHAPES, bounding_radius
from dataset_tools.synth.textures import TEXTURES, Material


def euler_matrix(euler_deg) -> np.ndarray:
    """Local -> parent rotation ``Rz @ Ry @ Rx`` from XYZ Euler angles in degrees."""
    rx, ry, rz = np.radians(np.asarray(euler_deg, dtype=np.float64))
    cx, sx, cy, sy, cz, sz = np.cos(rx), np.sin(rx), np.cos(ry), np.sin(ry), np.cos(rz), np.sin(rz)
    Rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
    Ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
    Rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
    return Rz @ Ry @ Rx


@dataclass(frozen=True)
class Prim:
    """One analytic primitive: ``shape`` with ``params`` (see shapes.N_PARAMS), placed by ``center`` and ``euler``."""

    shape: str
    params: tuple[float, ...]
    material: Material
    center: tuple[float, float, float] = (0.0, 0.0, 0.0)
    euler: tuple[float, float, float] = (0.0, 0.0, 0.0)  # degrees, local -> parent = Rz Ry Rx

    def __post_init__(self):
        if self.shape not in SHAPES:
            raise ValueError(f"unknown shape {self.shape!r}")
        if len(self.params) != N_PARAMS[self.shape] or min(self.params) < 0:
            raise ValueError(f"{self.shape}: expected {N_PARAMS[self.shape]} non-negative parameters, got {self.params}")
        if self.material.kind not in TEXTURES:
            raise ValueError(f"unknown texture kind {self.material.kind!r}")


@dataclass(frozen=True)
class ObjectSpec:
    """An object: primitives in object coordinates, placed at ``position`` and turned by ``yaw`` degrees about +z."""

    id: int  # 1..255, written to the instance masks (0 = background)
    label: str
    shape: str  # a short description of its geometry for objects.json, e.g. "cone+box"
    prims: tuple[Prim, ...]
    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    yaw: float = 0.0
    target: bool = False  # removal target (absent from the object-free test captures)

    def world_prims(self) -> list[tuple[Prim, np.ndarray, np.ndarray]]:
        """(prim, world->local rotation, world centre) for every primitive."""
        Ro = euler_matrix((0.0, 0.0, self.yaw))
        po = np.asarray(self.position, dtype=np.float64)
        out = []
        for p in self.prims:
            R_lw = Ro @ euler_matrix(p.euler)  # local -> world
            c = po + Ro @ np.asarray(p.center, dtype=np.float64)
            out.append((p, R_lw.T, c))
        return out

    def bounds(self) -> tuple[np.ndarray, float]:
        """Centre and radius of a sphere enclosing the object."""
        cs, rs = [], []
        for p, _, c in self.world_prims():
            cs.append(c)
            rs.append(bounding_radius(p.shape, p.params))
        cs = np.asarray(cs)
        centre = 0.5 * (cs.min(0) + cs.max(0))
        radius = float(max(np.linalg.norm(c - centre) + r for c, r in zip(cs, rs)))
        return centre, radius


@dataclass(frozen=True)
class Orbit:
    """Capture path: a 360° orbit about ``target`` whose elevation oscillates in ``elevation`` (degrees).

    ``radius`` None = chosen so the objects' bounding sphere spans ``fill`` of the half vertical field of view.
    """

    target: tuple[float, float, float] | None = None  # None = centre of the objects' bounding sphere
    radius: float | None = None
    fill: float = 0.8
    elevation: tuple[float, float] = (15.0, 45.0)
    cycles: int = 2  # elevation oscillations per turn
    jitter: float = 1.0  # scale of the seed-driven pose jitter


@dataclass(frozen=True)
class Light:
    """Soft lighting: a hemisphere (sky above, bounce below) plus a wrapped-diffuse key light, no shadows.

    Cast shadows are left out on purpose: they would differ between the object-inclusive and the
    object-free captures (an object's shadow vanishes with it), so a perfect inpainting of the
    revealed surface would be scored as wrong. For the same reason there is no contact shading.
    """

    sky: tuple[float, float, float] = (0.60, 0.62, 0.66)
    ground: tuple[float, float, float] = (0.30, 0.28, 0.26)
    key: tuple[float, float, float] = (0.55, 0.53, 0.50)
    key_dir: tuple[float, float, float] = (0.45, 0.3, 0.84)  # towards the light, world frame
    wrap: float = 0.4  # wrapped diffuse: soft terminator


@dataclass(frozen=True)
class SceneSpec:
    """A complete synthetic scene: surroundings (``background`` primitives, world frame), objects, orbit, light."""

    name: str
    description: str
    background: tuple[Prim, ...]
    objects: tuple[ObjectSpec, ...]
    orbit: Orbit = field(default_factory=Orbit)
    light: Light = field(default_factory=Light)
    n_views: int = 56  # object-inclusive captures (full size)
    n_test: int = 16  # object-free captures (full size)
    n_points: int = 8000  # sparse points sampled (before dropping points seen by < 2 views)

    @property
    def removal_targets(self) -> list[int]:
        return [o.id for o in self.objects if o.target]

    def objects_bounds(self) -> tuple[np.ndarray, float]:
        """Sphere enclosing all objects."""
        bs = [o.bounds() for o in self.objects]
        cs = np.asarray([c for c, _ in bs])
        centre = 0.5 * (cs.min(0) + cs.max(0))
        return centre, float(max(np.linalg.norm(c - centre) + r for c, r in bs))
