"""EWA projection of 3D Gaussians to 2D image-space Gaussians (3DGS Sec. 4 / Zwicker et al.).

Pure torch: runs on any device and dtype, and autograd gives the backward, so every rasterizer
backend shares one projection and one set of gradients for it. The rules follow the original
3DGS/gsplat CUDA code: the pinhole Jacobian is taken at the centre with x/z, y/z clamped to 1.3x
the field of view, the 2D covariance is dilated by ``eps2d`` pixels^2 (0.3 like 3DGS), the radius
is 3 sigma of the larger eigenvalue, and Gaussians behind the near plane, beyond the far plane,
with a degenerate 2D covariance or whose 3-sigma square misses the image are culled (radius 0).
"""

from __future__ import annotations

from dataclasses import dataclass

import torch

from inpaint360gs.core.camera import Camera
from inpaint360gs.core.gaussians import quat_to_rotmat


@dataclass
class Projection:
    """Per-Gaussian image-space quantities; culled Gaussians have ``radii == 0`` (their other values are finite but unused)."""

    means2d: torch.Tensor  # (N, 2) pixel coordinates (u, v) of the centre
    conics: torch.Tensor  # (N, 3) inverse 2D covariance (a, b, c) = [[a, b], [b, c]]
    depths: torch.Tensor  # (N,) camera-space z of the centre
    radii: torch.Tensor  # (N,) int32, 3-sigma radius in pixels, 0 = culled
    cov2d: torch.Tensor  # (N, 3) dilated 2D covariance (xx, xy, yy)


def covariance_3d(quats: torch.Tensor, log_scales: torch.Tensor) -> torch.Tensor:
    """World-space covariance R S S^T R^T, (N, 3, 3) (3DGS Eq. 6)."""
    m = quat_to_rotmat(quats) * torch.exp(log_scales)[:, None, :]
    return m @ m.transpose(1, 2)


def project_gaussians(
    means: torch.Tensor,
    quats: torch.Tensor,
    log_scales: torch.Tensor,
    camera: Camera,
    near: float = 0.01,
    far: float = 1e10,
    eps2d: float = 0.3,
) -> Projection:
    """Project Gaussians into ``camera``; differentiable w.r.t. means, quats and log-scales."""
    R = camera.R.to(means)
    t = camera.t.to(means)
    p = means @ R.T + t  # camera space
    x, y, z = p.unbind(-1)
    in_depth = (z > near) & (z < far)
    # culled Gaussians get a harmless z so no inf/NaN enters the graph (0 * inf would poison gradients)
    zs = torch.where(in_depth, z, torch.ones_like(z))
    fx, fy, cx, cy = camera.fx, camera.fy, camera.cx, camera.cy
    W, H = camera.width, camera.height

    # Jacobian of the perspective map at the centre, x/z and y/z clamped to 1.3x the FOV (3DGS / gsplat)
    tan_fovx, tan_fovy = 0.5 * W / fx, 0.5 * H / fy
    tx = zs * torch.clamp(x / zs, -(cx / fx + 0.3 * tan_fovx), (W - cx) / fx + 0.3 * tan_fovx)
    ty = zs * torch.clamp(y / zs, -(cy / fy + 0.3 * tan_fovy), (H - cy) / fy + 0.3 * tan_fovy)
    # rows of M = J @ R_cam (the world -> image Jacobian), written out: batched 3x3 matmuls and
    # per-entry indexing are slow on CPU for small matrices (their backward fills full-size zeros)
    R0, R1, R2 = R.unbind(0)
    M0 = (fx / zs)[:, None] * R0 - (fx * tx / (zs * zs))[:, None] * R2
    M1 = (fy / zs)[:, None] * R1 - (fy * ty / (zs * zs))[:, None] * R2
    RS = quat_to_rotmat(quats) * torch.exp(log_scales)[:, None, :]  # covariance = RS RS^T (3DGS Eq. 6)
    V0 = (M0[:, :, None] * RS).sum(1)
    V1 = (M1[:, :, None] * RS).sum(1)
    a = (V0 * V0).sum(-1) + eps2d  # low-pass dilation, 3DGS adds 0.3 px^2
    b = (V0 * V1).sum(-1)
    c = (V1 * V1).sum(-1) + eps2d
    det = a * c - b * b
    ok_det = det > 0
    det_s = torch.where(ok_det, det, torch.ones_like(det))
    conics = torch.stack([c / det_s, -b / det_s, a / det_s], dim=-1)
    means2d = torch.stack([fx * x / zs + cx, fy * y / zs + cy], dim=-1)

    with torch.no_grad():  # radius: 3 sigma of the larger eigenvalue, as in the 3DGS forward
        mid = 0.5 * (a + c)
        lam = mid + torch.sqrt(torch.clamp_min(mid * mid - det, 0.1))
        radius = torch.ceil(3.0 * torch.sqrt(lam))
        u, v = means2d.unbind(-1)
        on_screen = (u + radius > 0) & (u - radius < W) & (v + radius > 0) & (v - radius < H)
        keep = in_depth & ok_det & on_screen & torch.isfinite(radius)
        radii = torch.where(keep, radius, torch.zeros_like(radius)).to(torch.int32)
    return Projection(means2d=means2d, conics=conics, depths=z, radii=radii, cov2d=torch.stack([a, b, c], -1))
