"""Procedural solid textures (albedo as a function of a 3D surface point), band-limited per sample.

Every texture is evaluated in the primitive's local frame, so it sticks to its object, and takes
the sample's footprint (metres covered by one supersample): detail finer than the footprint fades to
its mean, the analytic counterpart of a camera integrating over the pixel. Together with 3x3
supersampling this keeps far and grazing surfaces (the floor towards the walls) free of aliasing,
while the features near the objects stay sharp enough for SIFT.

Written by hand: the textures must be evaluated at arbitrary 3D points with a per-sample filter
width, which image-based texture libraries do not offer.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dataset_tools.synth.noise import cell_random, fbm

Color = tuple[float, float, float]

@dataclass(frozen=True)
class Material:
    """A procedural surface: ``kind`` picks the pattern (see :data:`TEXTURES`), ``colors`` its palette.

    ``scale`` is the main feature size in metres, ``axis`` the local axis along which bands/grain run,
    ``detail`` the amplitude of the fine brightness noise laid over every pattern, ``duty`` the share
    of colour 1 in bands, ``seed`` an offset that makes two surfaces with the same parameters look
    different, ``unlit`` makes the surface self-luminous (sky). ``dots`` > 0 scatters round spots
    (chance per cell of size ``dot_size`` metres) in dark and light shades of the palette: blob-like,
    high-contrast features that SIFT finds reliably at low resolution (flowers in grass, marks on walls).
    ``extent``, ``border`` and ``bands`` shape a woven mat (:func:`tex_weave`).
    """

    kind: str
    colors: tuple[Color, ...]
    scale: float = 0.1
    axis: int = 2
    detail: float = 0.12
    duty: float = 0.5
    seed: int = 0
    unlit: bool = False  # emits its albedo as colour (the sky), ignoring the lights
    dots: float = 0.0
    dot_size: float = 0.2
    dot_colors: tuple[Color, ...] = ()  # empty: dark and light shades of ``colors``
    # woven mats (``weave``): the mat's half extents (local x, y; metres), the width of its hem
    # along every edge (0: none), and stripes of colour 2 across local y as (centre, half width)
    extent: tuple[float, float] = (0.0, 0.0)
    border: float = 0.0
    bands: tuple[tuple[float, float], ...] = ()


def smoothstep(e0: float, e1: float, x: np.ndarray) -> np.ndarray:
    t = np.clip((x - e0) / (e1 - e0), 0.0, 1.0)
    return t * t * (3.0 - 2.0 * t)


def box_square(x: np.ndarray, duty: float, width: np.ndarray) -> np.ndarray:
    """Square wave (1 on [0, duty) of each unit period) box-filtered over ``width`` (exact, any width)."""

    def integral(y):
        return np.floor(y) * duty + np.minimum(y - np.floor(y), duty)

    width = np.maximum(width, 1e-6)
    return (integral(x + 0.5 * width) - integral(x - 0.5 * width)) / width


def _mix(a: np.ndarray, b: np.ndarray, t: np.ndarray) -> np.ndarray:
    return a + (b - a) * t[:, None]


def _col(c) -> np.ndarray:
    return np.asarray(c, dtype=np.float64)[None, :]


def _detail(p, fp, m: Material, seed):
    """Brightness factor from fine fbm (a quarter of the main scale) with standard deviation ~``detail``."""
    s = m.scale * 0.25
    v = fbm(p / s, fp / s, seed + 7, octaves=3)
    return 1.0 + m.detail * 10.0 * (v - 0.5)  # fbm's own std is ~0.1


def tex_noise(p, fp, m: Material, seed):
    """Mottled mix of 2-3 colours by fbm thresholds (fruit skin, fur, stone, grass)."""
    c = m.colors
    a = fbm(p / m.scale, fp / m.scale, seed)
    out = _mix(_col(c[0]), _col(c[1]), smoothstep(0.38, 0.62, a))
    if len(c) > 2:
        b = fbm(p / m.scale + 31.7, fp / m.scale, seed + 13)
        out = _mix(out, np.broadcast_to(_col(c[2]), out.shape), 0.85 * smoothstep(0.55, 0.68, b))
    return out


def tex_patches(p, fp, m: Material, seed):
    """Blobs of distinct palette colours with soft edges (walls: poster-like, distinctive for SIFT)."""
    fields = [fbm(p / m.scale + 19.3 * i, fp / m.scale, seed + 37 * i, octaves=3) for i in range(len(m.colors))]
    top = fields[0]
    for f in fields[1:]:
        top = np.maximum(top, f)
    # soft arg-max: each point takes the colour of its largest field, blended over a narrow margin
    out = np.zeros((len(p), 3))
    total = np.zeros(len(p))
    for f, c in zip(fields, m.colors):
        w = np.exp(25.0 * (f - top))
        total += w
        out += w[:, None] * _col(c)
    return out / total[:, None]


def tex_checker(p, fp, m: Material, seed):
    """3D checker with box-filtered edges (exact for the separable product), colour-varied by noise."""
    x = p / m.scale
    w = np.maximum(fp / m.scale, 0.04)[:, None]
    s = 1.0 - 2.0 * box_square(x + 0.25, 0.5, w)
    sgn = s[:, 0] * s[:, 1] * s[:, 2]  # in [-1, 1]
    base = _mix(_col(m.colors[0]), _col(m.colors[1]), 0.5 - 0.5 * sgn)
    if len(m.colors) > 2:
        v = fbm(x * 0.5 + 3.1, w[:, 0] * 0.5, seed + 5)
        base = _mix(base, np.broadcast_to(_col(m.colors[2]), base.shape), 0.7 * smoothstep(0.5, 0.7, v))
    return base


def tex_stripes(p, fp, m: Material, seed):
    """Bands along local ``axis`` (period ``scale``, ``duty`` share of colour 1), gently warped by noise."""
    warp = 0.15 * (fbm(p / (2.0 * m.scale), fp / (2.0 * m.scale), seed + 3, octaves=2) - 0.5)
    x = p[:, m.axis] / m.scale + warp
    s = box_square(x, m.duty, np.maximum(fp / m.scale, 0.03))
    out = _mix(_col(m.colors[0]), _col(m.colors[1]), s)
    if len(m.colors) > 2:
        v = fbm(p / m.scale + 7.7, fp / m.scale, seed + 11)
        out = _mix(out, np.broadcast_to(_col(m.colors[2]), out.shape), 0.8 * smoothstep(0.58, 0.7, v))
    return out


def tex_wood(p, fp, m: Material, seed):
    """Growth rings around local ``axis`` distorted by noise (solid wood)."""
    ax = [i for i in range(3) if i != m.axis]
    q = p / m.scale
    r = np.hypot(q[:, ax[0]], q[:, ax[1]]) + 0.6 * fbm(q * 0.5, fp / m.scale * 0.5, seed)
    ring_fp = fp / m.scale * 4.0
    rings = 0.5 + 0.5 * np.sin(2.0 * np.pi * 4.0 * r) * (1.0 - smoothstep(0.25, 0.5, ring_fp))
    return _mix(_col(m.colors[0]), _col(m.colors[1]), rings**2)


def tex_planks(p, fp, m: Material, seed):
    """Floor boards along x of width ``scale`` with staggered joints, dark gaps and grain."""
    W = m.scale
    L = 6.0 * W
    y = p[:, 1] / W
    j = np.floor(y)
    off = cell_random(np.stack([j, np.full_like(j, 3.0), np.zeros_like(j)], -1).astype(np.int64), seed)  # joint offset per row
    x = p[:, 0] / L + off
    i = np.floor(x)
    cells = np.stack([i, j, np.zeros_like(i)], -1).astype(np.int64)
    tone = cell_random(cells, seed + 1)
    fade = 1.0 - smoothstep(0.25, 0.6, fp / W)
    c0, c1 = _col(m.colors[0]), _col(m.colors[1])
    base = _mix(c0, c1, 0.5 + fade * (tone - 0.5))
    grain = fbm(p * np.array([1.0 / (2.0 * W), 4.0 / W, 4.0 / W]), fp * 4.0 / W, seed + 2, octaves=3)
    base = base * (0.75 + 0.5 * smoothstep(0.3, 0.7, grain))[:, None]
    # dark knots: sparse blobs (distinctive features on an otherwise line-like pattern)
    knots = smoothstep(0.63, 0.7, fbm(p * np.array([0.8 / W, 1.6 / W, 1.6 / W]), fp * 1.6 / W, seed + 5, octaves=2))
    base = base * (1.0 - 0.6 * knots)[:, None]
    gap_w = 0.05
    gy = box_square(y - 0.5 * gap_w, 1.0 - gap_w, np.maximum(fp / W, 0.02))
    gx = box_square(x - 0.5 * gap_w / 6.0, 1.0 - gap_w / 6.0, np.maximum(fp / L, 0.004))
    board = gy * gx
    gap = _col(m.colors[2]) if len(m.colors) > 2 else c0 * 0.35
    return _mix(np.broadcast_to(gap, base.shape), base, board)


def tex_tiles(p, fp, m: Material, seed):
    """Square tiles of size ``scale`` (local x/y) with grout lines and per-tile colour from the palette."""
    S = m.scale
    g = 0.06
    q = p[:, :2] / S
    w = np.maximum(fp / S, 0.02)[:, None]
    b = box_square(q + 0.5 * g, 1.0 - g, w)
    tile = b[:, 0] * b[:, 1]  # grout centred on integer lines
    cells = np.concatenate([np.floor(q), np.zeros((len(q), 1))], -1).astype(np.int64)
    pal = np.asarray(m.colors[:-1], dtype=np.float64)
    k = np.minimum((cell_random(cells, seed) * len(pal)).astype(np.int64), len(pal) - 1)
    jitter = 0.85 + 0.3 * cell_random(cells, seed + 9)
    fade = (1.0 - smoothstep(0.3, 0.7, fp / S))[:, None]
    mean = pal.mean(axis=0, keepdims=True)
    colour = mean + fade * (pal[k] * jitter[:, None] - mean)
    # marble-like veins make every tile unique (a plain grid is ambiguous for feature matching)
    veins = fbm(p / (0.5 * S) + 5.3, fp / (0.5 * S), seed + 4, octaves=4)
    colour = colour * (0.8 + 0.4 * smoothstep(0.35, 0.65, veins))[:, None]
    return _mix(np.broadcast_to(_col(m.colors[-1]), colour.shape), colour, tile)


def tex_sky(p, fp, m: Material, seed):
    """Dome: tree line of varying height over the horizon, blue gradient and clouds above (world frame)."""
    r = np.sqrt(np.einsum("ij,ij->i", p, p))
    n = p / r[:, None]
    el = np.degrees(np.arcsin(np.clip(n[:, 2], -1.0, 1.0)))
    az = np.arctan2(n[:, 1], n[:, 0])
    ring = np.stack([np.cos(az), np.sin(az), np.zeros_like(az)], -1)
    fpa = fp / r  # footprint as an angle (radians)
    h = 4.0 + 14.0 * fbm(ring * 3.0, fpa * 3.0, seed + 1, octaves=5)  # tree-line height in degrees
    trees = 1.0 - smoothstep(h - 0.6, h + 0.6, el)
    sky = _mix(_col(m.colors[0]), _col(m.colors[1]), smoothstep(0.0, 60.0, el))
    cloud_p = n * 4.0
    clouds = smoothstep(0.5, 0.75, fbm(cloud_p, fpa * 4.0, seed + 2, octaves=5))
    sky = _mix(sky, np.broadcast_to(_col(m.colors[2]), sky.shape), 0.9 * clouds)
    leaf = fbm(n * 40.0, fpa * 40.0, seed + 3, octaves=4)
    foliage = _mix(_col(m.colors[3]), _col(m.colors[4]), smoothstep(0.3, 0.7, leaf))
    return _mix(sky, foliage, trees)


def _thread_profile(frac: np.ndarray, fade: np.ndarray) -> np.ndarray:
    """Brightness across a round thread (``frac`` in [0, 1) across it), faded to its mean 2/pi as it blurs."""
    mean = 2.0 / np.pi
    return mean + fade * (np.sin(np.pi * frac) - mean)


def _inside(dist: np.ndarray, fp: np.ndarray) -> np.ndarray:
    """Box-filtered indicator of ``dist > 0`` (signed distance to an edge, metres) over footprint ``fp``."""
    return np.clip(dist / np.maximum(fp, 1e-9) + 0.5, 0.0, 1.0)


def tex_weave(p, fp, m: Material, seed):
    """A plain-woven mat in its local x/y: warp threads along x (colour 0), weft threads along y (colour 1).

    Threads have pitch ``scale``; in a plain weave the warp lies on top on the cells where
    ``floor(x/scale) + floor(y/scale)`` is even, so the surface shows a checker of short thread
    segments, each shaded across its width like a round thread and toned per thread (mixed yarns).
    Warp threads inside a ``band`` (centre, half width along y) take colour 2: stripes along the mat.
    Within ``border`` of the mat's edges (``extent``: its half extents) a hem of colour 3 with ribs
    along the edge. Detail finer than the footprint fades to its mean, as everywhere.
    """
    S = m.scale
    c = [np.asarray(col, dtype=np.float64) for col in m.colors]
    u, v = p[:, 0] / S, p[:, 1] / S
    w = np.maximum(fp / S, 0.02)
    fade = 1.0 - smoothstep(0.25, 0.6, w)
    iu, iv = np.floor(u), np.floor(v)
    # share of the footprint where the warp is on top: the checker of period 2 cells, box-filtered
    warp_top = 0.5 + 0.5 * (1.0 - 2.0 * box_square(0.5 * u, 0.5, 0.5 * w)) * (1.0 - 2.0 * box_square(0.5 * v, 0.5, 0.5 * w))
    zero = np.zeros_like(iu)
    tone_warp = 0.8 + 0.4 * cell_random(np.stack([zero, iv, zero + 1], -1).astype(np.int64), seed)
    tone_weft = 0.8 + 0.4 * cell_random(np.stack([iu, zero, zero + 2], -1).astype(np.int64), seed)
    warp_col = np.broadcast_to(c[0], (len(p), 3))
    if len(c) > 2 and m.bands:
        inband = np.zeros(len(p))
        for centre, half in m.bands:
            inband = np.maximum(inband, _inside(half - np.abs(p[:, 1] - centre), fp))
        warp_col = _mix(warp_col, np.broadcast_to(c[2], warp_col.shape), inband)
    mean = 2.0 / np.pi
    prof_u, prof_v = _thread_profile(u - iu, fade), _thread_profile(v - iv, fade)
    warp = warp_col * ((1.0 + fade * (tone_warp - 1.0)) * prof_v / mean)[:, None]
    weft = c[1][None, :] * ((1.0 + fade * (tone_weft - 1.0)) * prof_u / mean)[:, None]
    out = _mix(weft, warp, warp_top)
    ex, ey = m.extent
    if m.border > 0 and ex > m.border and ey > m.border and len(c) > 3:
        edge = np.minimum(ex - np.abs(p[:, 0]), ey - np.abs(p[:, 1]))  # distance to the mat's outline
        rib = 0.25 * m.border
        ribs = 1.0 + 0.12 * (1.0 - smoothstep(0.25, 0.6, fp / rib)) * np.sin(2.0 * np.pi * edge / rib)
        out = _mix(c[3][None, :] * ribs[:, None], out, _inside(edge - m.border, fp))
    return out


def tex_grain(p, fp, m: Material, seed):
    """Table top of wide boards along local x (width ``scale``) with wood grain: per-board tone, growth
    rings cut by the board's face (long lines that swing into arches), fine dark streaks, rare knots,
    thin dark seams. Colours: light wood, dark wood, seam."""
    W = m.scale
    c0, c1 = _col(m.colors[0]), _col(m.colors[1])
    y = p[:, 1] / W
    j = np.floor(y)
    zero = np.zeros_like(j)
    tone = cell_random(np.stack([zero, j, zero + 5], -1).astype(np.int64), seed)
    fade = 1.0 - smoothstep(0.25, 0.6, fp / W)  # boards narrower than a few footprints blend
    base = _mix(c0, c1, 0.25 + 0.3 * fade * (tone - 0.5))
    # rings: distance to a per-board pith line that wanders along x; 7 rings per board width
    pith = cell_random(np.stack([zero, j, zero + 6], -1).astype(np.int64), seed) - 0.5
    wander = fbm(p * np.array([1.0 / (2.5 * W), 1.0 / (2.0 * W), 1.0 / W]) + 3.7 * j[:, None], fp / (2.5 * W), seed + 1, octaves=3) - 0.5
    r = np.abs(y - j - 0.5 - 0.5 * pith + 1.2 * wander) * 7.0
    ring_fade = 1.0 - smoothstep(0.15, 0.35, fp / W * 7.0)
    late = np.clip(ring_fade * (0.5 + 0.5 * np.cos(2.0 * np.pi * r)), 0.0, 1.0) ** 3  # thin dark latewood
    streak = fbm(p * np.array([1.0 / (3.0 * W), 25.0 / W, 25.0 / W]) + 1.3 * j[:, None], fp * 25.0 / W, seed + 2, octaves=2)
    dark = 0.6 * late + 0.4 * smoothstep(0.55, 0.8, streak) * fade
    out = _mix(base, np.broadcast_to(c1 * 0.8, base.shape), np.clip(dark, 0.0, 1.0))
    knots = smoothstep(0.8, 0.83, fbm(p * np.array([0.7 / W, 3.0 / W, 3.0 / W]), fp * 3.0 / W, seed + 3, octaves=2))
    out = out * (1.0 - 0.5 * knots)[:, None]
    seam = box_square(y - 0.5 * 0.012, 1.0 - 0.012, np.maximum(fp / W, 0.004))
    gap = _col(m.colors[2]) if len(m.colors) > 2 else c1 * 0.4
    return _mix(np.broadcast_to(gap, out.shape), out, seam)


TEXTURES = {
    "noise": tex_noise,
    "patches": tex_patches,
    "checker": tex_checker,
    "stripes": tex_stripes,
    "wood": tex_wood,
    "planks": tex_planks,
    "tiles": tex_tiles,
    "sky": tex_sky,
    "weave": tex_weave,
    "grain": tex_grain,
}


def albedo(m: Material, p: np.ndarray, fp: np.ndarray, scene_seed: int) -> np.ndarray:
    """Albedo (n, 3) in [0, 1] of material ``m`` at local points ``p`` with per-sample footprint ``fp`` (metres)."""
    if m.kind not in TEXTURES:
        raise ValueError(f"unknown texture kind {m.kind!r}")
    seed = (scene_seed * 7919 + m.seed) & 0x7FFFFFFF
    out = TEXTURES[m.kind](p, fp, m, seed)
    if m.detail > 0 and m.kind != "sky":
        out = out * _detail(p, fp, m, seed)[:, None]
    if m.dots > 0:
        out = _dots(out, p, fp, m, seed)
    return np.clip(out, 0.0, 1.0)


def _dots(out, p, fp, m: Material, seed):
    """Overlay spheres (one candidate per cubic cell, so a surface shows discs of varied size) in dark or
    light shades of the palette, with box-filtered edges; spots smaller than the footprint fade out."""
    D = m.dot_size
    q = p / D + np.array([0.37, 0.61, 0.53])  # lattice offset: axis planes through 0 (floors) cut cells mid-way
    cell = np.floor(q)
    ci = cell.astype(np.int64)
    rnd = [cell_random(ci, seed + 1000 + k) for k in range(6)]
    present = rnd[0] < m.dots
    centre = cell + 0.25 + 0.5 * np.stack(rnd[1:4], -1)  # spheres stay inside their cell
    radius = 0.08 + 0.17 * rnd[4]  # cell units
    dist = np.sqrt(np.einsum("ij,ij->i", q - centre, q - centre))
    w = np.maximum(fp / D, 0.01)
    cover = np.clip((radius - dist) / w + 0.5, 0.0, 1.0) * (1.0 - smoothstep(0.5, 1.0, w / radius)) * present
    if m.dot_colors:
        pal = np.asarray(m.dot_colors, dtype=np.float64)
        shade = pal[np.minimum((rnd[5] * len(pal)).astype(np.int64), len(pal) - 1)]
    else:
        pal = np.asarray(m.colors, dtype=np.float64)
        k = np.minimum((rnd[5] * len(pal) * 2).astype(np.int64), 2 * len(pal) - 1)
        shade = np.where((k % 2 == 0)[:, None], 0.3 * pal[k // 2], 0.35 * pal[k // 2] + 0.65)
    return out + (shade - out) * cover[:, None]
