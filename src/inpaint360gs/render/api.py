"""One rendering entry point over interchangeable rasterizer backends (torch, numba CPU, gsplat CUDA).

``render`` = EWA projection (:mod:`.projection`) -> SH colour (:mod:`.sh`) -> rasterize-to-pixels
of the channels [rgb, z, features] by the chosen backend. Depth is paper Eq. 5,
``sum z_i a_i T_i`` (not divided by alpha); features paper Eq. 2. The numba backend runs the same
projection and SH maths in its own fused kernels (:mod:`.numba_projection`), tested against these.
"""

from __future__ import annotations

from dataclasses import dataclass

import torch

from inpaint360gs.core.errors import InputError
from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.core.camera import Camera
from inpaint360gs.render.backends import Splats, available_backends, get_backend, resolve_backend
from inpaint360gs.render.projection import project_gaussians
from inpaint360gs.render.sh import sh_to_rgb

@dataclass
class RenderOutput:
    """What :func:`render` returns; H, W from the camera, N Gaussians, F feature channels."""

    color: torch.Tensor  # (H, W, 3) = sum_i c_i a_i T_i + T_final * background
    depth: torch.Tensor  # (H, W) = sum_i z_i a_i T_i (paper Eq. 5; NOT divided by alpha)
    alpha: torch.Tensor  # (H, W) = 1 - T_final
    features: torch.Tensor | None  # (H, W, F) = sum_i f_i a_i T_i (paper Eq. 2), when requested
    means2d: torch.Tensor  # (N, 2) projected centres in pixels; grad retained for densification
    radii: torch.Tensor  # (N,) int pixel radius (3 sigma), 0 = culled
    depths: torch.Tensor  # (N,) camera-space z of each centre


def _check_inputs(g: Gaussians, camera: Camera, background: torch.Tensor | None, with_features: bool) -> None:
    n = g.means.shape[0] if g.means.ndim == 2 else -1
    expect = {
        "means": (n, 3),
        "log_scales": (n, 3),
        "quats": (n, 4),
        "opacity_logits": (n,),
        "sh0": (n, 1, 3),
    }
    if g.means.ndim != 2 or g.means.shape[1] != 3:
        raise InputError(f"means must have shape (N, 3), got {tuple(g.means.shape)}", "gaussians.means")
    for name, shape in expect.items():
        if tuple(getattr(g, name).shape) != shape:
            raise InputError(f"{name} must have shape {shape}, got {tuple(getattr(g, name).shape)}", f"gaussians.{name}")
    if g.shN.ndim != 3 or g.shN.shape[0] != n or g.shN.shape[2] != 3:
        raise InputError(f"shN must have shape (N, K-1, 3), got {tuple(g.shN.shape)}", "gaussians.shN")
    if with_features and (g.features is None or g.features.ndim != 2 or g.features.shape[0] != n):
        got = None if g.features is None else tuple(g.features.shape)
        raise InputError(f"with_features=True needs features of shape (N, F), got {got}", "gaussians.features")
    if camera.width <= 0 or camera.height <= 0 or camera.fx <= 0 or camera.fy <= 0:
        raise InputError(f"camera {camera.name!r} has invalid size/focal ({camera.width}x{camera.height}, fx={camera.fx}, fy={camera.fy})", "camera")
    if background is not None and tuple(background.shape) != (3,):
        raise InputError(f"background must have shape (3,), got {tuple(background.shape)}", "background")


def rasterize_to_pixels(splats: Splats, channels: torch.Tensor, backend: str = "torch") -> tuple[torch.Tensor, torch.Tensor]:
    """Composite (N, C) channels of projected Gaussians -> ((H, W, C), (H, W) alpha) with one backend's
    kernels (:meth:`RasterizerBackend.rasterize`); ``backend`` names one (not "auto")."""
    return get_backend(backend).rasterize(splats, channels)


def render(
    gaussians: Gaussians,
    camera: Camera,
    *,
    sh_degree: int | None = None,
    background: torch.Tensor | None = None,
    with_features: bool = False,
    backend: str = "auto",
    near: float = 0.01,
    far: float = 1e10,
    eps2d: float = 0.3,
    absgrad: bool = False,
) -> RenderOutput:
    """Render colour, depth (Eq. 5), alpha and optionally features (Eq. 2) of Gaussians from one camera.

    Differentiable w.r.t. every Gaussian parameter; ``means2d`` of the output keeps its gradient.

    Args:
        gaussians: N Gaussians: means (N, 3), log_scales (N, 3), quats (N, 4) (w, x, y, z),
            opacity_logits (N,), sh0 (N, 1, 3), shN (N, K-1, 3), features (N, F) if ``with_features``.
        camera: Pinhole camera (world -> camera R, t; fx, fy, cx, cy, width, height in pixels);
            moved to the Gaussians' device and dtype.
        sh_degree: SH degree to evaluate, 0..``gaussians.sh_degree``; None = all the coefficients hold.
        background: (3,) RGB composited under the residual transmittance; None = black.
        with_features: Also composite ``gaussians.features`` into ``RenderOutput.features``.
        backend: Rasterizer: "auto" (best available for the device and dtype), "torch", "numba" or
            "gsplat"; a CUDA backend asked for CPU tensors falls back to "auto".
        near: Camera-space z (scene units) at or below which a Gaussian is culled.
        far: Camera-space z (scene units) at or beyond which a Gaussian is culled.
        eps2d: Low-pass dilation added to the 2D covariance diagonal, in pixels^2.
        absgrad: At backward, also leave on ``means2d.absgrad`` (N, 2) the sums over each
            Gaussian's pixels of the absolute per-pixel gradients of its centre (AbsGS).

    Returns:
        RenderOutput: color (H, W, 3), depth (H, W) (Eq. 5, not divided by alpha), alpha (H, W),
        features (H, W, F) or None, and per-Gaussian means2d (N, 2) pixels, radii (N,) int pixels
        (0 = culled), depths (N,) camera-space z.

    Raises:
        InputError: A Gaussian tensor, the features, the camera or the background has the wrong
            shape or value; ``sh_degree`` is out of range; the backend is unknown, unavailable, or
            runs on another device.
    """
    g = gaussians
    _check_inputs(g, camera, background, with_features)
    degree = g.sh_degree if sh_degree is None else sh_degree
    if not 0 <= degree <= g.sh_degree:
        raise InputError(f"sh_degree {degree} outside 0..{g.sh_degree} (what the coefficients hold)", "sh_degree")
    dev, dt = g.means.device, g.means.dtype
    rasterizer = resolve_backend(backend, dev, dt)
    bg = torch.zeros(3, device=dev, dtype=dt) if background is None else background.to(device=dev, dtype=dt)
    cam = camera.to(device=dev, dtype=dt)

    sh = torch.cat([g.sh0, g.shN[:, : (degree + 1) ** 2 - 1]], dim=1)
    fused = rasterizer.project_and_shade(g, sh, cam, degree, near=near, far=far, eps2d=eps2d)
    if fused is not None:
        means2d, conics, depths, radii, rgb = fused
    else:
        proj = project_gaussians(g.means, g.quats, g.log_scales, cam, near=near, far=far, eps2d=eps2d)
        means2d, conics, depths, radii = proj.means2d, proj.conics, proj.depths, proj.radii
        rgb = sh_to_rgb(sh, g.means, cam.center, degree)
    parts = [rgb, depths[:, None]]
    if with_features:
        parts.append(g.features.to(dt))
    channels = torch.cat(parts, dim=-1)  # [rgb, z, features]: depth (Eq. 5) and features (Eq. 2) composite like colour
    splats = Splats(means2d, conics, torch.sigmoid(g.opacity_logits), radii, depths, cam.width, cam.height, absgrad=absgrad)
    image, alpha = rasterizer.rasterize(splats, channels)
    out = RenderOutput(
        color=image[..., :3] + (1.0 - alpha)[..., None] * bg,
        depth=image[..., 3],
        alpha=alpha,
        features=image[..., 4:] if with_features else None,
        means2d=means2d,
        radii=radii,
        depths=depths,
    )
    if out.means2d.requires_grad:
        out.means2d.retain_grad()
    return out
