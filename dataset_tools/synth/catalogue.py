"""The named scenes of the embedded benchmark, modelled on the Inpaint360GS dataset (paper Sec. 3.5, supp. Sec. A).

The paper's 11 real scenes are 7 single-object (e.g. red/yellow cone, cube, bear, bag, car) and 4
multi-object ones with occlusions (e.g. fruits, doppelherz, toys, garden toys), indoors and outdoors.
Here: 7 single-object scenes (one with a thin structure: ``stool``), 3 multi-object scenes with
mutual occlusion where some objects are removal targets and others stay (``fruits``, ``toys``,
``garden``); ``garden`` is the outdoor one, with a large flat textured lawn and a wider orbit.
Units are metres; the floor is z = 0 and objects sit 2 mm into it, so no surface is coplanar with it.
The generator's seed changes only texture noise and small camera jitter, never the geometry.
Textures carry blob-like detail (knots, spots, veins) because at 128x96 SIFT finds too few features
on smooth patterns for joint SfM of the captures to register every view.

These ten are the ``classic`` family (the committed tables; ``all`` on the command line). The
``realistic`` family (``realistic.py``) adds scenes with real photos' effects. Every scene belongs to
a suite (docs/architecture.md, "Development and test scenes"): ``dev`` (the classic ten and the
realistic dev layouts: the code may be tuned on them) or ``test`` (realistic layouts from other
seeds, never looked at while tuning).
"""

from __future__ import annotations

import numpy as np

from dataset_tools.synth.parts import SINK, WALLS_COOL, WALLS_GREEN, WALLS_WARM, outdoors, room, segment  # noqa: F401 (shared with realistic.py)
from dataset_tools.synth.spec import SUITES, ObjectSpec, Orbit, Prim, SceneSpec
from dataset_tools.synth.textures import Material

FLOOR_PLANKS = Material("planks", ((0.55, 0.40, 0.27), (0.72, 0.56, 0.38), (0.22, 0.15, 0.10)), scale=0.12, detail=0.08, seed=21)
FLOOR_TILES = Material("tiles", ((0.70, 0.68, 0.64), (0.52, 0.55, 0.58), (0.62, 0.56, 0.48), (0.30, 0.29, 0.28)), scale=0.25, detail=0.1, seed=22)
FLOOR_CARPET = Material("noise", ((0.42, 0.36, 0.52), (0.58, 0.50, 0.64), (0.30, 0.44, 0.50)), scale=0.08, detail=0.2, seed=23,
                        dots=0.45, dot_size=0.2, dot_colors=((0.92, 0.88, 0.75), (0.20, 0.12, 0.28), (0.85, 0.55, 0.30)))
FLOOR_STONE = Material("tiles", ((0.62, 0.60, 0.55), (0.55, 0.52, 0.50), (0.70, 0.66, 0.60), (0.40, 0.36, 0.32)), scale=0.4, detail=0.15, seed=24)
GRASS = Material("noise", ((0.24, 0.42, 0.16), (0.40, 0.55, 0.22), (0.45, 0.38, 0.22)), scale=0.35, detail=0.25, seed=25, dots=0.5, dot_size=0.4,
                 dot_colors=((0.95, 0.95, 0.92), (0.95, 0.85, 0.25), (0.60, 0.45, 0.85), (0.55, 0.52, 0.50)))
SKY = Material("sky", ((0.72, 0.80, 0.88), (0.45, 0.60, 0.82), (0.95, 0.95, 0.97), (0.12, 0.24, 0.10), (0.26, 0.38, 0.16)), scale=1.0, detail=0.0, seed=26, unlit=True)


# ----------------------------------------------------------------------------------------------
# objects (object coordinates: base on z = -SINK, roughly centred on the z axis)


def traffic_cone(oid: int, label: str, body: tuple, band=(0.95, 0.95, 0.92), **kw) -> ObjectSpec:
    base_m = Material("noise", (tuple(c * 0.7 for c in body), tuple(c * 0.9 for c in body), (0.2, 0.2, 0.2)), scale=0.03, detail=0.15, seed=31)
    body_m = Material("stripes", (body, band, (0.35, 0.3, 0.25)), scale=0.11, axis=2, duty=0.62, detail=0.12, seed=32)
    prims = (
        Prim("box", (0.17, 0.17, 0.012), base_m, (0.0, 0.0, 0.012 - SINK)),
        Prim("cone", (0.13, 0.022, 0.25), body_m, (0.0, 0.0, 0.27)),
    )
    return ObjectSpec(oid, label, "cone+box", prims, **kw)


def cube(oid: int, **kw) -> ObjectSpec:
    m = Material("checker", ((0.92, 0.78, 0.25), (0.20, 0.35, 0.70), (0.80, 0.25, 0.22)), scale=0.085, detail=0.12, seed=41)
    return ObjectSpec(oid, "cube", "box", (Prim("box", (0.17, 0.17, 0.17), m, (0.0, 0.0, 0.17 - SINK)),), **kw)


def teddy_bear(oid: int, **kw) -> ObjectSpec:
    fur = Material("noise", ((0.50, 0.33, 0.18), (0.66, 0.47, 0.28), (0.38, 0.24, 0.14)), scale=0.035, detail=0.22, seed=51)
    light_fur = Material("noise", ((0.80, 0.66, 0.48), (0.70, 0.55, 0.38)), scale=0.02, detail=0.15, seed=52)
    dark = Material("noise", ((0.06, 0.05, 0.05), (0.15, 0.12, 0.10)), scale=0.01, detail=0.1, seed=53)
    prims = [
        Prim("ellipsoid", (0.15, 0.13, 0.19), fur, (0.0, 0.0, 0.19)),
        Prim("ellipsoid", (0.09, 0.11, 0.12), light_fur, (0.07, 0.0, 0.18)),
        Prim("ellipsoid", (0.115, 0.115, 0.11), fur, (0.0, 0.0, 0.44)),
        Prim("ellipsoid", (0.05, 0.045, 0.04), light_fur, (0.095, 0.0, 0.42)),
        Prim("ellipsoid", (0.017, 0.022, 0.014), dark, (0.142, 0.0, 0.437)),
        Prim("ellipsoid", (0.013, 0.013, 0.013), dark, (0.095, 0.045, 0.475)),
        Prim("ellipsoid", (0.013, 0.013, 0.013), dark, (0.095, -0.045, 0.475)),
        Prim("ellipsoid", (0.025, 0.045, 0.045), fur, (0.0, 0.085, 0.53)),
        Prim("ellipsoid", (0.025, 0.045, 0.045), fur, (0.0, -0.085, 0.53)),
        segment("capsule", 0.045, (0.02, 0.12, 0.30), (0.10, 0.17, 0.17), fur),
        segment("capsule", 0.045, (0.02, -0.12, 0.30), (0.10, -0.17, 0.17), fur),
        segment("capsule", 0.055, (0.02, 0.08, 0.055 - SINK), (0.16, 0.09, 0.055 - SINK), fur),
        segment("capsule", 0.055, (0.02, -0.08, 0.055 - SINK), (0.16, -0.09, 0.055 - SINK), fur),
    ]
    return ObjectSpec(oid, "bear", "ellipsoids+capsules", tuple(prims), **kw)


def bag(oid: int, **kw) -> ObjectSpec:
    tartan = Material("checker", ((0.62, 0.16, 0.14), (0.15, 0.28, 0.22), (0.85, 0.78, 0.45)), scale=0.05, detail=0.12, seed=61)
    leather = Material("noise", ((0.30, 0.18, 0.10), (0.42, 0.27, 0.15)), scale=0.02, detail=0.2, seed=62)
    prims = (
        Prim("box", (0.2, 0.08, 0.15), tartan, (0.0, 0.0, 0.15 - SINK)),
        Prim("box", (0.12, 0.012, 0.07), leather, (0.0, 0.078, 0.13)),
        Prim("torus", (0.11, 0.013), leather, (0.0, 0.0, 0.29), (90.0, 0.0, 0.0)),
    )
    return ObjectSpec(oid, "bag", "box+torus", prims, **kw)


def toy_car(oid: int, **kw) -> ObjectSpec:
    paint = Material("stripes", ((0.78, 0.12, 0.10), (0.95, 0.92, 0.85), (0.55, 0.08, 0.08)), scale=0.06, axis=0, duty=0.8, detail=0.1, seed=71)
    glass = Material("noise", ((0.35, 0.50, 0.62), (0.60, 0.72, 0.80)), scale=0.03, detail=0.1, seed=72)
    tyre = Material("stripes", ((0.10, 0.10, 0.10), (0.30, 0.30, 0.30)), scale=0.015, axis=0, duty=0.7, detail=0.1, seed=73)
    lamp = Material("noise", ((0.95, 0.85, 0.35), (1.0, 0.95, 0.6)), scale=0.01, detail=0.05, seed=74)
    prims = [
        Prim("box", (0.22, 0.1, 0.05), paint, (0.0, 0.0, 0.105)),
        Prim("box", (0.11, 0.085, 0.045), glass, (-0.03, 0.0, 0.195)),
        Prim("ellipsoid", (0.012, 0.02, 0.012), lamp, (0.22, 0.06, 0.115)),
        Prim("ellipsoid", (0.012, 0.02, 0.012), lamp, (0.22, -0.06, 0.115)),
    ]
    for x in (-0.14, 0.14):
        for y in (-0.1, 0.1):
            prims.append(Prim("cylinder", (0.055, 0.025), tyre, (x, y, 0.055 - SINK), (90.0, 0.0, 0.0)))
    return ObjectSpec(oid, "car", "boxes+cylinders", tuple(prims), **kw)


def stool(oid: int, **kw) -> ObjectSpec:
    """Seat on four splayed legs of 6 mm radius (1-2 px wide at the benchmark resolution) with rungs."""
    wood = Material("wood", ((0.62, 0.45, 0.28), (0.45, 0.30, 0.17)), scale=0.05, axis=0, detail=0.1, seed=81)
    legs = Material("noise", ((0.20, 0.20, 0.22), (0.35, 0.33, 0.32)), scale=0.02, detail=0.1, seed=82)
    prims = [Prim("cylinder", (0.16, 0.018), wood, (0.0, 0.0, 0.45))]
    top = 0.09
    foot = 0.13
    corners = [(sx, sy) for sx in (-1, 1) for sy in (-1, 1)]
    for sx, sy in corners:
        prims.append(segment("cylinder", 0.006, (sx * top, sy * top, 0.44), (sx * foot, sy * foot, -SINK), legs))
    z = 0.16
    s = top + (foot - top) * (0.44 - z) / 0.44
    for (ax, ay), (bx, by) in (((-1, -1), (1, -1)), ((1, -1), (1, 1)), ((1, 1), (-1, 1)), ((-1, 1), (-1, -1))):
        prims.append(segment("cylinder", 0.005, (ax * s, ay * s, z), (bx * s, by * s, z), legs))
    return ObjectSpec(oid, "stool", "cylinders (thin legs)", tuple(prims), **kw)


def fruit(oid: int, label: str, kind: str, **kw) -> ObjectSpec:
    if kind == "apple":
        m = Material("noise", ((0.72, 0.10, 0.08), (0.85, 0.65, 0.20), (0.45, 0.05, 0.05)), scale=0.02, detail=0.12, seed=91)
        prims = (Prim("ellipsoid", (0.055, 0.055, 0.05), m, (0.0, 0.0, 0.05 - SINK)),
                 segment("capsule", 0.003, (0.0, 0.0, 0.095), (0.006, 0.0, 0.118), Material("noise", ((0.3, 0.2, 0.1), (0.4, 0.3, 0.15)), 0.01, seed=92)))
        shape = "ellipsoid+capsule"
    elif kind == "orange":
        m = Material("noise", ((0.95, 0.52, 0.08), (0.85, 0.40, 0.05), (0.98, 0.65, 0.20)), scale=0.012, detail=0.15, seed=93)
        prims = (Prim("ellipsoid", (0.06, 0.06, 0.057), m, (0.0, 0.0, 0.057 - SINK)),)
        shape = "ellipsoid"
    elif kind == "lemon":
        m = Material("noise", ((0.95, 0.85, 0.20), (0.85, 0.75, 0.10), (0.70, 0.75, 0.25)), scale=0.015, detail=0.12, seed=94)
        prims = (Prim("ellipsoid", (0.06, 0.04, 0.04), m, (0.0, 0.0, 0.04 - SINK), (0.0, 0.0, 0.0)),)
        shape = "ellipsoid"
    elif kind == "pear":
        m = Material("noise", ((0.55, 0.70, 0.22), (0.70, 0.75, 0.30), (0.50, 0.45, 0.18)), scale=0.015, detail=0.15, seed=95)
        prims = (Prim("ellipsoid", (0.048, 0.048, 0.045), m, (0.0, 0.0, 0.045 - SINK)),
                 Prim("ellipsoid", (0.03, 0.03, 0.04), m, (0.0, 0.0, 0.1)))
        shape = "ellipsoids"
    elif kind == "banana":
        m = Material("stripes", ((0.95, 0.82, 0.22), (0.80, 0.70, 0.18), (0.40, 0.30, 0.10)), scale=0.02, axis=0, duty=0.8, detail=0.1, seed=96)
        prims = (segment("capsule", 0.02, (-0.08, -0.02, 0.02), (0.0, 0.0, 0.024), m),
                 segment("capsule", 0.02, (0.0, 0.0, 0.024), (0.07, -0.035, 0.02), m))
        shape = "capsules"
    else:
        raise ValueError(kind)
    return ObjectSpec(oid, label, shape, prims, **kw)


def plate(oid: int, **kw) -> ObjectSpec:
    m = Material("stripes", ((0.92, 0.92, 0.88), (0.25, 0.35, 0.65), (0.75, 0.75, 0.72)), scale=0.05, axis=0, duty=0.85, detail=0.08, seed=97)
    return ObjectSpec(oid, "plate", "cylinder", (Prim("cylinder", (0.21, 0.008), m, (0.0, 0.0, 0.008 - SINK)),), **kw)


def ring_stacker(oid: int, **kw) -> ObjectSpec:
    wood = Material("wood", ((0.80, 0.62, 0.40), (0.62, 0.45, 0.28)), scale=0.04, axis=2, detail=0.08, seed=101)
    cols = [((0.85, 0.15, 0.12), (0.95, 0.40, 0.30)), ((0.95, 0.80, 0.15), (0.85, 0.60, 0.10)), ((0.15, 0.35, 0.80), (0.35, 0.60, 0.90))]
    prims = [Prim("cylinder", (0.075, 0.015), wood, (0.0, 0.0, 0.015 - SINK)), Prim("cylinder", (0.012, 0.11), wood, (0.0, 0.0, 0.13))]
    for k, ((R, r, z), c) in enumerate(zip(((0.05, 0.022, 0.052), (0.042, 0.02, 0.094), (0.034, 0.018, 0.132)), cols)):
        prims.append(Prim("torus", (R, r), Material("noise", c, scale=0.015, detail=0.15, seed=102 + k), (0.0, 0.0, z)))
    prims.append(Prim("ellipsoid", (0.025, 0.025, 0.025), Material("noise", ((0.2, 0.65, 0.3), (0.4, 0.8, 0.4)), 0.01, seed=106), (0.0, 0.0, 0.245)))
    return ObjectSpec(oid, "ring stacker", "cylinders+tori+sphere", tuple(prims), **kw)


def ball(oid: int, radius: float, colors, label: str = "ball", scale: float = 0.05, **kw) -> ObjectSpec:
    m = Material("checker", colors, scale=scale, detail=0.1, seed=111 + oid)
    return ObjectSpec(oid, label, "sphere", (Prim("ellipsoid", (radius,) * 3, m, (0.0, 0.0, radius - SINK)),), **kw)


def block_tower(oid: int, **kw) -> ObjectSpec:
    ms = [Material("checker", c, scale=0.025, detail=0.1, seed=121 + k) for k, c in enumerate([
        ((0.20, 0.60, 0.30), (0.90, 0.90, 0.80), (0.1, 0.3, 0.15)),
        ((0.85, 0.45, 0.15), (0.95, 0.90, 0.75), (0.5, 0.2, 0.1)),
        ((0.55, 0.25, 0.65), (0.90, 0.85, 0.90), (0.3, 0.1, 0.4)),
    ])]
    prims = (
        Prim("box", (0.05, 0.05, 0.05), ms[0], (0.0, 0.0, 0.05 - SINK)),
        Prim("box", (0.042, 0.042, 0.042), ms[1], (0.0, 0.0, 0.139), (0.0, 0.0, 30.0)),
        Prim("box", (0.034, 0.034, 0.034), ms[2], (0.0, 0.0, 0.213), (0.0, 0.0, 55.0)),
    )
    return ObjectSpec(oid, "block tower", "boxes", prims, **kw)


def garden_gnome(oid: int, **kw) -> ObjectSpec:
    coat = Material("noise", ((0.15, 0.30, 0.65), (0.25, 0.42, 0.78), (0.10, 0.20, 0.45)), scale=0.04, detail=0.15, seed=131)
    skin = Material("noise", ((0.92, 0.72, 0.60), (0.85, 0.62, 0.50)), scale=0.02, detail=0.1, seed=132)
    beard = Material("noise", ((0.95, 0.95, 0.93), (0.80, 0.80, 0.78)), scale=0.015, detail=0.15, seed=133)
    hat = Material("stripes", ((0.80, 0.12, 0.10), (0.60, 0.08, 0.06), (0.95, 0.85, 0.3)), scale=0.05, axis=2, duty=0.7, detail=0.1, seed=134)
    boots = Material("noise", ((0.25, 0.15, 0.08), (0.35, 0.22, 0.12)), scale=0.02, detail=0.15, seed=135)
    prims = (
        Prim("box", (0.11, 0.09, 0.03), boots, (0.02, 0.0, 0.03 - SINK)),
        Prim("cone", (0.13, 0.09, 0.15), coat, (0.0, 0.0, 0.2)),
        Prim("ellipsoid", (0.085, 0.085, 0.08), skin, (0.0, 0.0, 0.41)),
        Prim("ellipsoid", (0.06, 0.08, 0.08), beard, (0.05, 0.0, 0.36)),
        Prim("cone", (0.09, 0.006, 0.14), hat, (0.0, 0.0, 0.59)),
    )
    return ObjectSpec(oid, "garden gnome", "cones+ellipsoids+box", prims, **kw)


def watering_can(oid: int, **kw) -> ObjectSpec:
    metal = Material("noise", ((0.25, 0.55, 0.35), (0.35, 0.65, 0.42), (0.55, 0.55, 0.50)), scale=0.04, detail=0.2, seed=141)
    prims = (
        Prim("cylinder", (0.11, 0.12), metal, (0.0, 0.0, 0.12 - SINK)),
        segment("capsule", 0.016, (0.08, 0.0, 0.08), (0.27, 0.0, 0.30), metal),
        Prim("torus", (0.08, 0.013), metal, (-0.02, 0.0, 0.27), (90.0, 0.0, 0.0)),
    )
    return ObjectSpec(oid, "watering can", "cylinder+capsule+torus", prims, **kw)


def potted_plant(oid: int, **kw) -> ObjectSpec:
    pot = Material("stripes", ((0.72, 0.38, 0.22), (0.60, 0.30, 0.18), (0.45, 0.25, 0.15)), scale=0.04, axis=2, duty=0.75, detail=0.12, seed=151)
    soil = Material("noise", ((0.20, 0.14, 0.09), (0.30, 0.22, 0.14)), scale=0.01, detail=0.2, seed=152)
    leaf = Material("noise", ((0.15, 0.45, 0.12), (0.30, 0.60, 0.20), (0.55, 0.65, 0.20)), scale=0.03, detail=0.15, seed=153)
    stem = Material("noise", ((0.25, 0.40, 0.12), (0.30, 0.45, 0.15)), scale=0.01, seed=154)
    prims = [Prim("cone", (0.09, 0.12, 0.12), pot, (0.0, 0.0, 0.12 - SINK)), Prim("cylinder", (0.11, 0.005), soil, (0.0, 0.0, 0.225))]
    for k in range(6):
        a = 2.0 * np.pi * k / 6.0 + 0.3
        tip = (0.16 * np.cos(a), 0.16 * np.sin(a), 0.42 + 0.05 * (k % 2))
        prims.append(segment("cylinder", 0.005, (0.0, 0.0, 0.22), tip, stem))
        prims.append(Prim("ellipsoid", (0.07, 0.035, 0.012), leaf, tip, (0.0, -20.0, float(np.degrees(a)))))
    return ObjectSpec(oid, "potted plant", "cone+cylinders+ellipsoids", tuple(prims), **kw)


# ----------------------------------------------------------------------------------------------
# the catalogue


def _build() -> dict[str, SceneSpec]:
    s: list[SceneSpec] = []
    s.append(SceneSpec(
        "cone", "single red traffic cone on wooden floor boards (paper: red cone)",
        room(FLOOR_PLANKS, WALLS_WARM), (traffic_cone(1, "red cone", (0.85, 0.18, 0.10), target=True),),
    ))
    s.append(SceneSpec(
        "ycone", "single yellow traffic cone on a tiled floor (paper: yellow cone)",
        room(FLOOR_TILES, WALLS_COOL), (traffic_cone(1, "yellow cone", (0.92, 0.78, 0.12), band=(0.15, 0.15, 0.15), target=True, yaw=20.0),),
    ))
    s.append(SceneSpec(
        "cube", "single checkered cube on a tiled floor (paper: cube)",
        room(FLOOR_STONE, WALLS_GREEN), (cube(1, target=True, yaw=25.0),),
    ))
    s.append(SceneSpec(
        "bear", "single teddy bear on a carpet (paper: bear)",
        room(FLOOR_CARPET, WALLS_WARM), (teddy_bear(1, target=True, yaw=-30.0),),
    ))
    s.append(SceneSpec(
        "bag", "single tartan bag with a ring handle (torus) on floor boards (paper: bag)",
        room(FLOOR_PLANKS, WALLS_COOL), (bag(1, target=True, yaw=15.0),),
    ))
    s.append(SceneSpec(
        "car", "single toy car on a tiled floor (paper: car)",
        room(FLOOR_TILES, WALLS_GREEN), (toy_car(1, target=True, yaw=40.0),),
    ))
    s.append(SceneSpec(
        "stool", "single stool with 1-2 px wide legs and rungs (thin structure)",
        room(FLOOR_TILES, WALLS_WARM), (stool(1, target=True, yaw=10.0),),
    ))
    s.append(SceneSpec(
        "fruits", "fruits on a plate; apple and orange are removed, lemon, pear, banana and plate stay; mutual occlusion (paper: fruits)",
        room(FLOOR_PLANKS, WALLS_GREEN),
        (
            plate(1),
            fruit(2, "apple", "apple", position=(0.06, 0.05, 0.016), target=True),
            fruit(3, "orange", "orange", position=(-0.07, -0.04, 0.016), target=True),
            fruit(4, "lemon", "lemon", position=(0.05, -0.11, 0.016), yaw=30.0),
            fruit(5, "pear", "pear", position=(-0.08, 0.10, 0.016)),
            fruit(6, "banana", "banana", position=(0.13, 0.12, 0.016), yaw=-60.0),
        ),
        orbit=Orbit(fill=0.55),
    ))
    s.append(SceneSpec(
        "toys", "three toys in a row: ring stacker and ball are removed, the block tower stays; they occlude each other (paper: toys)",
        room(FLOOR_TILES, WALLS_WARM),
        (
            ring_stacker(1, position=(0.0, 0.0, 0.0), target=True),
            ball(2, 0.085, ((0.95, 0.85, 0.20), (0.15, 0.45, 0.85), (0.9, 0.2, 0.2)), position=(0.2, 0.07, 0.0), target=True),
            block_tower(3, position=(-0.19, -0.08, 0.0), yaw=15.0),
        ),
    ))
    s.append(SceneSpec(
        "garden", "outdoor lawn with garden toys (gnome, watering can removed; plant and football stay), wide orbit (paper: garden toys)",
        outdoors(GRASS, SKY) + (
            Prim("cylinder", (0.22, 0.01), FLOOR_STONE, (0.45, -0.55, 0.0)),
            Prim("cylinder", (0.2, 0.01), FLOOR_STONE, (-0.6, -0.35, 0.0)),
            Prim("cylinder", (0.24, 0.01), FLOOR_STONE, (-0.2, 0.75, 0.0)),
        ),
        (
            garden_gnome(1, position=(0.0, 0.0, 0.0), yaw=-20.0, target=True),
            watering_can(2, position=(0.45, 0.3, 0.0), yaw=140.0, target=True),
            potted_plant(3, position=(-0.45, 0.3, 0.0)),
            ball(4, 0.11, ((0.95, 0.95, 0.95), (0.1, 0.1, 0.1)), label="football", scale=0.06, position=(0.15, -0.5, 0.0)),
        ),
        orbit=Orbit(radius=2.6, target=(0.0, 0.0, 0.2), elevation=(15.0, 40.0)),
    ))
    return {spec.name: spec for spec in s}


def _catalogue() -> dict[str, SceneSpec]:
    from dataset_tools.synth.realistic import realistic_scenes

    out = _build()
    for spec in realistic_scenes():
        if spec.name in out:
            raise ValueError(f"two catalogue scenes named {spec.name!r}")
        out[spec.name] = spec
    return out


SCENES: dict[str, SceneSpec] = _catalogue()
# ``all``: the ten scenes of the committed tables (what `all` meant before the realistic family)
BENCHMARK_SCENES: tuple[str, ...] = tuple(sorted(n for n, s in SCENES.items() if s.family == "classic"))


# Scenes whose unseen share (visibility.unseen_shares: mean over the test views of the share of
# pixels under the unseen mask; full size, seed 0) is below visibility.MIN_UNSEEN_SHARE: their
# masked and ROI scores rest on few pixels (bear 0.85 %, toys 0.68 %, garden 0.55 %, fruits 0.028 %,
# stool 0.016 %; docs/guide.md, "The synthetic benchmark"). Every realistic scene is above it.
LOW_UNSEEN_SHARE: tuple[str, ...] = ("bear", "fruits", "garden", "stool", "toys")


def suite_scenes(suite: str) -> list[str]:
    """Names of the scenes of ``suite`` (dev | test), sorted."""
    from inpaint360gs.core.errors import InputError

    if suite not in SUITES:
        raise InputError(f"unknown suite {suite!r} (known: {', '.join(SUITES)})")
    return sorted(n for n, s in SCENES.items() if s.suite == suite)


def scene_spec(name: str) -> SceneSpec:
    """The catalogue entry ``name``; unknown names raise :class:`InputError` listing the known ones."""
    from inpaint360gs.core.errors import InputError

    if name not in SCENES:
        raise InputError(f"unknown synthetic scene {name!r} (known: {', '.join(sorted(SCENES))})")
    return SCENES[name]
