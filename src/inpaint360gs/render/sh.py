"""View-dependent colour from real spherical harmonics up to degree 3 (3DGS convention).

The constants and the basis ordering are those of the original 3DGS code (``eval_sh``); the
colour is ``SH + 0.5`` clamped at 0, as in its rasterizer, so PLY files trained elsewhere render
the same here. Plain torch, so autograd supplies the gradients w.r.t. the coefficients and (through
the viewing direction) the means.
"""

from __future__ import annotations

import torch

from inpaint360gs.core.errors import InputError
from inpaint360gs.core.gaussians import SH_C0

SH_C1 = 0.4886025119029199
SH_C2 = (1.0925484305920792, -1.0925484305920792, 0.31539156525252005, -1.0925484305920792, 0.5462742152960396)
SH_C3 = (
    -0.5900435899266435,
    2.890611442640554,
    -0.4570457994644658,
    0.3731763325901154,
    -0.4570457994644658,
    1.445305721320277,
    -0.5900435899266435,
)


def sh_basis(degree: int, dirs: torch.Tensor) -> torch.Tensor:
    """Real SH basis values (N, (degree+1)^2) along unit directions ``dirs`` (N, 3), 3DGS ordering and signs."""
    x, y, z = dirs.unbind(-1)  # unbind, not [:, i]: one cheap backward instead of one full-size zero fill per index
    out = [torch.full_like(x, SH_C0)]
    if degree >= 1:
        out += [-SH_C1 * y, SH_C1 * z, -SH_C1 * x]
    if degree >= 2:
        xx, yy, zz = x * x, y * y, z * z
        xy, yz, xz = x * y, y * z, x * z
        out += [
            SH_C2[0] * xy,
            SH_C2[1] * yz,
            SH_C2[2] * (2.0 * zz - xx - yy),
            SH_C2[3] * xz,
            SH_C2[4] * (xx - yy),
        ]
    if degree >= 3:
        out += [
            SH_C3[0] * y * (3.0 * xx - yy),
            SH_C3[1] * xy * z,
            SH_C3[2] * y * (4.0 * zz - xx - yy),
            SH_C3[3] * z * (2.0 * zz - 3.0 * xx - 3.0 * yy),
            SH_C3[4] * x * (4.0 * zz - xx - yy),
            SH_C3[5] * z * (xx - yy),
            SH_C3[6] * x * (xx - 3.0 * yy),
        ]
    return torch.stack(out, dim=-1)


def eval_sh(degree: int, sh: torch.Tensor, dirs: torch.Tensor) -> torch.Tensor:
    """Evaluate SH coefficients ``sh`` (N, K>=(degree+1)^2, 3) along unit directions ``dirs`` (N, 3) -> (N, 3)."""
    if not 0 <= degree <= 3:
        raise InputError(f"SH degree must be 0..3, got {degree}", "sh_degree")
    k = (degree + 1) ** 2
    if sh.shape[1] < k:
        raise InputError(f"SH degree {degree} needs {k} coefficients, have {sh.shape[1]}", "sh_degree")
    return (sh_basis(degree, dirs)[:, :, None] * sh[:, :k]).sum(dim=1)


def view_dirs(means: torch.Tensor, cam_center: torch.Tensor) -> torch.Tensor:
    """Unit directions from the camera centre to each mean, (N, 3); differentiable w.r.t. ``means``."""
    d = means - cam_center.to(means)
    # the clamp keeps a Gaussian sitting exactly at the camera centre finite (its colour is then SH_C0 * dc)
    return d / d.norm(dim=-1, keepdim=True).clamp_min(1e-12)


def sh_to_rgb(sh: torch.Tensor, means: torch.Tensor, cam_center: torch.Tensor, degree: int) -> torch.Tensor:
    """RGB per Gaussian seen from ``cam_center``: ``max(SH(dir) + 0.5, 0)`` like the 3DGS rasterizer, (N, 3)."""
    if degree == 0:  # direction unused: skip the normalisation (and its gradient path)
        return torch.clamp_min(SH_C0 * sh[:, 0, :] + 0.5, 0.0)
    return torch.clamp_min(eval_sh(degree, sh, view_dirs(means, cam_center)) + 0.5, 0.0)
