"""The rasterizer backend interface and its one registry of names.

A backend composites projected 2D Gaussians into pixels (the rasterize-to-pixels step of 3DGS,
paper Sec. 3.1 Eq. 1). Each backend is one module ``inpaint360gs/render/<name>_backend.py`` that
defines ``BACKEND``, an instance of a :class:`RasterizerBackend` subclass; the registry finds them
by that file-name pattern, so adding a backend touches one file. Backend modules import their heavy
dependencies (numba, gsplat) lazily, inside methods, so listing backends stays cheap.
"""

from __future__ import annotations

import abc
import importlib
import pkgutil
from dataclasses import dataclass
from functools import cache
from pathlib import Path
from typing import ClassVar

import torch

from inpaint360gs.core.errors import InputError


@dataclass
class Splats:
    """Gaussians projected into one image: the rasterizer's input (culled ones have ``radii == 0``)."""

    means2d: torch.Tensor  # (N, 2) pixel coordinates of the centres
    conics: torch.Tensor  # (N, 3) inverse 2D covariance (a, b, c) = [[a, b], [b, c]]
    opacities: torch.Tensor  # (N,) in [0, 1]
    radii: torch.Tensor  # (N,) int, 3-sigma radius in pixels, 0 = culled
    depths: torch.Tensor  # (N,) camera-space z of the centres (compositing order)
    width: int
    height: int
    # also leave on ``means2d.absgrad`` (N, 2) the sums over each Gaussian's pixels of the absolute
    # per-pixel gradients of its centre, at backward (AbsGS's densification statistic, gs/strategy.py)
    absgrad: bool = False


class RasterizerBackend(abc.ABC):
    """Composite per-Gaussian channels front to back with the 3DGS rules (:mod:`.tiles`)."""

    name: ClassVar[str]
    # "auto" picks the highest-priority available backend that runs tensors of this device and dtype
    priority: ClassVar[int] = 0
    device_type: ClassVar[str] = "cpu"  # the torch device type the backend runs on ("any": every device)
    auto_dtypes: ClassVar[tuple[torch.dtype, ...]] = (torch.float32,)  # dtypes "auto" may send it

    @abc.abstractmethod
    def available(self) -> bool:
        """True when the backend can run in this process (its libraries import, its device exists)."""

    @abc.abstractmethod
    def rasterize(self, splats: Splats, channels: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Composite (N, C) per-Gaussian ``channels`` -> ((H, W, C) sum of c a T, (H, W) alpha = 1 - T_final).
        Differentiable w.r.t. the splats' means2d, conics, opacities and the channels."""

    def project_and_shade(self, gaussians, sh: torch.Tensor, camera, degree: int, *, near: float, far: float, eps2d: float):
        """Optional fused projection + SH colour: (means2d, conics, depths, radii, rgb) or None to use the
        shared torch projection (:mod:`.projection`) and SH (:mod:`.sh`)."""
        return None


@cache
def _registry() -> dict[str, RasterizerBackend]:
    found = {}
    for mod in pkgutil.iter_modules([str(Path(__file__).resolve().parent)]):  # the backend files beside this one
        if mod.name.endswith("_backend"):
            backend = importlib.import_module(f"{__package__}.{mod.name}").BACKEND
            found[backend.name] = backend
    return dict(sorted(found.items(), key=lambda kv: -kv[1].priority))


def backend_names() -> list[str]:
    """Every registered backend name, highest priority first (what ``--backend`` accepts besides "auto")."""
    return list(_registry())


def backend_choices() -> list[str]:
    """What ``--backend`` accepts: "auto" and every registered name."""
    return ["auto", *backend_names()]


def available_backends() -> list[str]:
    """Backends usable in this process."""
    return [n for n, b in _registry().items() if b.available()]


def get_backend(name: str) -> RasterizerBackend:
    """The backend registered as ``name``; :class:`InputError` for an unknown name."""
    reg = _registry()
    if name not in reg:
        raise InputError(f"unknown rasterizer backend {name!r}; choose one of {', '.join(backend_choices())}", "backend")
    return reg[name]


def preferred_device(name: str) -> torch.device:
    """Where a stage that optimises Gaussians with backend ``name`` keeps them: on the GPU for gsplat
    (and for "auto" when gsplat and CUDA are there), else on the CPU."""
    b = get_backend("gsplat") if name in ("gsplat", "auto") else None
    if b is not None and b.available():
        return torch.device("cuda")
    if name == "gsplat":
        raise InputError(f"rasterizer backend 'gsplat' is not available here (available: {', '.join(available_backends())})", "backend")
    return torch.device("cpu")


def resolve_backend(name: str, device: torch.device, dtype: torch.dtype) -> RasterizerBackend:
    """The backend to use for tensors on ``device``: "auto" = the highest-priority available one that runs
    that device and dtype (gsplat on CUDA, numba for float32 on CPU, else torch); a named one is checked."""
    if name == "auto":
        for b in _registry().values():
            if b.device_type in (device.type, "any") and dtype in b.auto_dtypes and b.available():
                return b
        return get_backend("torch")
    b = get_backend(name)
    if not b.available():
        raise InputError(f"rasterizer backend {name!r} is not available here (available: {', '.join(available_backends())})", "backend")
    if b.device_type == "cuda" and device.type == "cpu":
        # gsplat is the GPU's rasterizer: the stages that optimise keep their Gaussians on the GPU
        # (preferred_device); what a stage keeps on the CPU renders with the CPU's best backend
        return resolve_backend("auto", device, dtype)
    if b.device_type != device.type and b.device_type != "any":
        raise InputError(f"the {name} backend runs on {b.device_type.upper()} tensors, got {device}", "backend")
    return b
