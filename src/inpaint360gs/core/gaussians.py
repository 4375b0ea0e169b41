"""Container for a set of 3D Gaussians (paper Sec. 3.1: position, scale, rotation, opacity, SH colour).

Parameters are stored in their unconstrained form, as in the original 3DGS code: log-scales,
opacity logits, unnormalised quaternions (w, x, y, z). ``features`` holds the optional
per-Gaussian object-ID embedding of the distillation stage (paper Sec. 3.3).
"""

from __future__ import annotations

from dataclasses import dataclass, fields

import torch

SH_C0 = 0.28209479177387814  # Y_0^0, colour = SH_C0 * f_dc + 0.5 (3DGS convention)


def num_sh_bases(degree: int) -> int:
    """Number of SH coefficients per colour channel up to ``degree``: (degree + 1)^2."""
    return (degree + 1) ** 2


def quat_to_rotmat(quats: torch.Tensor) -> torch.Tensor:
    """Rotation matrices (N, 3, 3) from quaternions (N, 4) in (w, x, y, z) order; normalised first."""
    q = quats / quats.norm(dim=-1, keepdim=True).clamp_min(1e-12)
    w, x, y, z = q.unbind(-1)
    return torch.stack(
        [
            1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
            2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
            2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y),
        ],
        dim=-1,
    ).reshape(-1, 3, 3)  # fmt: skip


@dataclass
class Gaussians:
    means: torch.Tensor  # (N, 3) world positions
    log_scales: torch.Tensor  # (N, 3)
    quats: torch.Tensor  # (N, 4) w, x, y, z (normalised on use)
    opacity_logits: torch.Tensor  # (N,)
    sh0: torch.Tensor  # (N, 1, 3) DC SH coefficient (PLY f_dc_*)
    shN: torch.Tensor  # (N, K-1, 3) higher SH coefficients, K = (degree+1)^2 (PLY f_rest_*)
    features: torch.Tensor | None = None  # (N, F) object-ID embedding, optional

    def __len__(self) -> int:
        return self.means.shape[0]

    @property
    def sh_degree(self) -> int:
        """Highest SH degree the coefficients can represent."""
        k = self.shN.shape[1] + 1
        d = round(k**0.5) - 1
        return d

    @property
    def scales(self) -> torch.Tensor:
        """(N, 3) scales, ``exp(log_scales)``."""
        return torch.exp(self.log_scales)

    @property
    def opacities(self) -> torch.Tensor:
        """(N,) opacities in (0, 1), ``sigmoid(opacity_logits)``."""
        return torch.sigmoid(self.opacity_logits)

    @property
    def sh(self) -> torch.Tensor:
        """All SH coefficients, (N, K, 3)."""
        return torch.cat([self.sh0, self.shN], dim=1)

    def tensors(self) -> dict[str, torch.Tensor]:
        """Field name -> tensor, for every field that is not None."""
        return {f.name: getattr(self, f.name) for f in fields(self) if getattr(self, f.name) is not None}

    def map(self, fn) -> "Gaussians":
        """Apply ``fn`` to every tensor (e.g. ``lambda t: t.detach()``)."""
        return Gaussians(**{k: fn(v) for k, v in self.tensors().items()})

    def subset(self, index: torch.Tensor) -> "Gaussians":
        """Gaussians selected by a boolean mask or an index tensor."""
        return self.map(lambda t: t[index])

    def to(self, device=None, dtype=None) -> "Gaussians":
        """A copy with every tensor moved to ``device`` / cast to ``dtype``."""
        return self.map(lambda t: t.to(device=device, dtype=dtype))

    @staticmethod
    def from_points(
        points: torch.Tensor,
        colors: torch.Tensor,
        sh_degree: int = 3,
        init_opacity: float = 0.1,
        scales: torch.Tensor | None = None,
    ) -> "Gaussians":
        """Isotropic Gaussians at ``points`` with RGB ``colors`` in [0, 1] (3DGS initialisation).

        Without ``scales`` each Gaussian's radius is the RMS distance to its 3 nearest neighbours,
        as in the original code.
        """
        points = points.float()
        n = points.shape[0]
        if scales is None:
            from scipy.spatial import cKDTree

            p = points.cpu().numpy()
            k = min(4, n)
            d, _ = cKDTree(p).query(p, k=k)
            d2 = (d[:, 1:] ** 2).mean(axis=1) if k > 1 else torch.ones(n).numpy()
            scales = torch.from_numpy(d2).float().clamp_min(1e-7).sqrt()
        log_scales = torch.log(scales.float().reshape(n, 1).expand(n, 3).clone())
        quats = torch.zeros(n, 4)
        quats[:, 0] = 1.0
        opacity_logits = torch.logit(torch.full((n,), init_opacity))
        sh0 = ((colors.float() - 0.5) / SH_C0).reshape(n, 1, 3)
        shN = torch.zeros(n, num_sh_bases(sh_degree) - 1, 3)
        return Gaussians(points.clone(), log_scales, quats, opacity_logits, sh0, shN)
