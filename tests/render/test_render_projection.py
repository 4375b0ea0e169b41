"""EWA projection and SH colour against closed forms (render/projection.py, render/sh.py)."""

from __future__ import annotations

import math

import pytest
import torch

from inpaint360gs.core.camera import Camera
from inpaint360gs.core.gaussians import quat_to_rotmat
from inpaint360gs.render.projection import covariance_3d, project_gaussians
from inpaint360gs.render.sh import SH_C1, eval_sh, sh_basis, sh_to_rgb

D = torch.float64


def _cam(width=64, height=48, fx=50.0, fy=55.0, cx=None, cy=None) -> Camera:
    cx = width / 2 if cx is None else cx
    cy = height / 2 if cy is None else cy
    return Camera(torch.eye(3, dtype=D), torch.zeros(3, dtype=D), fx, fy, cx, cy, width, height)


def _quat_z(theta: float) -> torch.Tensor:
    return torch.tensor([math.cos(theta / 2), 0.0, 0.0, math.sin(theta / 2)], dtype=D)


def test_gaussian_on_optical_axis_projects_to_principal_point_with_closed_form_covariance():
    cam = _cam(cx=30.0, cy=20.0)
    z, s1, s2, s3, theta = 4.0, 0.05, 0.02, 0.3, 0.7
    means = torch.tensor([[0.0, 0.0, z]], dtype=D)
    quats = _quat_z(theta)[None] * 3.0  # unnormalised on purpose
    log_scales = torch.log(torch.tensor([[s1, s2, s3]], dtype=D))
    p = project_gaussians(means, quats, log_scales, cam, eps2d=0.3)
    assert torch.allclose(p.means2d, torch.tensor([[30.0, 20.0]], dtype=D), atol=1e-12)
    assert p.depths.item() == pytest.approx(z)
    # on the axis J = diag(fx/z, fy/z) x [I 0]: cov2d = J R2 diag(s1^2, s2^2) R2^T J^T + 0.3 I (depth axis drops out)
    c, s = math.cos(theta), math.sin(theta)
    R2 = torch.tensor([[c, -s], [s, c]], dtype=D)
    Jd = torch.diag(torch.tensor([cam.fx / z, cam.fy / z], dtype=D))
    cov = Jd @ R2 @ torch.diag(torch.tensor([s1**2, s2**2], dtype=D)) @ R2.T @ Jd + 0.3 * torch.eye(2, dtype=D)
    assert torch.allclose(p.cov2d[0], torch.stack([cov[0, 0], cov[0, 1], cov[1, 1]]), rtol=1e-12)
    inv = torch.linalg.inv(cov)
    assert torch.allclose(p.conics[0], torch.stack([inv[0, 0], inv[0, 1], inv[1, 1]]), rtol=1e-10)
    # radius: 3 sigma of the larger eigenvalue with the 3DGS guard max(0.1, mid^2 - det)
    a, b, cc = cov[0, 0], cov[0, 1], cov[1, 1]
    mid = 0.5 * (a + cc)
    lam = mid + math.sqrt(max(0.1, float(mid * mid - (a * cc - b * b))))
    assert int(p.radii[0]) == math.ceil(3 * math.sqrt(lam))


def test_off_axis_centre_and_isotropic_covariance():
    cam = _cam()
    x, y, z, s = 0.4, -0.3, 2.5, 0.01
    p = project_gaussians(torch.tensor([[x, y, z]], dtype=D), _quat_z(0.0)[None], torch.full((1, 3), math.log(s), dtype=D), cam, eps2d=0.0)
    assert p.means2d[0, 0].item() == pytest.approx(cam.fx * x / z + cam.cx)
    assert p.means2d[0, 1].item() == pytest.approx(cam.fy * y / z + cam.cy)
    # isotropic: cov2d = s^2 J J^T with the full pinhole Jacobian at the centre
    J = torch.tensor([[cam.fx / z, 0, -cam.fx * x / z**2], [0, cam.fy / z, -cam.fy * y / z**2]], dtype=D)
    cov = s * s * J @ J.T
    assert torch.allclose(p.cov2d[0], torch.stack([cov[0, 0], cov[0, 1], cov[1, 1]]), rtol=1e-12)


def test_jacobian_uses_clamped_direction_outside_1_3_fov():
    cam = _cam(width=40, height=40, fx=40.0, fy=40.0)  # tan(fov/2) = 0.5, so x/z is clamped to 1.3 * 0.5
    x, z, s = 3.0, 1.0, 2.0  # x/z = 3 far beyond the limit; huge Gaussian so it still reaches the image
    p = project_gaussians(torch.tensor([[x, 0.0, z]], dtype=D), _quat_z(0.0)[None], torch.full((1, 3), math.log(s), dtype=D), cam, eps2d=0.0)
    lim = (cam.width - cam.cx) / cam.fx + 0.3 * 0.5 * cam.width / cam.fx
    tx = z * lim
    J = torch.tensor([[cam.fx / z, 0, -cam.fx * tx / z**2], [0, cam.fy / z, 0.0]], dtype=D)
    cov = s * s * J @ J.T
    assert torch.allclose(p.cov2d[0], torch.stack([cov[0, 0], cov[0, 1], cov[1, 1]]), rtol=1e-12)
    assert p.means2d[0, 0].item() == pytest.approx(cam.fx * x / z + cam.cx)  # the centre itself is not clamped


def test_culling_near_far_offscreen_and_finite_gradients():
    cam = _cam()
    means = torch.tensor(
        [[0.0, 0.0, 2.0], [0.0, 0.0, -2.0], [0.0, 0.0, 0.005], [0.0, 0.0, 50.0], [100.0, 0.0, 2.0], [0.0, 0.0, 0.0]],
        dtype=D,
        requires_grad=True,
    )
    n = means.shape[0]
    quats = torch.randn(n, 4, dtype=D, generator=torch.Generator().manual_seed(0)).requires_grad_(True)
    log_scales = torch.full((n, 3), math.log(0.02), dtype=D, requires_grad=True)
    p = project_gaussians(means, quats, log_scales, cam, near=0.01, far=20.0)
    assert p.radii.tolist()[0] > 0
    assert p.radii.tolist()[1:] == [0, 0, 0, 0, 0]  # behind, before near, beyond far, off-screen, at the centre
    (p.means2d.sum() + p.conics.sum()).backward()
    for t in (means, quats, log_scales):
        assert torch.isfinite(t.grad).all()


def test_projection_gradcheck_float64():
    cam = _cam()
    gen = torch.Generator().manual_seed(1)
    means = (torch.randn(5, 3, dtype=D, generator=gen) * 0.3 + torch.tensor([0, 0, 3.0], dtype=D)).requires_grad_(True)
    quats = torch.randn(5, 4, dtype=D, generator=gen).requires_grad_(True)
    log_scales = (torch.randn(5, 3, dtype=D, generator=gen) * 0.3 - 3).requires_grad_(True)

    def f(m, q, s):
        p = project_gaussians(m, q, s, cam)
        return p.means2d, p.conics, p.depths

    assert torch.autograd.gradcheck(f, (means, quats, log_scales))


def test_covariance_is_r_s_s_rt():
    gen = torch.Generator().manual_seed(2)
    q = torch.randn(4, 4, dtype=D, generator=gen)
    ls = torch.randn(4, 3, dtype=D, generator=gen)
    R = quat_to_rotmat(q)
    assert torch.allclose(R @ R.transpose(1, 2), torch.eye(3, dtype=D).expand(4, 3, 3), atol=1e-12)
    assert torch.allclose(torch.linalg.det(R), torch.ones(4, dtype=D))
    S = torch.diag_embed(torch.exp(ls))
    assert torch.allclose(covariance_3d(q, ls), R @ S @ S @ R.transpose(1, 2), rtol=1e-12)


def _sphere_grid(n_theta=48, n_phi=96):
    """Gauss-Legendre in cos(theta) x uniform in phi: exact for the products of degree <= 3 SH."""
    import numpy as np

    x, w = np.polynomial.legendre.leggauss(n_theta)
    phi = (np.arange(n_phi) + 0.5) * 2 * np.pi / n_phi
    ct, ph = np.meshgrid(x, phi, indexing="ij")
    st = np.sqrt(1 - ct**2)
    dirs = np.stack([st * np.cos(ph), st * np.sin(ph), ct], -1).reshape(-1, 3)
    weights = (w[:, None] * np.full(n_phi, 2 * np.pi / n_phi)[None, :]).reshape(-1)
    return torch.from_numpy(dirs), torch.from_numpy(weights)


def test_sh_basis_is_orthonormal_on_the_sphere():
    dirs, w = _sphere_grid()
    B = sh_basis(3, dirs)
    gram = (B * w[:, None]).T @ B
    assert torch.allclose(gram, torch.eye(16, dtype=D), atol=1e-12)


def test_sh_known_values_and_clamp():
    dirs = torch.tensor([[0.0, 1.0, 0.0]], dtype=D)
    sh = torch.zeros(1, 16, 3, dtype=D)
    sh[0, 1] = torch.tensor([1.0, 2.0, -3.0], dtype=D)  # Y_1^-1 = -C1 * y in 3DGS's sign convention
    assert torch.allclose(eval_sh(3, sh, dirs), -SH_C1 * sh[0, 1][None])
    rgb = sh_to_rgb(sh, torch.tensor([[0.0, 2.0, 0.0]], dtype=D), torch.zeros(3, dtype=D), 3)
    expect = torch.clamp_min(-SH_C1 * sh[0, 1] + 0.5, 0.0)
    assert torch.allclose(rgb[0], expect)
    assert rgb[0, 1] == 0.0 and rgb[0, 0] > 0.0  # -2 C1 + 0.5 < 0 is clamped; -C1 + 0.5 > 0 is not


@pytest.mark.parametrize("degree", [0, 1, 2, 3])
def test_numba_projection_and_sh_match_the_torch_reference(degree):
    """The fused numba kernels (hand-written backward) against autograd of projection.py + sh.py in float64."""
    pytest.importorskip("numba")
    from inpaint360gs.render.numba_projection import project_and_shade_numba

    gen = torch.Generator().manual_seed(10 + degree)
    n = 64
    cam = Camera.look_at([0.3, -0.2, -1.0], [0.0, 0.0, 2.0], [0.0, -1.0, 0.0], 50.0, 52.0, 31.0, 25.0, 64, 48).to(dtype=D)
    means = torch.randn(n, 3, generator=gen, dtype=D) * torch.tensor([1.5, 1.0, 1.0], dtype=D) + torch.tensor([0, 0, 2.0], dtype=D)
    means[:4] = torch.tensor([[0.3, -0.2, -1.0]], dtype=D) + torch.tensor([[0, 0, -1.0]], dtype=D)  # behind
    means[4:8, 0] = 30.0  # beyond the 1.3 x FOV clamp (and mostly off-screen)
    quats = torch.randn(n, 4, generator=gen, dtype=D)
    log_scales = torch.randn(n, 3, generator=gen, dtype=D) * 0.7 - 2.5
    log_scales[8:12, 1] = math.log(1e-7)  # nearly flat
    log_scales[4:8] = 1.0  # big, so clamped ones still reach the image
    sh = torch.randn(n, 16, 3, generator=gen, dtype=D) * 0.5
    ups = [torch.randn(s, generator=gen, dtype=D) for s in ((n, 2), (n, 3), (n,), (n, 3))]

    def ref(m, q, s, c):
        p = project_gaussians(m, q, s, cam)
        return p.means2d, p.conics, p.depths, p.radii, sh_to_rgb(c[:, : (degree + 1) ** 2], m, cam.center, degree)

    def run(fn, dtype):
        leaves = [t.to(dtype).clone().requires_grad_(True) for t in (means, quats, log_scales, sh)]
        m2d, con, dep, radii, rgb = fn(*leaves)
        loss = sum((o * u.to(dtype)).sum() for o, u in zip((m2d, con, dep, rgb), ups))
        loss.backward()
        return (m2d, con, dep, radii, rgb), [t.grad.double() for t in leaves]

    (r_m2d, r_con, r_dep, r_rad, r_rgb), r_grads = run(ref, D)
    (m2d, con, dep, rad, rgb), grads = run(lambda m, q, s, c: project_and_shade_numba(m, q, s, c, cam, degree), torch.float32)
    assert (r_rad[:4] == 0).all() and (r_rad > 0).sum() > 30
    assert torch.equal(rad, r_rad)
    for a, b in ((m2d, r_m2d), (con, r_con), (dep, r_dep), (rgb, r_rgb)):
        assert torch.allclose(a.double(), b.detach(), rtol=1e-5, atol=1e-5)
    for name, a, b in zip(("means", "quats", "log_scales", "sh"), grads, r_grads):
        assert float((a - b).norm() / b.norm()) < 1e-5, name
    assert torch.equal(grads[3][:, (degree + 1) ** 2 :], torch.zeros_like(grads[3][:, (degree + 1) ** 2 :]))
