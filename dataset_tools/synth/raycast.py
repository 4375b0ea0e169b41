"""A world of primitives that answers nearest-hit ray queries and shades hit points.

Background primitives (floor, walls, dome) are tested against every ray; each object first against
its bounding sphere, so its primitives only see the rays that can reach it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from dataset_tools.synth import shapes
from dataset_tools.synth.occlusion import occlusion
from dataset_tools.synth.spec import Light, Prim, SceneSpec, euler_matrix
from dataset_tools.synth.textures import albedo


@dataclass
class _Compiled:
    prim: Prim
    R: np.ndarray  # world -> local rotation
    c: np.ndarray  # world position of the local origin
    obj_id: int  # 0 = background
    radius: float = np.inf  # bounding sphere about ``c`` (culling; see World.cast's ``cull``)


@dataclass
class _Group:
    obj_id: int
    centre: np.ndarray
    radius: float
    members: list[int]


def _rows(a: np.ndarray, idx: np.ndarray) -> np.ndarray:
    """``a[idx]`` for per-ray arrays; a single shared origin (1, 3) is passed through."""
    return a if a.shape[0] == 1 else a[idx]


class World:
    """The primitives of a scene with some objects hidden; ``cast`` gives the nearest hit per ray."""

    def __init__(self, spec: SceneSpec, hidden: set[int] | frozenset[int] = frozenset(), seed: int = 0):
        self.spec = spec
        self.seed = int(seed)
        self.hidden = frozenset(hidden)
        self.prims: list[_Compiled] = []
        self.background: list[int] = []
        self.groups: list[_Group] = []
        for p in spec.background:
            self.background.append(len(self.prims))
            self.prims.append(_Compiled(p, euler_matrix(p.euler).T, np.asarray(p.center, dtype=np.float64), 0))
        for obj in spec.objects:
            if obj.id in self.hidden:
                continue
            members = []
            for p, R, c in obj.world_prims():
                members.append(len(self.prims))
                self.prims.append(_Compiled(p, R, c, obj.id, shapes.bounding_radius(p.shape, p.params) * (1.0 + 1e-9) + 1e-9))
            centre, radius = obj.bounds()
            self.groups.append(_Group(obj.id, centre, radius * (1.0 + 1e-9) + 1e-9, members))
        self.obj_ids = np.array([p.obj_id for p in self.prims], dtype=np.int64)

    def _test(self, k: int, o: np.ndarray, d: np.ndarray, tmin: float) -> np.ndarray:
        cp = self.prims[k]
        ol = shapes.rows_times(o - cp.c, cp.R)
        dl = shapes.rows_times(d, cp.R)
        return shapes.intersect(cp.prim.shape, ol, dl, cp.prim.params, tmin)

    def cast(self, o: np.ndarray, d: np.ndarray, tmin: float = 0.0, tmax: float = np.inf,
             background: bool = True, cull: bool | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Nearest hit ``tmin < t < tmax`` of rays ``o + t d`` ((n, 3) or one origin (3,)) -> (t, primitive index).

        A ray with no such hit gets ``t = tmax`` and index -1. ``background=False`` tests the objects
        only; ``cull`` tests each object primitive only on the rays that reach its bounding sphere
        before the best hit so far (short occlusion rays: most reach one or two primitives). By
        default it is on except in the classic scenes, whose images must stay byte for byte those of
        the committed tables: the culled path gives the same hits, but not provably the same bits.
        """
        if cull is None:
            cull = self.spec.family != "classic"
        d = np.asarray(d, dtype=np.float64).reshape(-1, 3)
        o = np.asarray(o, dtype=np.float64).reshape(-1, 3)
        n = d.shape[0]
        t_best = np.full(n, tmax, dtype=np.float64)
        idx = np.full(n, -1, dtype=np.int64)
        for k in self.background if background else ():
            t = self._test(k, o, d, tmin)
            better = t < t_best
            t_best[better] = t[better]
            idx[better] = k
        for g in self.groups:
            t_in, t_out = shapes._sphere_interval(o - g.centre, d, g.radius)
            sub = np.nonzero((t_out > tmin) & (t_in < t_best))[0]
            if sub.size == 0:
                continue
            os_, ds = _rows(o, sub), d[sub]
            if cull:
                inv_dd = 1.0 / np.einsum("ij,ij->i", ds, ds)
            for k in g.members:
                if cull:  # the ray's interval inside the primitive's bounding sphere: tc -+ half
                    cp = self.prims[k]
                    oc = cp.c - os_
                    tc = np.einsum("ij,ij->i", oc, ds) * inv_dd
                    h2 = cp.radius**2 * inv_dd - (np.einsum("ij,ij->i", oc, oc) * inv_dd - tc * tc)
                    half = np.sqrt(np.maximum(h2, 0.0))
                    ok = np.nonzero((h2 >= 0.0) & (tc + half > tmin) & (tc - half < t_best[sub]))[0]
                    if ok.size == 0:
                        continue
                    rows = sub[ok]
                    t = self._test(k, _rows(os_, ok), ds[ok], tmin)
                else:
                    rows = sub
                    t = self._test(k, os_, ds, tmin)
                better = t < t_best[rows]
                t_best[rows[better]] = t[better]
                idx[rows[better]] = k
        return t_best, idx

    def surface(self, points: np.ndarray, idx: np.ndarray) -> tuple[np.ndarray, list[tuple[int, np.ndarray, np.ndarray]]]:
        """World normals (n, 3) at hit ``points`` of primitives ``idx`` and, per primitive, (k, rows, local points)."""
        normals = np.zeros_like(points)
        parts = []
        for k in np.unique(idx):
            if k < 0:
                continue
            rows = np.nonzero(idx == k)[0]
            cp = self.prims[k]
            xl = shapes.rows_times(points[rows] - cp.c, cp.R)
            normals[rows] = shapes.rows_times(shapes.normal(cp.prim.shape, xl, cp.prim.params), cp.R.T)
            parts.append((int(k), rows, xl))
        return normals, parts

    def shade(self, o: np.ndarray, d: np.ndarray, t: np.ndarray, idx: np.ndarray, rad_per_sample: float) -> np.ndarray:
        """Colour (n, 3) in [0, 1] of the hits: procedural albedo times soft hemisphere + key light
        (times ``1 - ao * occlusion`` when the light has ambient occlusion, ``occlusion.py``).

        ``rad_per_sample`` is the angle one sample covers (for texture band-limiting).
        """
        o = np.asarray(o, dtype=np.float64).reshape(-1, 3)
        dn = shapes.norm(d)
        u = d / dn[:, None]
        pts = o + t[:, None] * d
        normals, parts = self.surface(pts, idx)
        cos = np.einsum("ij,ij->i", normals, u)
        normals = np.where((cos > 0)[:, None], -normals, normals)  # two-sided: face the viewer
        fp = (t * dn) * rad_per_sample / np.maximum(np.abs(cos), 0.15)
        alb = np.zeros_like(pts)
        light = lighting(normals, self.spec.light)
        if self.spec.light.ao > 0:  # off in the classic scenes (spec.Light)
            light *= (1.0 - self.spec.light.ao * occlusion(self, pts, normals, idx))[:, None]
        for k, rows, xl in parts:
            m = self.prims[k].prim.material
            alb[rows] = albedo(m, xl, fp[rows], self.seed)
            if m.unlit:
                light[rows] = 1.0
        return np.clip(alb * light, 0.0, 1.0)


def lighting(n: np.ndarray, light: Light) -> np.ndarray:
    """Irradiance (n, 3): hemisphere sky/bounce blend by n_z plus wrapped-diffuse key (no shadows, see spec.Light)."""
    up = 0.5 + 0.5 * n[:, 2:3]
    amb = up * np.asarray(light.sky) + (1.0 - up) * np.asarray(light.ground)
    ld = np.asarray(light.key_dir, dtype=np.float64)
    ld = ld / np.linalg.norm(ld)
    key = np.clip((np.einsum("ij,j->i", n, ld) + light.wrap) / (1.0 + light.wrap), 0.0, None)[:, None] * np.asarray(light.key)
    return amb + key

