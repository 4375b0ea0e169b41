"""Projection + SH colour for the numba backend: one fused CPU kernel each way, as a ``torch.autograd.Function``.

The same maths as :func:`.projection.project_gaussians` and :func:`.sh.sh_to_rgb` (which stay the
reference, and what the torch backend uses), written per Gaussian because on CPU the overhead of
the ~150 small torch ops of the autograd version dominates (results/README.md, "Rasterizer"). The backward is derived by hand (chain rule through conic -> 2D covariance -> J R_cam R_q S,
the clamped pinhole Jacobian, quaternion normalisation and the SH basis); tests check it against
autograd of the reference in float64.
"""

from __future__ import annotations

import math

import numpy as np
import torch

import inpaint360gs.render.numba_cache  # noqa: F401  (sets the cache folder before the kernels are defined)
from numba import njit, prange  # isort: skip

from inpaint360gs.core.camera import Camera
from inpaint360gs.render.numba_arrays import set_numba_threads, to_f32
from inpaint360gs.render.sh import SH_C0, SH_C1, SH_C2, SH_C3

# no fastmath: radii and culling must match the reference. It also keeps prange safe for cold/warm-cache
# reproducibility: a prange body is linked into the kernel as a second, re-optimised copy, and without
# fastmath LLVM may not change its results (see the numba_kernels module docstring).
_OPTS = {"error_model": "numpy", "cache": True}
_CHUNK = 256  # Gaussians per parallel work item


@njit(inline="always", **_OPTS)
def _rotmat(w, x, y, z):
    return (
        1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
        2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
        2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y),
    )  # fmt: skip


@njit(inline="always", **_OPTS)
def _basis(x, y, z, out):
    """SH basis up to degree 3 (3DGS order and signs) into ``out`` (16,)."""
    xx, yy, zz, xy, yz, xz = x * x, y * y, z * z, x * y, y * z, x * z
    out[0] = SH_C0
    out[1], out[2], out[3] = -SH_C1 * y, SH_C1 * z, -SH_C1 * x
    out[4], out[5], out[6] = SH_C2[0] * xy, SH_C2[1] * yz, SH_C2[2] * (2.0 * zz - xx - yy)
    out[7], out[8] = SH_C2[3] * xz, SH_C2[4] * (xx - yy)
    out[9], out[10] = SH_C3[0] * y * (3.0 * xx - yy), SH_C3[1] * xy * z
    out[11], out[12] = SH_C3[2] * y * (4.0 * zz - xx - yy), SH_C3[3] * z * (2.0 * zz - 3.0 * xx - 3.0 * yy)
    out[13], out[14] = SH_C3[4] * x * (4.0 * zz - xx - yy), SH_C3[5] * z * (xx - yy)
    out[15] = SH_C3[6] * x * (xx - 3.0 * yy)


@njit(inline="always", **_OPTS)
def _basis_grad(x, y, z, gb):
    """d(sum_k gb_k Y_k)/d(x, y, z) for the degree-3 basis (derivatives of the polynomials in _basis)."""
    xx, yy, zz, xy, yz, xz = x * x, y * y, z * z, x * y, y * z, x * z
    gx = -SH_C1 * gb[3]
    gy = -SH_C1 * gb[1]
    gz = SH_C1 * gb[2]
    gx += SH_C2[0] * y * gb[4] - 2.0 * SH_C2[2] * x * gb[6] + SH_C2[3] * z * gb[7] + 2.0 * SH_C2[4] * x * gb[8]
    gy += SH_C2[0] * x * gb[4] + SH_C2[1] * z * gb[5] - 2.0 * SH_C2[2] * y * gb[6] - 2.0 * SH_C2[4] * y * gb[8]
    gz += SH_C2[1] * y * gb[5] + 4.0 * SH_C2[2] * z * gb[6] + SH_C2[3] * x * gb[7]
    gx += (
        SH_C3[0] * 6.0 * xy * gb[9] + SH_C3[1] * yz * gb[10] - SH_C3[2] * 2.0 * xy * gb[11]
        - SH_C3[3] * 6.0 * xz * gb[12] + SH_C3[4] * (4.0 * zz - 3.0 * xx - yy) * gb[13]
        + SH_C3[5] * 2.0 * xz * gb[14] + SH_C3[6] * (3.0 * xx - 3.0 * yy) * gb[15]
    )  # fmt: skip
    gy += (
        SH_C3[0] * (3.0 * xx - 3.0 * yy) * gb[9] + SH_C3[1] * xz * gb[10] + SH_C3[2] * (4.0 * zz - xx - 3.0 * yy) * gb[11]
        - SH_C3[3] * 6.0 * yz * gb[12] - SH_C3[4] * 2.0 * xy * gb[13] - SH_C3[5] * 2.0 * yz * gb[14]
        - SH_C3[6] * 6.0 * xy * gb[15]
    )  # fmt: skip
    gz += (
        SH_C3[1] * xy * gb[10] + SH_C3[2] * 8.0 * yz * gb[11] + SH_C3[3] * (6.0 * zz - 3.0 * xx - 3.0 * yy) * gb[12]
        + SH_C3[4] * 8.0 * xz * gb[13] + SH_C3[5] * (xx - yy) * gb[14]
    )  # fmt: skip
    return gx, gy, gz


@njit(parallel=True, **_OPTS)
def project_forward(means, quats, log_scales, sh, degree, cam, W, H, near, far, eps2d):
    """-> means2d (N,2), conics (N,3), depths (N,), radii (N,) int32, rgb (N,3); rules of projection.py / sh.py.

    ``cam`` = (R (9, row-major), t (3), centre (3), fx, fy, cx, cy) as float64.
    """
    n = means.shape[0]
    K = (degree + 1) * (degree + 1)
    means2d = np.empty((n, 2), np.float32)
    conics = np.empty((n, 3), np.float32)
    depths = np.empty(n, np.float32)
    radii = np.zeros(n, np.int32)
    rgb = np.empty((n, 3), np.float32)
    fx, fy, cx, cy = cam[15], cam[16], cam[17], cam[18]
    lxn, lxp = cx / fx + 0.3 * 0.5 * W / fx, (W - cx) / fx + 0.3 * 0.5 * W / fx
    lyn, lyp = cy / fy + 0.3 * 0.5 * H / fy, (H - cy) / fy + 0.3 * 0.5 * H / fy
    n_chunks = (n + _CHUNK - 1) // _CHUNK
    for chunk in prange(n_chunks):  # chunks: scratch arrays allocated once per chunk, not per Gaussian
        bas = np.zeros(16)
        for i in range(chunk * _CHUNK, min(n, (chunk + 1) * _CHUNK)):
            mx, my, mz = np.float64(means[i, 0]), np.float64(means[i, 1]), np.float64(means[i, 2])
            px = cam[0] * mx + cam[1] * my + cam[2] * mz + cam[9]
            py = cam[3] * mx + cam[4] * my + cam[5] * mz + cam[10]
            pz = cam[6] * mx + cam[7] * my + cam[8] * mz + cam[11]
            in_depth = pz > near and pz < far
            zs = pz if in_depth else 1.0
            tx = zs * min(max(px / zs, -lxn), lxp)
            ty = zs * min(max(py / zs, -lyn), lyp)
            k0, h0 = fx / zs, -fx * tx / (zs * zs)
            k1, h1 = fy / zs, -fy * ty / (zs * zs)
            m0 = (k0 * cam[0] + h0 * cam[6], k0 * cam[1] + h0 * cam[7], k0 * cam[2] + h0 * cam[8])
            m1 = (k1 * cam[3] + h1 * cam[6], k1 * cam[4] + h1 * cam[7], k1 * cam[5] + h1 * cam[8])
            qw, qx, qy, qz = np.float64(quats[i, 0]), np.float64(quats[i, 1]), np.float64(quats[i, 2]), np.float64(quats[i, 3])
            qn = max(math.sqrt(qw * qw + qx * qx + qy * qy + qz * qz), 1e-12)
            r = _rotmat(qw / qn, qx / qn, qy / qn, qz / qn)
            s0 = math.exp(np.float64(log_scales[i, 0]))
            s1 = math.exp(np.float64(log_scales[i, 1]))
            s2 = math.exp(np.float64(log_scales[i, 2]))
            v00 = (m0[0] * r[0] + m0[1] * r[3] + m0[2] * r[6]) * s0
            v01 = (m0[0] * r[1] + m0[1] * r[4] + m0[2] * r[7]) * s1
            v02 = (m0[0] * r[2] + m0[1] * r[5] + m0[2] * r[8]) * s2
            v10 = (m1[0] * r[0] + m1[1] * r[3] + m1[2] * r[6]) * s0
            v11 = (m1[0] * r[1] + m1[1] * r[4] + m1[2] * r[7]) * s1
            v12 = (m1[0] * r[2] + m1[1] * r[5] + m1[2] * r[8]) * s2
            a = v00 * v00 + v01 * v01 + v02 * v02 + eps2d
            b = v00 * v10 + v01 * v11 + v02 * v12
            c = v10 * v10 + v11 * v11 + v12 * v12 + eps2d
            det = a * c - b * b
            dets = det if det > 0 else 1.0
            u, v = fx * px / zs + cx, fy * py / zs + cy
            means2d[i, 0], means2d[i, 1] = u, v
            conics[i, 0], conics[i, 1], conics[i, 2] = c / dets, -b / dets, a / dets
            depths[i] = pz
            mid = 0.5 * (a + c)
            rad = np.ceil(3.0 * math.sqrt(mid + math.sqrt(max(mid * mid - det, 0.1))))
            if in_depth and det > 0 and u + rad > 0 and u - rad < W and v + rad > 0 and v - rad < H and rad < 2e9:
                radii[i] = int(rad)
            # colour: max(SH(dir) + 0.5, 0), dir from the camera centre
            if degree > 0:
                dx, dy, dz = mx - cam[12], my - cam[13], mz - cam[14]
                nd = max(math.sqrt(dx * dx + dy * dy + dz * dz), 1e-12)
                _basis(dx / nd, dy / nd, dz / nd, bas)
            else:
                bas[0] = SH_C0
            for ch in range(3):
                acc = 0.5
                for k in range(K):
                    acc += bas[k] * sh[i, k, ch]
                rgb[i, ch] = max(acc, 0.0)
    return means2d, conics, depths, radii, rgb


@njit(parallel=True, **_OPTS)
def project_backward(means, quats, log_scales, sh, degree, cam, W, H, near, far, eps2d, g_m2d, g_con, g_dep, g_rgb):
    """Gradients (means (N,3), quats (N,4), log_scales (N,3), sh (N,K,3)) from those of the forward's outputs."""
    n = means.shape[0]
    K = (degree + 1) * (degree + 1)
    d_means = np.zeros((n, 3), np.float32)
    d_quats = np.zeros((n, 4), np.float32)
    d_ls = np.zeros((n, 3), np.float32)
    d_sh = np.zeros(sh.shape, np.float32)
    fx, fy, cx, cy = cam[15], cam[16], cam[17], cam[18]
    lxn, lxp = cx / fx + 0.3 * 0.5 * W / fx, (W - cx) / fx + 0.3 * 0.5 * W / fx
    lyn, lyp = cy / fy + 0.3 * 0.5 * H / fy, (H - cy) / fy + 0.3 * 0.5 * H / fy
    n_chunks = (n + _CHUNK - 1) // _CHUNK
    for chunk in prange(n_chunks):
        rs, drs, dr = np.empty(9), np.empty(9), np.empty(9)
        v0, v1, dv0, dv1, dm0, dm1 = np.empty(3), np.empty(3), np.empty(3), np.empty(3), np.empty(3), np.empty(3)
        bas, gbas = np.zeros(16), np.zeros(16)
        for i in range(chunk * _CHUNK, min(n, (chunk + 1) * _CHUNK)):
            mx, my, mz = np.float64(means[i, 0]), np.float64(means[i, 1]), np.float64(means[i, 2])
            # ---- recompute the forward
            px = cam[0] * mx + cam[1] * my + cam[2] * mz + cam[9]
            py = cam[3] * mx + cam[4] * my + cam[5] * mz + cam[10]
            pz = cam[6] * mx + cam[7] * my + cam[8] * mz + cam[11]
            in_depth = pz > near and pz < far
            zs = pz if in_depth else 1.0
            rx, ry = px / zs, py / zs
            rxc, ryc = min(max(rx, -lxn), lxp), min(max(ry, -lyn), lyp)
            tx, ty = zs * rxc, zs * ryc
            k0, h0 = fx / zs, -fx * tx / (zs * zs)
            k1, h1 = fy / zs, -fy * ty / (zs * zs)
            m0 = (k0 * cam[0] + h0 * cam[6], k0 * cam[1] + h0 * cam[7], k0 * cam[2] + h0 * cam[8])
            m1 = (k1 * cam[3] + h1 * cam[6], k1 * cam[4] + h1 * cam[7], k1 * cam[5] + h1 * cam[8])
            qw, qx, qy, qz = np.float64(quats[i, 0]), np.float64(quats[i, 1]), np.float64(quats[i, 2]), np.float64(quats[i, 3])
            qnorm = math.sqrt(qw * qw + qx * qx + qy * qy + qz * qz)
            qn = max(qnorm, 1e-12)
            w, x, y, z = qw / qn, qx / qn, qy / qn, qz / qn
            r = _rotmat(w, x, y, z)
            s = (math.exp(np.float64(log_scales[i, 0])), math.exp(np.float64(log_scales[i, 1])), math.exp(np.float64(log_scales[i, 2])))
            for row in range(3):
                for col in range(3):
                    rs[3 * row + col] = r[3 * row + col] * s[col]
            for col in range(3):
                v0[col] = m0[0] * rs[col] + m0[1] * rs[3 + col] + m0[2] * rs[6 + col]
                v1[col] = m1[0] * rs[col] + m1[1] * rs[3 + col] + m1[2] * rs[6 + col]
            a = v0[0] * v0[0] + v0[1] * v0[1] + v0[2] * v0[2] + eps2d
            b = v0[0] * v1[0] + v0[1] * v1[1] + v0[2] * v1[2]
            c = v1[0] * v1[0] + v1[1] * v1[1] + v1[2] * v1[2] + eps2d
            det = a * c - b * b
            # ---- conic (c, -b, a) / det -> (a, b, c)
            gA, gB, gC = np.float64(g_con[i, 0]), np.float64(g_con[i, 1]), np.float64(g_con[i, 2])
            if det > 0:
                g_det = -(gA * c - gB * b + gC * a) / (det * det)
                ga = gC / det + g_det * c
                gb = -gB / det - 2.0 * g_det * b
                gc = gA / det + g_det * a
            else:  # the reference substitutes det = 1 (a constant) for a degenerate covariance
                ga, gb, gc = gC, -gB, gA
            # ---- (a, b, c) = (v0.v0, v0.v1, v1.v1) -> v0, v1 -> M rows and R_q S
            for col in range(3):
                dv0[col] = 2.0 * ga * v0[col] + gb * v1[col]
                dv1[col] = gb * v0[col] + 2.0 * gc * v1[col]
            dm0[:] = 0.0
            dm1[:] = 0.0
            for row in range(3):
                for col in range(3):
                    dm0[row] += dv0[col] * rs[3 * row + col]
                    dm1[row] += dv1[col] * rs[3 * row + col]
                    drs[3 * row + col] = m0[row] * dv0[col] + m1[row] * dv1[col]
            # R_q S -> rotation entries and log-scales
            for col in range(3):
                dsc = 0.0
                for row in range(3):
                    dr[3 * row + col] = drs[3 * row + col] * s[col]
                    dsc += drs[3 * row + col] * r[3 * row + col]
                d_ls[i, col] = dsc * s[col]
            # rotation matrix -> normalised quaternion -> quaternion
            dw = 2.0 * (-z * dr[1] + y * dr[2] + z * dr[3] - x * dr[5] - y * dr[6] + x * dr[7])
            dx = 2.0 * (y * dr[1] + z * dr[2] + y * dr[3] - 2.0 * x * dr[4] - w * dr[5] + z * dr[6] + w * dr[7] - 2.0 * x * dr[8])
            dy = 2.0 * (-2.0 * y * dr[0] + x * dr[1] + w * dr[2] + x * dr[3] + z * dr[5] - w * dr[6] + z * dr[7] - 2.0 * y * dr[8])
            dz = 2.0 * (-2.0 * z * dr[0] - w * dr[1] + x * dr[2] + w * dr[3] - 2.0 * z * dr[4] + y * dr[5] + x * dr[6] + y * dr[7])
            if qnorm > 1e-12:
                dot = w * dw + x * dx + y * dy + z * dz
                dw, dx, dy, dz = dw - w * dot, dx - x * dot, dy - y * dot, dz - z * dot
            d_quats[i, 0], d_quats[i, 1], d_quats[i, 2], d_quats[i, 3] = dw / qn, dx / qn, dy / qn, dz / qn
            # ---- M rows = k R_cam row + h R_cam row 2 -> k, h -> zs, tx, ty
            dk0 = dm0[0] * cam[0] + dm0[1] * cam[1] + dm0[2] * cam[2]
            dh0 = dm0[0] * cam[6] + dm0[1] * cam[7] + dm0[2] * cam[8]
            dk1 = dm1[0] * cam[3] + dm1[1] * cam[4] + dm1[2] * cam[5]
            dh1 = dm1[0] * cam[6] + dm1[1] * cam[7] + dm1[2] * cam[8]
            z2, z3 = zs * zs, zs * zs * zs
            dzs = -dk0 * fx / z2 - dk1 * fy / z2 + dh0 * 2.0 * fx * tx / z3 + dh1 * 2.0 * fy * ty / z3
            dtx, dty = -dh0 * fx / z2, -dh1 * fy / z2
            dpx = 0.0
            dpy = 0.0
            # t = zs * clamp(p / zs): the clamp passes gradient only inside its range (inclusive, like torch.clamp)
            dzs += dtx * rxc + dty * ryc
            if -lxn <= rx <= lxp:
                dpx += dtx
                dzs -= dtx * rx
            if -lyn <= ry <= lyp:
                dpy += dty
                dzs -= dty * ry
            # ---- means2d = (fx px / zs + cx, fy py / zs + cy)
            gu, gv = np.float64(g_m2d[i, 0]), np.float64(g_m2d[i, 1])
            dpx += gu * fx / zs
            dpy += gv * fy / zs
            dzs -= (gu * fx * px + gv * fy * py) / z2
            dpz = np.float64(g_dep[i]) + (dzs if in_depth else 0.0)
            gmx = cam[0] * dpx + cam[3] * dpy + cam[6] * dpz
            gmy = cam[1] * dpx + cam[4] * dpy + cam[7] * dpz
            gmz = cam[2] * dpx + cam[5] * dpy + cam[8] * dpz
            # ---- colour
            ddx, ddy, ddz, nd = 0.0, 0.0, 0.0, 1.0
            bas[:] = 0.0
            gbas[:] = 0.0
            if degree > 0:
                ddx, ddy, ddz = mx - cam[12], my - cam[13], mz - cam[14]
                nd = max(math.sqrt(ddx * ddx + ddy * ddy + ddz * ddz), 1e-12)
                ddx, ddy, ddz = ddx / nd, ddy / nd, ddz / nd
                _basis(ddx, ddy, ddz, bas)
            else:
                bas[0] = SH_C0
            for ch in range(3):
                acc = 0.5
                for k in range(K):
                    acc += bas[k] * sh[i, k, ch]
                graw = np.float64(g_rgb[i, ch]) if acc >= 0.0 else 0.0  # clamp at 0 passes gradient where >= 0
                for k in range(K):
                    d_sh[i, k, ch] = bas[k] * graw
                    gbas[k] += sh[i, k, ch] * graw
            if degree > 0:
                gdx, gdy, gdz = _basis_grad(ddx, ddy, ddz, gbas)
                if nd > 1e-12:  # unit-vector normalisation
                    dot = ddx * gdx + ddy * gdy + ddz * gdz
                    gdx, gdy, gdz = gdx - ddx * dot, gdy - ddy * dot, gdz - ddz * dot
                gmx += gdx / nd
                gmy += gdy / nd
                gmz += gdz / nd
            d_means[i, 0], d_means[i, 1], d_means[i, 2] = gmx, gmy, gmz
    return d_means, d_quats, d_ls, d_sh


def _camera_vector(cam: Camera) -> np.ndarray:
    R = cam.R.detach().double().cpu().numpy().reshape(9)
    t = cam.t.detach().double().cpu().numpy()
    centre = -(cam.R.detach().double().cpu().numpy().T @ t)
    return np.concatenate([R, t, centre, [cam.fx, cam.fy, cam.cx, cam.cy]]).astype(np.float64)


class _ProjectNumba(torch.autograd.Function):
    @staticmethod
    def forward(ctx, means, quats, log_scales, sh, cam: Camera, degree: int, near: float, far: float, eps2d: float):
        set_numba_threads()
        args = (to_f32(means), to_f32(quats), to_f32(log_scales), to_f32(sh), degree, _camera_vector(cam), cam.width, cam.height, near, far, eps2d)
        means2d, conics, depths, radii, rgb = project_forward(*args)
        ctx.args = args
        ctx.dtypes = (means.dtype, quats.dtype, log_scales.dtype, sh.dtype)
        radii_t = torch.from_numpy(radii)
        ctx.mark_non_differentiable(radii_t)
        dt = means.dtype
        return tuple(torch.from_numpy(x).to(dt) for x in (means2d, conics, depths, rgb)) + (radii_t,)

    @staticmethod
    def backward(ctx, g_m2d, g_con, g_dep, g_rgb, _g_radii):
        set_numba_threads()
        a = ctx.args
        n = a[0].shape[0]

        def grad(g, shape):
            return np.zeros(shape, np.float32) if g is None else to_f32(g)

        out = project_backward(*a, grad(g_m2d, (n, 2)), grad(g_con, (n, 3)), grad(g_dep, (n,)), grad(g_rgb, (n, 3)))
        grads = tuple(torch.from_numpy(g).to(dt) for g, dt in zip(out, ctx.dtypes))
        return grads + (None, None, None, None, None)


def project_and_shade_numba(
    means: torch.Tensor,
    quats: torch.Tensor,
    log_scales: torch.Tensor,
    sh: torch.Tensor,
    camera: Camera,
    degree: int,
    near: float = 0.01,
    far: float = 1e10,
    eps2d: float = 0.3,
) -> tuple[torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor, torch.Tensor]:
    """(means2d, conics, depths, radii, rgb) like project_gaussians + sh_to_rgb, computed by the numba kernels.

    ``sh`` holds at least (degree+1)^2 coefficients; only those are used and receive gradient.
    """
    k = (degree + 1) ** 2
    means2d, conics, depths, rgb, radii = _ProjectNumba.apply(means, quats, log_scales, sh[:, :k], camera, degree, near, far, eps2d)
    return means2d, conics, depths, radii, rgb
