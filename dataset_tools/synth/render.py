"""Render a view of a synthetic scene: supersampled RGB plus exact centre-ray depth, instance ids and hit points."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dataset_tools.synth.cameras import View
from dataset_tools.synth.raycast import World

SUPERSAMPLE = 3  # 3x3 regular sub-pixel grid; its middle sample is the pixel centre
CHUNK_RAYS = 1 << 16  # rays per batch (keeps temporaries cache- and memory-friendly)


@dataclass
class Rendering:
    """Outputs of :func:`render`; depth, instance and points come from the ray through each pixel centre."""

    rgb: np.ndarray  # (H, W, 3) float64 in [0, 1], mean of the supersamples
    depth: np.ndarray  # (H, W) float64 camera z of the centre-ray hit
    instance: np.ndarray  # (H, W) uint8 object id at the centre ray, 0 = background
    points: np.ndarray  # (H, W, 3) float64 world point hit by the centre ray

    def rgb8(self) -> np.ndarray:
        return np.round(self.rgb * 255.0).astype(np.uint8)


def render(world: World, view: View, supersample: int = SUPERSAMPLE) -> Rendering:
    """Ray-cast ``view`` in ``world``; every pixel hits a surface (the scenes are enclosed)."""
    if supersample < 1 or supersample % 2 == 0:
        raise ValueError("supersample must be odd (its middle sample is the pixel centre)")
    W, H, s = view.camera.width, view.camera.height, supersample
    offs = (np.arange(s) + 0.5) / s
    mid = s // 2
    rgb = np.zeros((H, W, 3))
    depth = np.zeros((H, W))
    inst = np.zeros((H, W), dtype=np.uint8)
    pts = np.zeros((H, W, 3))
    origin = view.center[None, :]
    rad_per_sample = 1.0 / (view.camera.fx * s)
    rows_per_chunk = max(1, CHUNK_RAYS // (W * s * s))
    for i0 in range(0, H, rows_per_chunk):
        i1 = min(H, i0 + rows_per_chunk)
        ii, jj, a, b = np.meshgrid(np.arange(i0, i1), np.arange(W), np.arange(s), np.arange(s), indexing="ij")
        v = ii + offs[a]
        u = jj + offs[b]
        d = view.rays(u.ravel().astype(np.float64), v.ravel().astype(np.float64))
        t, idx = world.cast(origin, d)
        if np.any(idx < 0):
            raise RuntimeError(f"{view.name}: some rays escape the scene (it must be enclosed)")
        col = world.shade(origin, d, t, idx, rad_per_sample)
        shape = (i1 - i0, W, s, s)
        rgb[i0:i1] = col.reshape(*shape, 3).mean(axis=(2, 3))
        t = t.reshape(shape)[:, :, mid, mid]
        depth[i0:i1] = t  # ray directions have camera z = 1
        inst[i0:i1] = world.obj_ids[idx.reshape(shape)[:, :, mid, mid]]
        dc = d.reshape(*shape, 3)[:, :, mid, mid]
        pts[i0:i1] = origin[0] + t[..., None] * dc
    return Rendering(rgb, depth, inst, pts)


def centre_depth(world: World, view: View) -> np.ndarray:
    """(H, W) camera z of the surface hit by the ray through each pixel centre (no shading): the same
    depth :func:`render` returns, at a fraction of its cost."""
    W, H = view.camera.width, view.camera.height
    jj, ii = np.meshgrid(np.arange(W, dtype=np.float64) + 0.5, np.arange(H, dtype=np.float64) + 0.5)
    t = np.empty(H * W)
    d = view.rays(jj.ravel(), ii.ravel())
    for s in range(0, H * W, CHUNK_RAYS):
        t[s : s + CHUNK_RAYS], idx = world.cast(view.center[None, :], d[s : s + CHUNK_RAYS])
        if np.any(idx < 0):
            raise RuntimeError(f"{view.name}: some rays escape the scene (it must be enclosed)")
    return t.reshape(H, W)  # ray directions have camera z = 1
