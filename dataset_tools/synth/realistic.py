"""The realistic scene family: what real captures do to the method, with the generator's exact ground truth.

Real 360° photos of an object on a table (the Mip-NeRF 360 kitchen is the model: a toy bulldozer on
two woven placemats on a wooden table) differ from the classic scenes in ways that matter for
removal and inpainting:

* soft contact shadows: the support darkens where the object touches it and under overhangs
  (``Light.ao``; absent from the object-free photos, as after really taking the object away);
* objects with dark undersides a few millimetres above the support (a vehicle's tracks and chassis);
* supports with structure that runs under the object: woven mats with a visible weave, stripes and
  hems, two mats meeting under the object, wood grain;
* photos that differ in exposure and white balance, carry sensor noise and JPEG artefacts (``Photo``);
* poses and points from structure from motion rather than the truth (``poses="colmap"``);
* low camera elevations, and sparse captures of about 25 photos (the ``-sparse`` variants).

Four layouts, each drawn from a layout seed: ``dozer`` (a toy bulldozer with dark tracks and
chassis on two placemats whose seam crosses under it, on a wooden table), ``teapot`` (a teapot on
wood grain against a bread box that stays: a backdrop), ``duck`` (a small rubber duck on the edge of
a woven rug), ``plush`` (a plush bear that fills much of the frame, on a plain sheet in a plain
room: the capture where structure from motion finds few points, mostly on the toy, and the
backdrop gives segmentation and densification little to work with). Scene names carry the random stream and the layout seed (``dozer-dev1``,
``dozer-test3``, ``dozer-test3-sparse``); the dev and test streams are disjoint, so a test scene's
positions, angles, colours and seams are never those of a dev scene. The test stream's first seeds
(``*-test1``, ``*-test2``, ``*-test1-sparse``) were run and looked at while settings changed: they
are development scenes now, under their old names (:data:`LOOKED_AT`); the test suite is the test
stream's later seeds (docs/architecture.md, "Development and test scenes").
"""

from __future__ import annotations

import zlib

import numpy as np

from dataset_tools.synth.parts import SINK, WALLS_COOL, WALLS_GREEN, WALLS_WARM, room, segment
from dataset_tools.synth.spec import Light, ObjectSpec, Orbit, Photo, Prim, SceneSpec
from dataset_tools.synth.textures import Material

FAMILY = "realistic"
LAYOUTS = ("dozer", "teapot", "duck", "plush")
SEEDS = {"dev": (1, 2), "test": (1, 2, 3, 4)}  # layout seeds per random stream (separate streams)
SPARSE = {"dev": (1,), "test": (1, 3, 4)}  # which of them also get a ~25-photo variant
# the plain-backdrop layout is sparse by nature (few SfM points): one dev and one test scene, no ~25-photo variant
LAYOUT_SEEDS = {"plush": {"dev": (1,), "test": (3,)}}
LAYOUT_SPARSE = {"plush": {"dev": (), "test": ()}}
# layout seeds of the test stream that were run and looked at while settings changed: development scenes now
LOOKED_AT = {"test": (1, 2)}
SPARSE_VIEWS = 25  # object-inclusive photos of a sparse variant (a real hand-held capture's count)

# Camera effects of the family: ~0.1 stop exposure and 3 % white-balance spread, noise of ~2/255
# plus shot noise, JPEG at quality 90 (a phone's default range).
PHOTO = Photo(exposure=0.1, white_balance=0.03, noise=0.008, shot_noise=0.0004, jpeg_quality=90)
ORBIT_ELEVATION = (8.0, 32.0)  # degrees: low, as photos taken around a table
MAT_T = 0.003  # placemat thickness (metres)


def _rng(layout: str, suite: str, k: int) -> np.random.Generator:
    return np.random.default_rng([zlib.crc32(f"{FAMILY}/{layout}/{suite}".encode()), int(k)])


def _pick(rng: np.random.Generator, items):
    return items[int(rng.integers(len(items)))]


def _rot(deg: float, v) -> tuple[float, float]:
    a = np.radians(deg)
    return (float(np.cos(a) * v[0] - np.sin(a) * v[1]), float(np.sin(a) * v[0] + np.cos(a) * v[1]))


# ----------------------------------------------------------------------------------------------
# supports

TABLE_OAK = ((0.66, 0.47, 0.30), (0.42, 0.27, 0.15), (0.16, 0.10, 0.06))
TABLE_WALNUT = ((0.52, 0.34, 0.20), (0.30, 0.18, 0.10), (0.12, 0.08, 0.05))
TABLE_ASH = ((0.76, 0.62, 0.45), (0.55, 0.40, 0.26), (0.22, 0.16, 0.10))

# (warp, weft, stripe, hem): grey-blue with navy stripes, salmon pink, sage, ochre, cream with rust
MATS = (
    ((0.62, 0.64, 0.66), (0.70, 0.62, 0.50), (0.12, 0.20, 0.32), (0.30, 0.32, 0.36)),
    ((0.86, 0.52, 0.46), (0.90, 0.60, 0.54), (0.70, 0.36, 0.32), (0.80, 0.44, 0.38)),
    ((0.56, 0.64, 0.50), (0.68, 0.72, 0.60), (0.30, 0.38, 0.26), (0.40, 0.48, 0.36)),
    ((0.80, 0.62, 0.28), (0.86, 0.74, 0.46), (0.50, 0.30, 0.14), (0.62, 0.44, 0.18)),
    ((0.86, 0.84, 0.78), (0.80, 0.76, 0.68), (0.66, 0.30, 0.20), (0.56, 0.52, 0.46)),
)


def table(rng, seed: int) -> Material:
    """A wooden table top (boards along x, wood grain): the room's floor."""
    return Material("grain", _pick(rng, (TABLE_OAK, TABLE_WALNUT, TABLE_ASH)), scale=0.16, detail=0.06, seed=seed)


def placemat(colors, half: tuple[float, float], pitch: float, seed: int, n_bands: int, rng, flecks: float = 0.0) -> Material:
    """A woven placemat: warp along local x, ``n_bands`` stripes along it, a 12 mm hem; ``flecks`` > 0
    scatters 2-6 mm flecks of darker and lighter yarn (blobs SIFT can match across a regular weave)."""
    bands = tuple((float(c), float(w)) for c, w in zip(rng.uniform(-0.8, 0.8, n_bands) * half[1], rng.uniform(0.006, 0.014, n_bands)))
    return Material("weave", colors, scale=pitch, detail=0.04, seed=seed, extent=half, border=0.012, bands=bands,
                    dots=flecks, dot_size=0.02)


# ----------------------------------------------------------------------------------------------
# objects (object coordinates: resting on z = -SINK, x forward)


def toy_bulldozer(oid: int, body=(0.95, 0.78, 0.08), **kw) -> ObjectSpec:
    """A toy bulldozer ~0.40 m long: dark tracks and a dark chassis whose underside is 6 mm above the
    support, grey road wheels, a yellow body and engine, an open cab of thin posts, a blade 5 mm above
    the support on dark arms."""
    yellow = Material("noise", (body, tuple(c * 0.85 for c in body), (0.98, 0.92, 0.55)), scale=0.03, detail=0.1, seed=201,
                      dots=0.3, dot_size=0.025, dot_colors=(tuple(c * 0.6 for c in body), (0.98, 0.95, 0.8)))
    track = Material("stripes", ((0.07, 0.07, 0.08), (0.22, 0.22, 0.23), (0.12, 0.12, 0.13)), scale=0.012, axis=0, duty=0.6, detail=0.1, seed=202)
    dark = Material("noise", ((0.06, 0.06, 0.07), (0.12, 0.12, 0.13)), scale=0.02, detail=0.1, seed=203)
    grey = Material("stripes", ((0.62, 0.63, 0.65), (0.35, 0.36, 0.38)), scale=0.008, axis=0, duty=0.7, detail=0.08, seed=204)
    red = Material("noise", ((0.85, 0.10, 0.08), (0.95, 0.30, 0.20)), scale=0.01, detail=0.05, seed=205)
    prims = []
    for sy in (-1.0, 1.0):
        y = sy * 0.068
        prims.append(Prim("box", (0.10, 0.022, 0.033), track, (0.0, y, 0.033 - SINK)))
        for x in (-0.10, 0.10):
            prims.append(Prim("cylinder", (0.033, 0.022), track, (x, y, 0.033 - SINK), (90.0, 0.0, 0.0)))
        for x in (-0.10, -0.035, 0.035, 0.10):
            prims.append(Prim("cylinder", (0.02, 0.003), grey, (x, sy * 0.0915, 0.033 - SINK), (90.0, 0.0, 0.0)))
    prims += [
        Prim("box", (0.115, 0.046, 0.022), dark, (0.0, 0.0, 0.028)),  # chassis: underside at z = 0.006
        Prim("box", (0.13, 0.095, 0.022), yellow, (-0.01, 0.0, 0.088)),  # body deck over the tracks
        Prim("box", (0.06, 0.07, 0.035), yellow, (-0.075, 0.0, 0.145)),  # engine
        segment("cylinder", 0.008, (-0.09, 0.04, 0.18), (-0.09, 0.04, 0.235), dark),  # exhaust
        Prim("ellipsoid", (0.008, 0.008, 0.008), red, (-0.09, 0.04, 0.24)),
        Prim("box", (0.045, 0.075, 0.006), yellow, (0.04, 0.0, 0.245)),  # cab roof
        Prim("box", (0.014, 0.115, 0.042), yellow, (0.205, 0.0, 0.049), (0.0, -12.0, 0.0)),  # blade, lower edge ~5 mm up
    ]
    for x in (0.0, 0.08):
        for sy in (-1.0, 1.0):
            prims.append(segment("cylinder", 0.006, (x, sy * 0.065, 0.11), (x, sy * 0.065, 0.242), dark))
    for sy in (-1.0, 1.0):
        prims.append(segment("capsule", 0.009, (0.09, sy * 0.085, 0.08), (0.195, sy * 0.085, 0.05), dark))
    return ObjectSpec(oid, "bulldozer", "boxes+cylinders (dark underside)", tuple(prims), **kw)


def teapot(oid: int, glaze, **kw) -> ObjectSpec:
    """A glazed teapot ~0.3 m long on an unglazed foot ring, spout and handle overhanging."""
    g = Material("noise", glaze, scale=0.03, detail=0.08, seed=211, dots=0.25, dot_size=0.03,
                 dot_colors=(tuple(c * 0.5 for c in glaze[0]), (0.95, 0.93, 0.88)))
    foot = Material("noise", ((0.55, 0.48, 0.40), (0.40, 0.34, 0.28)), scale=0.01, detail=0.1, seed=212)
    prims = (
        Prim("cylinder", (0.08, 0.006), foot, (0.0, 0.0, 0.006 - SINK)),
        Prim("ellipsoid", (0.10, 0.10, 0.075), g, (0.0, 0.0, 0.078)),
        Prim("ellipsoid", (0.05, 0.05, 0.02), g, (0.0, 0.0, 0.152)),
        Prim("ellipsoid", (0.014, 0.014, 0.016), g, (0.0, 0.0, 0.178)),
        segment("capsule", 0.013, (0.08, 0.0, 0.06), (0.17, 0.0, 0.15), g),
        Prim("torus", (0.05, 0.011), g, (-0.115, 0.0, 0.09), (90.0, 0.0, 0.0)),
    )
    return ObjectSpec(oid, "teapot", "ellipsoids+capsule+torus", prims, **kw)


def bread_box(oid: int, paint, **kw) -> ObjectSpec:
    """A printed tin bread box ~0.42 x 0.16 x 0.26 m (the backdrop that stays), with a darker lid line.
    Its print (patches of the palette, dark and light spots) keeps SfM going in the views it fills."""
    m = Material("patches", paint, scale=0.04, detail=0.1, seed=221, dots=0.45, dot_size=0.025,
                 dot_colors=((0.12, 0.10, 0.10), (0.95, 0.93, 0.88)))
    trim = Material("noise", ((0.25, 0.18, 0.12), (0.35, 0.26, 0.18)), scale=0.01, detail=0.1, seed=222)
    prims = (
        Prim("box", (0.21, 0.08, 0.13), m, (0.0, 0.0, 0.13 - SINK)),
        Prim("box", (0.215, 0.085, 0.006), trim, (0.0, 0.0, 0.17)),
        Prim("box", (0.05, 0.01, 0.008), trim, (0.0, -0.088, 0.2)),  # handle
    )
    return ObjectSpec(oid, "bread box", "boxes", prims, **kw)


def rubber_duck(oid: int, **kw) -> ObjectSpec:
    """A rubber duck ~0.12 m long: a body cut flat at the support and bulging over its base (a dark crease all round)."""
    yellow = Material("noise", ((0.98, 0.82, 0.10), (0.92, 0.70, 0.06), (1.0, 0.92, 0.40)), scale=0.015, detail=0.08, seed=231,
                      dots=0.2, dot_size=0.012, dot_colors=((0.75, 0.50, 0.05), (1.0, 0.97, 0.75)))
    orange = Material("noise", ((0.95, 0.45, 0.08), (0.85, 0.35, 0.05)), scale=0.005, detail=0.05, seed=232)
    black = Material("noise", ((0.04, 0.04, 0.05), (0.10, 0.10, 0.12)), scale=0.003, detail=0.05, seed=233)
    prims = (
        Prim("ellipsoid", (0.06, 0.045, 0.04), yellow, (0.0, 0.0, 0.026)),  # flat base 9 x 7 cm, overhanging above it
        Prim("ellipsoid", (0.03, 0.03, 0.028), yellow, (0.032, 0.0, 0.082)),
        Prim("ellipsoid", (0.018, 0.012, 0.006), orange, (0.062, 0.0, 0.078)),
        Prim("ellipsoid", (0.006, 0.006, 0.006), black, (0.05, 0.018, 0.092)),
        Prim("ellipsoid", (0.006, 0.006, 0.006), black, (0.05, -0.018, 0.092)),
        Prim("ellipsoid", (0.02, 0.012, 0.012), yellow, (-0.058, 0.0, 0.05), (0.0, -30.0, 0.0)),  # tail
    )
    return ObjectSpec(oid, "rubber duck", "ellipsoids", prims, **kw)


def plush_bear(oid: int, fur, **kw) -> ObjectSpec:
    """A sitting plush bear ~0.33 m tall: fur with faint tufts, a lighter muzzle and paw pads, button
    eyes and nose, and a checked scarf (the few sharp features structure from motion finds on it)."""
    f = Material("noise", fur, scale=0.012, detail=0.1, seed=241, dots=0.25, dot_size=0.01)
    light = tuple(tuple(min(1.0, 0.35 + 0.7 * c) for c in col) for col in fur[:2])
    pale = Material("noise", light, scale=0.008, detail=0.08, seed=242)
    black = Material("noise", ((0.03, 0.03, 0.04), (0.10, 0.09, 0.09)), scale=0.003, detail=0.05, seed=243)
    scarf = Material("checker", ((0.80, 0.12, 0.12), (0.92, 0.90, 0.84), (0.15, 0.20, 0.45)), scale=0.012, detail=0.05, seed=244)
    prims = [
        Prim("ellipsoid", (0.085, 0.08, 0.10), f, (0.0, 0.0, 0.098)),  # body, sitting
        Prim("ellipsoid", (0.072, 0.07, 0.066), f, (0.01, 0.0, 0.245)),  # head
        Prim("ellipsoid", (0.032, 0.036, 0.026), pale, (0.066, 0.0, 0.232)),  # muzzle
        Prim("ellipsoid", (0.012, 0.016, 0.009), black, (0.096, 0.0, 0.244)),  # nose
        Prim("torus", (0.062, 0.014), scarf, (0.005, 0.0, 0.185)),  # scarf round the neck
    ]
    for sy in (-1.0, 1.0):
        prims += [
            Prim("ellipsoid", (0.026, 0.012, 0.026), f, (-0.005, sy * 0.055, 0.305), (sy * 20.0, 0.0, 0.0)),  # ear
            Prim("ellipsoid", (0.014, 0.006, 0.014), pale, (0.002, sy * 0.055, 0.303), (sy * 20.0, 0.0, 0.0)),
            Prim("ellipsoid", (0.008, 0.008, 0.008), black, (0.062, sy * 0.03, 0.268)),  # button eye
            Prim("ellipsoid", (0.065, 0.038, 0.036), f, (0.07, sy * 0.052, 0.034)),  # leg forward, resting on the sheet
            Prim("ellipsoid", (0.006, 0.024, 0.028), pale, (0.133, sy * 0.052, 0.036)),  # foot pad
            segment("capsule", 0.024, (0.01, sy * 0.085, 0.16), (0.06, sy * 0.07, 0.09), f),  # arm
        ]
    return ObjectSpec(oid, "plush bear", "ellipsoids+torus+capsules", tuple(prims), **kw)


# ----------------------------------------------------------------------------------------------
# layouts


def _mat_prims(q, angle: float, mats, rng, seed: int, pitch: float, half_seam: float, depth: tuple[float, float]) -> list[Prim]:
    """Two mats of different colours abutting along a seam through ``q`` at ``angle`` (degrees, the
    seam's normal): mat A on the negative side, mat B on the positive side, each shifted along the seam."""
    prims = []
    for k, (side, colors) in enumerate(zip((-1.0, 1.0), mats)):
        hx, hy = depth[k], half_seam
        shift = float(rng.uniform(-0.35, 0.35)) * hy
        cx, cy = _rot(angle, (side * hx, shift))
        m = placemat(colors, (hx, hy), pitch, seed + k, int(rng.integers(1, 4)), rng)
        prims.append(Prim("box", (hx, hy, 0.5 * MAT_T), m, (q[0] + cx, q[1] + cy, 0.5 * MAT_T), (0.0, 0.0, angle)))
    return prims


def dozer(suite: str, k: int, sparse: bool = False) -> SceneSpec:
    rng = _rng("dozer", suite, k)
    seed = 300 + 10 * k + (0 if suite == "dev" else 5)
    yaw = float(rng.uniform(0.0, 360.0))
    pos = tuple(float(x) for x in rng.uniform(-0.02, 0.02, 2))
    i, j = rng.choice(len(MATS), 2, replace=False)
    # the seam crosses the footprint within 6 cm of its centre, at any angle to the vehicle
    off = float(rng.uniform(-0.06, 0.06))
    angle = float(rng.uniform(0.0, 180.0))
    q = (pos[0] + _rot(angle, (off, 0.0))[0], pos[1] + _rot(angle, (off, 0.0))[1])
    bg = room(table(rng, seed), _pick(rng, (WALLS_WARM, WALLS_COOL, WALLS_GREEN)))
    bg += tuple(_mat_prims(q, angle, (MATS[i], MATS[j]), rng, seed + 1, 0.008, 0.24, tuple(rng.uniform(0.24, 0.3, 2))))
    obj = toy_bulldozer(1, position=(pos[0], pos[1], MAT_T), yaw=yaw, target=True)
    return _spec("dozer", suite, k, sparse,
                 "toy bulldozer (dark tracks and chassis 6 mm above the support) on two woven placemats meeting under it, wooden table",
                 bg, (obj,), ao_radius=0.2)


def teapot_scene(suite: str, k: int, sparse: bool = False) -> SceneSpec:
    rng = _rng("teapot", suite, k)
    seed = 400 + 10 * k + (0 if suite == "dev" else 5)
    turn = float(rng.uniform(0.0, 360.0))  # the whole arrangement
    gap = float(rng.uniform(0.025, 0.05))  # between the teapot's widest point and the bread box
    glaze = _pick(rng, (((0.20, 0.35, 0.62), (0.28, 0.45, 0.72), (0.85, 0.85, 0.80)),
                        ((0.30, 0.55, 0.42), (0.38, 0.62, 0.48), (0.90, 0.88, 0.78)),
                        ((0.88, 0.86, 0.80), (0.78, 0.76, 0.70), (0.30, 0.40, 0.65)),
                        ((0.62, 0.18, 0.14), (0.72, 0.26, 0.18), (0.92, 0.85, 0.70))))
    paint = _pick(rng, (((0.85, 0.82, 0.72), (0.45, 0.55, 0.68), (0.70, 0.42, 0.35)),
                        ((0.30, 0.42, 0.36), (0.80, 0.78, 0.66), (0.62, 0.50, 0.30)),
                        ((0.62, 0.20, 0.18), (0.90, 0.86, 0.76), (0.25, 0.30, 0.45))))
    box_y = 0.10 + gap + 0.08  # bread box centre behind the teapot (its half depth 0.08)
    box_c = _rot(turn, (float(rng.uniform(-0.06, 0.06)), box_y))
    pot = teapot(1, glaze, position=(0.0, 0.0, 0.0), yaw=turn + float(rng.uniform(-50.0, 50.0)), target=True)
    box = bread_box(2, paint, position=(box_c[0], box_c[1], 0.0), yaw=turn)
    bg = room(table(rng, seed), _pick(rng, (WALLS_WARM, WALLS_COOL, WALLS_GREEN)))
    return _spec("teapot", suite, k, sparse,
                 "teapot on wood grain right in front of a bread box that stays (a backdrop: the gap and the box's face behind the pot are unseen)",
                 bg, (pot, box), ao_radius=0.12)


def duck(suite: str, k: int, sparse: bool = False) -> SceneSpec:
    rng = _rng("duck", suite, k)
    seed = 500 + 10 * k + (0 if suite == "dev" else 5)
    yaw = float(rng.uniform(0.0, 360.0))
    angle = float(rng.uniform(0.0, 360.0))
    off = float(rng.uniform(-0.02, 0.02))  # the rug's edge passes under the duck
    half = (0.5, 0.35)
    cx, cy = _rot(angle, (-half[0] + off, float(rng.uniform(-0.15, 0.15))))
    colors = MATS[int(rng.integers(len(MATS)))]
    rug = placemat(colors, half, 0.007, seed + 1, int(rng.integers(2, 5)), rng, flecks=0.3)
    # tiles marked with spots: a plain grid of 10 cm tiles is too repetitive for SfM from 0.3 m
    floor = Material("tiles", ((0.70, 0.68, 0.64), (0.52, 0.55, 0.58), (0.62, 0.56, 0.48), (0.30, 0.29, 0.28)), scale=0.1, detail=0.1, seed=seed,
                     dots=0.35, dot_size=0.03)
    bg = room(floor, _pick(rng, (WALLS_WARM, WALLS_COOL, WALLS_GREEN)))
    bg += (Prim("box", (half[0], half[1], 0.5 * MAT_T), rug, (cx, cy, 0.5 * MAT_T), (0.0, 0.0, angle)),)
    obj = rubber_duck(1, position=(0.0, 0.0, MAT_T), yaw=yaw, target=True)
    return _spec("duck", suite, k, sparse, "small rubber duck on the edge of a woven rug over a tiled floor", bg, (obj,), ao_radius=0.06)


# A cotton sheet: off-white with broad, faint folds (almost nothing for SIFT), spread on a wooden
# floor in a furnished room (the floor beyond the sheet and the walls are what lets the photos taken
# after the toy's removal register)
SHEETS = (((0.88, 0.87, 0.84), (0.80, 0.79, 0.76)), ((0.84, 0.86, 0.88), (0.76, 0.78, 0.81)), ((0.90, 0.86, 0.80), (0.82, 0.78, 0.72)))
SHEET_HALF = 0.5  # metres: the toy fills the frame, so the sheet fills most of each photo
FURS = (((0.55, 0.38, 0.22), (0.48, 0.32, 0.18)), ((0.78, 0.66, 0.48), (0.70, 0.58, 0.40)), ((0.42, 0.42, 0.44), (0.36, 0.36, 0.38)))


def plush(suite: str, k: int, sparse: bool = False) -> SceneSpec:
    rng = _rng("plush", suite, k)
    seed = 600 + 10 * k + (0 if suite == "dev" else 5)
    sheet = Material("noise", _pick(rng, SHEETS), scale=0.25, detail=0.02, seed=seed)
    bg = room(table(rng, seed), _pick(rng, (WALLS_WARM, WALLS_COOL, WALLS_GREEN)))
    angle = float(rng.uniform(0.0, 90.0))
    centre = _rot(angle, tuple(float(x) for x in rng.uniform(-0.1, 0.1, 2)))
    bg += (Prim("box", (SHEET_HALF, SHEET_HALF, 0.5 * MAT_T), sheet, (centre[0], centre[1], 0.5 * MAT_T), (0.0, 0.0, angle)),)
    obj = plush_bear(1, _pick(rng, FURS), position=(0.0, 0.0, MAT_T), yaw=float(rng.uniform(0.0, 360.0)), target=True)
    return _spec("plush", suite, k, sparse, "plush bear filling much of the frame on a plain sheet spread on a wooden floor (few SfM points, mostly on the toy and beyond the sheet)",
                 bg, (obj,), ao_radius=0.1, fill=1.05)


def _spec(layout: str, suite: str, k: int, sparse: bool, description: str, background, objects, ao_radius: float,
          fill: float = 0.8) -> SceneSpec:
    """The scene of ``layout`` at layout seed ``k`` of the random stream ``suite`` (its name); in the dev
    suite when the stream is dev or the seed was looked at (:data:`LOOKED_AT`), else in the test suite."""
    name = f"{layout}-{suite}{k}" + ("-sparse" if sparse else "")
    n_views = SPARSE_VIEWS if sparse else 56
    targets = tuple(o.id for o in objects if o.target)  # the photos frame the object to remove
    return SceneSpec(
        name, description + (f"; sparse: {SPARSE_VIEWS} photos" if sparse else ""), tuple(background), tuple(objects),
        orbit=Orbit(elevation=ORBIT_ELEVATION, frame=targets, fill=fill), light=Light(ao=0.85, ao_radius=ao_radius, ao_samples=8),
        n_views=n_views, n_test=16, photo=PHOTO, poses="colmap", family=FAMILY, suite="dev" if k in LOOKED_AT.get(suite, ()) else suite,
    )


BUILDERS = {"dozer": dozer, "teapot": teapot_scene, "duck": duck, "plush": plush}


def realistic_scenes() -> list[SceneSpec]:
    """Every scene of the family: each layout at each suite's seeds, and the sparse variants."""
    out = []
    for layout in LAYOUTS:
        for suite, seeds in LAYOUT_SEEDS.get(layout, SEEDS).items():
            for k in seeds:
                out.append(BUILDERS[layout](suite, k))
                if k in LAYOUT_SPARSE.get(layout, SPARSE)[suite]:
                    out.append(BUILDERS[layout](suite, k, sparse=True))
    return out
