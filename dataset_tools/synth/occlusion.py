"""Ambient occlusion by ray casting: the soft darkening real photos show where an object meets its support.

For a shaded point with normal n, ``occlusion`` is the cosine-weighted mean over the hemisphere
about n of ``max(0, 1 - t / R)``, where t is the distance at which a ray from the point first hits a
surface and R is ``Light.ao_radius`` (rays that hit nothing within R count 0). A point on a plane
at the foot of a tall wall has occlusion 1/2 (half of the hemisphere is wall at distance -> 0), and
0 at R and beyond; a point under a wide flat overhang at height h < R has occlusion ``(1 - h/R)**2``
(the mean of ``1 - h / (R cos theta)`` where positive, cos theta having density 2 cos theta): the
floor under a vehicle's chassis is darker than its contact rim.

What occludes what: a point on the background (floor, mat, walls) is occluded by the objects only,
so the room's own corners stay as in the classic scenes and the darkening is the objects' doing; a
point on an object is occluded by everything (its underside darkens near the support). Only
background points within R of an object's bounding sphere can be occluded, so the rest of the image
costs nothing.

Sampling: ``Light.ao_samples`` rays per supersample, a fixed cosine-weighted Hammersley set turned
about n by an angle hashed from the point's position (a property of the surface point, the same
from every camera); the 3x3 supersamples of a pixel average 9 such sets.
"""

from __future__ import annotations

import numpy as np

from dataset_tools.synth.noise import cell_random

EPS = 1e-5  # metres: rays start this far above the surface (no self-hit)
JITTER_CELL = 1e-4  # metres: the turning angle is constant on cells of this size
_SEED = 0x0A0C


def hemisphere_set(k: int) -> np.ndarray:
    """(k, 3) cosine-weighted directions about +z: a Hammersley set (stratified in cos^2 theta and azimuth)."""
    i = np.arange(k)
    u1 = (i + 0.5) / k
    u2 = np.zeros(k)
    bits, scale = i.copy(), 0.5
    while bits.any():  # radical inverse in base 2
        u2 += (bits & 1) * scale
        bits >>= 1
        scale *= 0.5
    r = np.sqrt(u1)
    phi = 2.0 * np.pi * u2
    return np.stack([r * np.cos(phi), r * np.sin(phi), np.sqrt(1.0 - u1)], -1)


def tangent_frames(n: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Two unit tangents (t, b) completing unit normals ``n`` (n, 3) to right-handed frames (Duff et al. 2017)."""
    s = np.where(n[:, 2] >= 0.0, 1.0, -1.0)
    a = -1.0 / (s + n[:, 2])
    b = n[:, 0] * n[:, 1] * a
    t = np.stack([1.0 + s * n[:, 0] ** 2 * a, s * b, -s * n[:, 0]], -1)
    bb = np.stack([b, s + n[:, 1] ** 2 * a, -n[:, 1]], -1)
    return t, bb


def occlusion(world, points: np.ndarray, normals: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """(n,) occlusion in [0, 1] of hit ``points`` with unit ``normals`` (facing the viewer) on primitives ``idx``."""
    light = world.spec.light
    R, k = float(light.ao_radius), int(light.ao_samples)
    out = np.zeros(len(points))
    if not world.groups or len(points) == 0:
        return out
    on_object = world.obj_ids[idx] != 0
    near = on_object.copy()
    for g in world.groups:
        d = points - g.centre
        near |= np.einsum("ij,ij->i", d, d) < (g.radius + R) ** 2
    base = hemisphere_set(k)
    for objects_only in (True, False):
        rows = np.nonzero(near & (on_object != objects_only))[0]
        if rows.size == 0:
            continue
        p, n = points[rows], normals[rows]
        t1, t2 = tangent_frames(n)
        cells = np.floor(p / JITTER_CELL).astype(np.int64)
        ang = 2.0 * np.pi * cell_random(cells, _SEED)
        c, s = np.cos(ang)[:, None], np.sin(ang)[:, None]
        # direction j of point i: (x cos - y sin) t1 + (x sin + y cos) t2 + z n
        x, y, z = base[:, 0][None, :], base[:, 1][None, :], base[:, 2][None, :]
        a, b = x * c - y * s, x * s + y * c
        d = a[..., None] * t1[:, None, :] + b[..., None] * t2[:, None, :] + z[..., None] * n[:, None, :]
        o = np.repeat(p + EPS * n, k, axis=0)
        t, _ = world.cast(o, d.reshape(-1, 3), tmax=R, background=not objects_only)
        w = np.clip(1.0 - t / R, 0.0, 1.0)  # t = R where nothing is hit within R
        out[rows] = w.reshape(-1, k).mean(axis=1)
    return out
