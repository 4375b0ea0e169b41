"""Declarative scene description: primitives with materials, objects made of primitives, orbit, light and photos.

A :class:`SceneSpec` fixes the geometry of a scene completely; the generator's seed only changes
texture noise, small camera jitter and the photo effects' random draws (:class:`Photo`), so a scene
folder's GT can always be recomputed from its ``scene.json`` (name + seed) and ``gt/cameras.json``.
The realistic family's layouts vary with a layout seed that is part of the scene's name
(``catalogue.py``), so the name alone still fixes the geometry.
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


SUITES = ("dev", "test")


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
    frame: tuple[int, ...] = ()  # ids of the objects the target and fill refer to (empty: all objects)


@dataclass(frozen=True)
class Light:
    """Soft lighting: a hemisphere (sky above, bounce below) plus a wrapped-diffuse key light, no shadows.

    Cast shadows are left out on purpose: they would differ between the object-inclusive and the
    object-free captures (an object's shadow vanishes with it), so a perfect inpainting of the
    revealed surface would be scored as wrong. For the same reason the classic scenes have no
    contact shading (``ao = 0``).

    The realistic family turns on ambient occlusion (``ao`` > 0, ``synth/occlusion.py``), as real
    photos have it: the support darkens where an object touches it and under overhangs, and an
    object's underside darkens near the support. It is computed in each capture's own world, so the
    object-free captures show the support without the removed objects' darkening, as photos taken
    after really removing them do: a method that keeps the darkened support leaves a print.
    """

    sky: tuple[float, float, float] = (0.60, 0.62, 0.66)
    ground: tuple[float, float, float] = (0.30, 0.28, 0.26)
    key: tuple[float, float, float] = (0.55, 0.53, 0.50)
    key_dir: tuple[float, float, float] = (0.45, 0.3, 0.84)  # towards the light, world frame
    wrap: float = 0.4  # wrapped diffuse: soft terminator
    ao: float = 0.0  # ambient-occlusion strength in [0, 1]: irradiance x (1 - ao * occlusion); 0 = off
    ao_radius: float = 0.05  # metres: occluders farther than this along an occlusion ray do not count
    ao_samples: int = 8  # occlusion rays per supersample (3x3 per pixel)

    def __post_init__(self):
        if not 0.0 <= self.ao <= 1.0 or self.ao_radius <= 0 or self.ao_samples < 1:
            raise ValueError(f"ao must be in [0, 1], ao_radius > 0, ao_samples >= 1 (got {self.ao}, {self.ao_radius}, {self.ao_samples})")


@dataclass(frozen=True)
class Photo:
    """What a camera does to the rendered radiance before the image is written (``synth/photo.py``).

    Every effect is off by default (the classic scenes); the realistic family turns them on. Per
    image, drawn from the generator's seed and the image's name: an exposure gain ``2**N(0,
    exposure)`` (``exposure``: standard deviation in stops), white-balance gains of the red and blue
    channels ``exp(N(0, white_balance))`` (green fixed), then sensor noise of standard deviation
    ``sqrt(noise**2 + shot_noise * value)`` (values in [0, 1]), 8-bit quantisation and, when
    ``jpeg_quality`` > 0, a JPEG round trip at that quality (OpenCV); images keep their PNG names.
    """

    exposure: float = 0.0
    white_balance: float = 0.0
    noise: float = 0.0
    shot_noise: float = 0.0
    jpeg_quality: int = 0  # 0 = off, else 1..100

    def __post_init__(self):
        if min(self.exposure, self.white_balance, self.noise, self.shot_noise) < 0:
            raise ValueError("photo effects must be non-negative")
        if not 0 <= self.jpeg_quality <= 100:
            raise ValueError(f"jpeg_quality must be in 0..100, got {self.jpeg_quality}")

    @property
    def active(self) -> bool:
        return any((self.exposure, self.white_balance, self.noise, self.shot_noise, self.jpeg_quality))

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
    photo: Photo = field(default_factory=Photo)
    # where the scene folder's poses and sparse points come from: the generator's truth, or joint
    # pycolmap SfM on its images only (``synth/generate.py``; gt/ keeps the truth either way)
    poses: str = "generator"
    family: str = "classic"  # classic: the ten scenes of the committed tables; realistic: catalogue.py
    # dev: the code may be tuned on it; test: never looked at while tuning (docs/architecture.md)
    suite: str = "dev"

    def __post_init__(self):
        if self.poses not in ("generator", "colmap"):
            raise ValueError(f"poses must be 'generator' or 'colmap', got {self.poses!r}")
        if self.suite not in SUITES:
            raise ValueError(f"suite must be one of {SUITES}, got {self.suite!r}")

    @property
    def removal_targets(self) -> list[int]:
        return [o.id for o in self.objects if o.target]

    def objects_bounds(self) -> tuple[np.ndarray, float]:
        """Sphere enclosing all objects."""
        bs = [o.bounds() for o in self.objects]
        cs = np.asarray([c for c, _ in bs])
        centre = 0.5 * (cs.min(0) + cs.max(0))
        return centre, float(max(np.linalg.norm(c - centre) + r for c, r in bs))
