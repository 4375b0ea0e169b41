"""Building blocks shared by the scene catalogues: the floor convention, segments, rooms, the sky, walls."""

from __future__ import annotations

import numpy as np

from dataset_tools.synth.spec import Prim
from dataset_tools.synth.textures import Material

SINK = 0.002  # objects stand this far into the floor (no coplanar surfaces, no slivers of light)


# ----------------------------------------------------------------------------------------------
# helpers


def segment(shape: str, r: float, p0, p1, material: Material) -> Prim:
    """A cylinder/capsule of radius ``r`` whose axis runs from ``p0`` to ``p1`` (object coordinates)."""
    p0, p1 = np.asarray(p0, dtype=np.float64), np.asarray(p1, dtype=np.float64)
    v = p1 - p0
    L = float(np.linalg.norm(v))
    v = v / L
    ry = np.degrees(np.arctan2(np.hypot(v[0], v[1]), v[2]))  # tilt from +z
    rz = np.degrees(np.arctan2(v[1], v[0]))  # then turn about +z (R = Rz Ry)
    centre = tuple(float(x) for x in 0.5 * (p0 + p1))
    return Prim(shape, (r, 0.5 * L), material, centre, (0.0, float(ry), float(rz)))


def room(floor: Material, walls: Material, half: float = 4.0, height: float = 3.0) -> tuple[Prim, ...]:
    """A closed room: textured walls + ceiling (inside of a box) and a floor rectangle at z = 0."""
    return (
        Prim("box", (half, half, 0.5 * height + 0.05), walls, (0.0, 0.0, 0.5 * height - 0.05)),
        Prim("rect", (half + 0.01, half + 0.01), floor, (0.0, 0.0, 0.0)),
    )


def outdoors(ground: Material, sky: Material, radius: float = 45.0, drop: float = 5.0) -> tuple[Prim, ...]:
    """A sky dome (sphere centred ``drop`` below the ground) and a ground disc reaching just past it (no gap)."""
    rim = np.sqrt(radius**2 - drop**2)
    return (
        Prim("ellipsoid", (radius, radius, radius), sky, (0.0, 0.0, -drop)),
        Prim("disc", (1.02 * rim,), ground, (0.0, 0.0, 0.0)),
    )


# ----------------------------------------------------------------------------------------------
# surroundings

WALLS_WARM = Material("patches", ((0.78, 0.72, 0.62), (0.45, 0.55, 0.68), (0.70, 0.42, 0.35), (0.52, 0.62, 0.45), (0.85, 0.82, 0.75)), scale=0.55, detail=0.18, seed=11, dots=0.35, dot_size=0.5)
WALLS_COOL = Material("patches", ((0.62, 0.68, 0.75), (0.80, 0.76, 0.66), (0.38, 0.45, 0.58), (0.72, 0.55, 0.62), (0.50, 0.60, 0.55)), scale=0.5, detail=0.18, seed=12, dots=0.35, dot_size=0.5)
WALLS_GREEN = Material("patches", ((0.55, 0.66, 0.55), (0.82, 0.80, 0.70), (0.62, 0.50, 0.42), (0.42, 0.50, 0.62)), scale=0.6, detail=0.2, seed=13, dots=0.35, dot_size=0.5)
