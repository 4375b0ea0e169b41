"""Ray intersection and surface normals of analytic primitives, vectorised over rays (numpy, float64).

Every shape lives in its own local frame (axis shapes along local +z, centred at the origin). Rays
are ``o + t d`` with ``d`` not necessarily unit length, so ``t`` is in units of ``|d|``; a caster
that builds ``d`` with camera-z component 1 gets z-depth directly. Each ``intersect_*`` returns
the smallest root ``t > tmin`` (``inf`` where the ray misses), which makes the same code serve
solids seen from outside and enclosures (a room, a sky dome) seen from inside.

Written by hand because no maintained library here offers batched analytic ray casting on the CPU
(Open3D's RaycastingScene needs meshes and is not installed; meshing would also break exactness).
"""

from __future__ import annotations

import numpy as np

SHAPES = ("ellipsoid", "box", "cylinder", "cone", "capsule", "torus", "rect", "disc")

# Number of parameters of each shape (local frame):
#   ellipsoid (a, b, c) semi-axes          box (hx, hy, hz) half extents
#   cylinder (r, hz) capped, z in [-hz, hz]  cone (r0, r1, hz) frustum, r0 at z=-hz, r1 at z=+hz
#   capsule (r, hz) segment z in [-hz, hz]  torus (R, r) in the xy-plane
#   rect (hx, hy) in the plane z=0          disc (r,) in the plane z=0
N_PARAMS = {"ellipsoid": 3, "box": 3, "cylinder": 2, "cone": 3, "capsule": 2, "torus": 2, "rect": 2, "disc": 1}


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.einsum("...i,...i->...", a, b)


def rows_times(x: np.ndarray, M: np.ndarray) -> np.ndarray:
    """``x @ M.T`` for (n, 3) rows (einsum: single-threaded and steady; BLAS matmul on tall 3-wide arrays
    timed erratically here, up to 10x slower under load)."""
    return np.einsum("ij,kj->ik", x, M)


def norm(x: np.ndarray) -> np.ndarray:
    """Row norms of (n, 3) (faster than ``np.linalg.norm(axis=-1)`` on 3-wide rows)."""
    return np.sqrt(_dot(x, x))


def _nearest(cands: list[np.ndarray], tmin: float) -> np.ndarray:
    """Smallest candidate root above ``tmin``; NaN/invalid candidates must already be ``inf``."""
    t = np.full(np.broadcast_shapes(*[c.shape for c in cands]), np.inf)
    for c in cands:
        ok = (c > tmin) & (c < t)
        t = np.where(ok, c, t)
    return t


def quadratic_roots(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Both real roots of ``a t^2 + b t + c`` (numerically stable form); ``inf`` where none exist."""
    with np.errstate(divide="ignore", invalid="ignore"):
        disc = b * b - 4.0 * a * c
        ok = disc >= 0.0
        sq = np.sqrt(np.where(ok, disc, 0.0))
        q = -0.5 * (b + np.copysign(sq, b))
        # a == 0 leaves the linear root -c/b in t2
        t1 = np.where(ok & (a != 0.0), q / a, np.inf)
        t2 = np.where(ok & (q != 0.0), c / q, np.inf)
    t1 = np.where(np.isfinite(t1), t1, np.inf)
    t2 = np.where(np.isfinite(t2), t2, np.inf)
    return t1, t2


def _sphere_interval(o: np.ndarray, d: np.ndarray, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """Entry/exit ``t`` of a ray with the origin-centred sphere (``inf`` both when it misses)."""
    t1, t2 = quadratic_roots(_dot(d, d), 2.0 * _dot(o, d), _dot(o, o) - radius * radius)
    lo, hi = np.minimum(t1, t2), np.maximum(t1, t2)
    miss = ~np.isfinite(hi)
    return np.where(miss, np.inf, lo), np.where(miss, np.inf, hi)


def intersect_ellipsoid(o, d, p, tmin):
    s = np.asarray(p[:3], dtype=np.float64)
    os_, ds = o / s, d / s
    t1, t2 = quadratic_roots(_dot(ds, ds), 2.0 * _dot(os_, ds), _dot(os_, os_) - 1.0)
    return _nearest([t1, t2], tmin)


def intersect_box(o, d, p, tmin):
    h = np.asarray(p[:3], dtype=np.float64)
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / d
        ta = (-h - o) * inv
        tb = (h - o) * inv
    # a zero direction component gives +-inf (inside the slab) or NaN (0 * inf on the slab plane)
    ta = np.where(np.isnan(ta), -np.inf, ta)
    tb = np.where(np.isnan(tb), np.inf, tb)
    lo, hi = np.minimum(ta, tb), np.maximum(ta, tb)
    # explicit 3-way max/min: numpy reductions over a length-3 last axis are ~10x slower
    tnear = np.maximum(np.maximum(lo[..., 0], lo[..., 1]), lo[..., 2])
    tfar = np.minimum(np.minimum(hi[..., 0], hi[..., 1]), hi[..., 2])
    hit = tnear <= tfar
    return _nearest([np.where(hit, tnear, np.inf), np.where(hit, tfar, np.inf)], tmin)


def _caps(o, d, hz, r_bottom, r_top):
    """Roots with the planes z=-hz (disc radius r_bottom) and z=+hz (r_top)."""
    out = []
    with np.errstate(divide="ignore", invalid="ignore"):
        for z, r in ((-hz, r_bottom), (hz, r_top)):
            if r <= 0.0:
                continue
            t = (z - o[..., 2]) / d[..., 2]
            x = o[..., 0] + t * d[..., 0]
            y = o[..., 1] + t * d[..., 1]
            out.append(np.where(np.isfinite(t) & (x * x + y * y <= r * r), t, np.inf))
    return out


def _within_z(o, d, t, lo, hi):
    z = o[..., 2] + np.where(np.isfinite(t), t, 0.0) * d[..., 2]
    return np.where((z >= lo) & (z <= hi), t, np.inf)


def intersect_cylinder(o, d, p, tmin):
    r, hz = float(p[0]), float(p[1])
    a = d[..., 0] ** 2 + d[..., 1] ** 2
    b = 2.0 * (o[..., 0] * d[..., 0] + o[..., 1] * d[..., 1])
    c = o[..., 0] ** 2 + o[..., 1] ** 2 - r * r
    t1, t2 = quadratic_roots(a, b, c)
    side = [_within_z(o, d, t1, -hz, hz), _within_z(o, d, t2, -hz, hz)]
    return _nearest(side + _caps(o, d, hz, r, r), tmin)


def intersect_cone(o, d, p, tmin):
    r0, r1, hz = float(p[0]), float(p[1]), float(p[2])
    k = (r1 - r0) / (2.0 * hz)  # radius(z) = k z + m
    m = 0.5 * (r0 + r1)
    rz_o = k * o[..., 2] + m
    a = d[..., 0] ** 2 + d[..., 1] ** 2 - (k * d[..., 2]) ** 2
    b = 2.0 * (o[..., 0] * d[..., 0] + o[..., 1] * d[..., 1] - k * d[..., 2] * rz_o)
    c = o[..., 0] ** 2 + o[..., 1] ** 2 - rz_o**2
    t1, t2 = quadratic_roots(a, b, c)
    side = [_within_z(o, d, t1, -hz, hz), _within_z(o, d, t2, -hz, hz)]
    return _nearest(side + _caps(o, d, hz, r0, r1), tmin)


def intersect_capsule(o, d, p, tmin):
    r, hz = float(p[0]), float(p[1])
    a = d[..., 0] ** 2 + d[..., 1] ** 2
    b = 2.0 * (o[..., 0] * d[..., 0] + o[..., 1] * d[..., 1])
    c = o[..., 0] ** 2 + o[..., 1] ** 2 - r * r
    t1, t2 = quadratic_roots(a, b, c)
    cands = [_within_z(o, d, t1, -hz, hz), _within_z(o, d, t2, -hz, hz)]
    for zc, lo, hi in ((-hz, -np.inf, -hz), (hz, hz, np.inf)):
        oc = o - np.array([0.0, 0.0, zc])
        s1, s2 = quadratic_roots(_dot(d, d), 2.0 * _dot(oc, d), _dot(oc, oc) - r * r)
        cands += [_within_z(o, d, s1, lo, hi), _within_z(o, d, s2, lo, hi)]
    return _nearest(cands, tmin)


def intersect_torus(o, d, p, tmin):
    """Quartic ``(|x|^2 - R^2 - r^2)^2 + 4 R^2 (z^2 - r^2) = 0`` solved by companion-matrix eigenvalues.

    Only rays through the bounding sphere are solved; the ray origin is first moved to the sphere
    entry so the quartic is well conditioned, and each real root is polished by Newton steps.
    """
    R, r = float(p[0]), float(p[1])
    o, d = np.broadcast_arrays(o, d)
    n = o.shape[0]
    out = np.full(n, np.inf)
    t_in, t_out = _sphere_interval(o, d, R + r)
    # cull to rays whose part inside the bounding sphere also crosses the slab |z| <= r
    with np.errstate(divide="ignore", invalid="ignore"):
        za, zb = (-r - o[:, 2]) / d[:, 2], (r - o[:, 2]) / d[:, 2]
    flat = d[:, 2] == 0.0
    z_lo = np.where(flat, np.where(np.abs(o[:, 2]) <= r, -np.inf, np.inf), np.minimum(za, zb))
    z_hi = np.where(flat, np.where(np.abs(o[:, 2]) <= r, np.inf, -np.inf), np.maximum(za, zb))
    lo, hi = np.maximum(t_in, z_lo), np.minimum(t_out, z_hi)
    cand = np.nonzero(np.isfinite(t_in) & (t_out > tmin) & (lo <= hi) & (hi > tmin))[0]
    if cand.size == 0:
        return out
    dn = norm(d[cand])
    u = d[cand] / dn[:, None]
    t0 = np.maximum(t_in[cand], tmin) * dn  # start (unit-length parameter) at the sphere entry
    q = o[cand] + t0[:, None] * u
    e = _dot(q, q) - R * R - r * r
    f = _dot(q, u)
    coef = np.stack(
        [
            4.0 * f,
            4.0 * f * f + 2.0 * e + 4.0 * R * R * u[:, 2] ** 2,
            4.0 * f * e + 8.0 * R * R * q[:, 2] * u[:, 2],
            e * e + 4.0 * R * R * (q[:, 2] ** 2 - r * r),
        ],
        axis=-1,
    )
    comp = np.zeros((cand.size, 4, 4))
    comp[:, 1, 0] = comp[:, 2, 1] = comp[:, 3, 2] = 1.0
    comp[:, :, 3] = -coef[:, ::-1]
    roots = np.linalg.eigvals(comp)
    scale = 2.0 * (R + r)
    real = np.abs(roots.imag) <= 1e-6 * scale
    s = np.where(real, roots.real, np.nan)

    def poly(x):
        return (((x + coef[:, 0:1]) * x + coef[:, 1:2]) * x + coef[:, 2:3]) * x + coef[:, 3:4]

    def dpoly(x):
        return ((4.0 * x + 3.0 * coef[:, 0:1]) * x + 2.0 * coef[:, 1:2]) * x + coef[:, 2:3]

    with np.errstate(divide="ignore", invalid="ignore"):
        for _ in range(3):
            step = poly(s) / dpoly(s)
            s = np.where(np.isfinite(step) & (np.abs(step) < 1e-3 * scale), s - step, s)
    # back to the caller's parameter: t = (t0 + s) / |d|
    t = (t0[:, None] + s) / dn[:, None]
    t = np.where(np.isnan(t), np.inf, t)
    out[cand] = _nearest([t[:, i] for i in range(4)], tmin)
    return out


def intersect_rect(o, d, p, tmin):
    hx, hy = float(p[0]), float(p[1])
    with np.errstate(divide="ignore", invalid="ignore"):
        t = -o[..., 2] / d[..., 2]
        x = o[..., 0] + t * d[..., 0]
        y = o[..., 1] + t * d[..., 1]
    ok = np.isfinite(t) & (np.abs(x) <= hx) & (np.abs(y) <= hy)
    return _nearest([np.where(ok, t, np.inf)], tmin)


def intersect_disc(o, d, p, tmin):
    r = float(p[0])
    with np.errstate(divide="ignore", invalid="ignore"):
        t = -o[..., 2] / d[..., 2]
        x = o[..., 0] + t * d[..., 0]
        y = o[..., 1] + t * d[..., 1]
    ok = np.isfinite(t) & (x * x + y * y <= r * r)
    return _nearest([np.where(ok, t, np.inf)], tmin)


INTERSECT = {
    "ellipsoid": intersect_ellipsoid,
    "box": intersect_box,
    "cylinder": intersect_cylinder,
    "cone": intersect_cone,
    "capsule": intersect_capsule,
    "torus": intersect_torus,
    "rect": intersect_rect,
    "disc": intersect_disc,
}


def intersect(shape: str, o: np.ndarray, d: np.ndarray, params, tmin: float = 0.0) -> np.ndarray:
    """Nearest ``t > tmin`` of rays ``o + t d`` (local frame, (n, 3) or broadcastable) with a shape; ``inf`` = miss."""
    o = np.asarray(o, dtype=np.float64)
    d = np.asarray(d, dtype=np.float64)
    t = INTERSECT[shape](o, d, params, tmin)
    return np.broadcast_to(t, np.broadcast_shapes(o.shape[:-1], d.shape[:-1])).copy()


def normal(shape: str, x: np.ndarray, params) -> np.ndarray:
    """Outward unit normal at local surface points ``x`` (n, 3); on edges the face with the smaller residual wins."""
    x = np.asarray(x, dtype=np.float64)
    p = [float(v) for v in params]
    nx = np.zeros_like(x)
    if shape == "ellipsoid":
        nx = x / np.asarray(p[:3]) ** 2
    elif shape == "box":
        h = np.asarray(p[:3])
        k = np.argmin(np.abs(h - np.abs(x)), axis=-1)
        nx[np.arange(len(x)), k] = np.sign(x[np.arange(len(x)), k])
    elif shape in ("cylinder", "cone"):
        if shape == "cylinder":
            r0 = r1 = p[0]
            hz = p[1]
        else:
            r0, r1, hz = p
        k = (r1 - r0) / (2.0 * hz)
        rz = k * x[:, 2] + 0.5 * (r0 + r1)
        rho = np.hypot(x[:, 0], x[:, 1])
        side_res = np.abs(rho - rz) / np.sqrt(1.0 + k * k)
        cap_res = np.abs(np.abs(x[:, 2]) - hz)
        side = side_res <= cap_res
        # side: gradient of x^2 + y^2 - (k z + m)^2 is 2 rho (x/rho, y/rho, -k) on the surface
        safe = np.maximum(rho, 1e-300)[:, None]
        nx[:, 0:2] = np.where(side[:, None], x[:, 0:2] / safe, 0.0)
        nx[:, 2] = np.where(side, -k, np.sign(x[:, 2]))
    elif shape == "capsule":
        r, hz = p
        c = np.zeros_like(x)
        c[:, 2] = np.clip(x[:, 2], -hz, hz)
        nx = x - c
    elif shape == "torus":
        R = p[0]
        rho = np.maximum(np.hypot(x[:, 0], x[:, 1]), 1e-300)
        c = np.stack([x[:, 0] / rho * R, x[:, 1] / rho * R, np.zeros(len(x))], axis=-1)
        nx = x - c
    elif shape in ("rect", "disc"):
        nx[:, 2] = 1.0
    else:
        raise ValueError(f"unknown shape {shape!r}")
    return nx / np.maximum(norm(nx), 1e-300)[:, None]


def bounding_radius(shape: str, params) -> float:
    """Radius of an origin-centred sphere containing the shape (for culling)."""
    p = [float(v) for v in params]
    if shape == "ellipsoid":
        return max(p[:3])
    if shape == "box":
        return float(np.linalg.norm(p[:3]))
    if shape == "cylinder":
        return float(np.hypot(p[0], p[1]))
    if shape == "cone":
        return float(np.hypot(max(p[0], p[1]), p[2]))
    if shape == "capsule":
        return p[0] + p[1]
    if shape == "torus":
        return p[0] + p[1]
    if shape == "rect":
        return float(np.hypot(p[0], p[1]))
    if shape == "disc":
        return p[0]
    raise ValueError(f"unknown shape {shape!r}")
