"""Gaussians <-> PLY in the layout of the original 3DGS code and common viewers (plyfile).

Vertex properties, all float32, in this order: ``x y z nx ny nz f_dc_0..2 f_rest_0..M-1 opacity
scale_0..2 rot_0..3`` and optionally ``obj_0..F-1`` (the object-ID embedding of paper Sec. 3.3).
``f_rest`` is channel-major as in 3DGS ``save_ply``: the (N, K-1, 3) higher SH coefficients are
transposed to (N, 3, K-1) and flattened, so M = 3(K-1). Opacity is a logit, scales are logs,
``rot`` is an unnormalised quaternion (w, x, y, z). Reading also accepts Gaussian Grouping's
``obj_dc_*`` fields for the embedding. Float32 models round-trip bit-exactly.
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import torch
from plyfile import PlyData, PlyElement

from inpaint360gs.core.errors import InputError
from inpaint360gs.core.files import check_readable
from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.io.atomic import atomic_path

_BASE = ["x", "y", "z", "nx", "ny", "nz", "f_dc_0", "f_dc_1", "f_dc_2"]
_TAIL = ["opacity", "scale_0", "scale_1", "scale_2", "rot_0", "rot_1", "rot_2", "rot_3"]


def ply_field_names(sh_degree: int, num_features: int = 0) -> list[str]:
    """Vertex property names, in file order, for a model of this SH degree and feature width."""
    n_rest = 3 * ((sh_degree + 1) ** 2 - 1)
    return _BASE + [f"f_rest_{i}" for i in range(n_rest)] + _TAIL + [f"obj_{i}" for i in range(num_features)]


def gaussians_to_array(g: Gaussians) -> np.ndarray:
    """Structured float32 vertex array in the 3DGS PLY layout."""
    n = len(g)
    k1 = g.shN.shape[1]

    def cols(t: torch.Tensor) -> np.ndarray:
        return t.detach().cpu().to(torch.float32).reshape(n, -1).numpy()

    parts = [
        cols(g.means),
        np.zeros((n, 3), dtype=np.float32),  # normals: unused, kept for viewer compatibility
        cols(g.sh0.transpose(1, 2)),
        cols(g.shN.transpose(1, 2)),  # (N, 3, K-1) flattened: channel-major like 3DGS
        cols(g.opacity_logits),
        cols(g.log_scales),
        cols(g.quats),
    ]
    nf = 0
    if g.features is not None:
        parts.append(cols(g.features))
        nf = g.features.shape[1]
    names = ply_field_names(round((k1 + 1) ** 0.5) - 1, nf)
    data = np.concatenate(parts, axis=1)
    if data.shape[1] != len(names):
        raise ValueError(f"SH layout with {k1 + 1} bases is not (degree+1)^2")
    out = np.empty(n, dtype=[(name, "f4") for name in names])
    for i, name in enumerate(names):
        out[name] = data[:, i]
    return out


def write_ply(path: str | Path, g: Gaussians) -> None:
    """Write ``g`` as a binary little-endian PLY, atomically."""
    el = PlyElement.describe(gaussians_to_array(g), "vertex")
    with atomic_path(path) as tmp:
        PlyData([el], text=False, byte_order="<").write(str(tmp))


def _numbered(names: list[str], prefix: str) -> list[str]:
    """Properties ``<prefix><int>`` sorted by their number (as the original loader does)."""
    pat = re.compile(rf"^{re.escape(prefix)}(\d+)$")
    found = sorted((int(m.group(1)), n) for n in names if (m := pat.match(n)))
    return [n for _, n in found]


def read_ply(path: str | Path, *, device: torch.device | str = "cpu") -> Gaussians:
    """Read a Gaussian PLY written by this code, the original 3DGS or Gaussian Grouping."""
    path = Path(path)
    check_readable(path, "a Gaussian PLY file", missing="PLY file not found")
    try:
        ply = PlyData.read(str(path))
    except Exception as e:  # plyfile raises PlyHeaderParseError, ValueError, struct errors...
        raise InputError(f"not a readable PLY file ({e.__class__.__name__}: {str(e).splitlines()[0] if str(e) else ''})", path) from None
    if "vertex" not in [el.name for el in ply.elements]:
        raise InputError("PLY has no 'vertex' element", path)
    v = ply["vertex"]
    names = [p.name for p in v.properties]
    required = ["x", "y", "z", "f_dc_0", "f_dc_1", "f_dc_2", *_TAIL]
    missing = [n for n in required if n not in names]
    if missing:
        raise InputError(f"not a Gaussian PLY: missing properties {missing}", path)
    n = v.count
    if n == 0:
        raise InputError("PLY holds no Gaussians", path)

    def stack(fields: list[str]) -> np.ndarray:
        if not fields:
            return np.zeros((n, 0), dtype=np.float32)
        try:
            return np.stack([np.asarray(v[f], dtype=np.float32) for f in fields], axis=1)
        except Exception as e:
            raise InputError(f"truncated or corrupt vertex data ({e.__class__.__name__})", path) from None

    rest = _numbered(names, "f_rest_")
    n_rest = len(rest)
    k1 = n_rest // 3
    degree = round((k1 + 1) ** 0.5) - 1
    if n_rest % 3 or (degree + 1) ** 2 != k1 + 1:
        raise InputError(f"{n_rest} f_rest_* properties is not 3*((degree+1)^2-1) for any SH degree", path)
    obj = _numbered(names, "obj_") or _numbered(names, "obj_dc_")

    def t(a: np.ndarray) -> torch.Tensor:
        return torch.from_numpy(np.ascontiguousarray(a)).to(device)

    means = stack(["x", "y", "z"])
    sh0 = stack(["f_dc_0", "f_dc_1", "f_dc_2"]).reshape(n, 3, 1).transpose(0, 2, 1)
    shN = stack(rest).reshape(n, 3, k1).transpose(0, 2, 1)
    opacity = stack(["opacity"])[:, 0]
    scales = stack(_numbered(names, "scale_"))
    rots = stack(_numbered(names, "rot_"))
    if scales.shape[1] != 3 or rots.shape[1] != 4:
        raise InputError(f"expected scale_0..2 and rot_0..3, found {scales.shape[1]} and {rots.shape[1]}", path)
    arrays = [means, sh0, shN, opacity, scales, rots]
    if not all(np.isfinite(a).all() for a in arrays):
        raise InputError("PLY holds NaN or infinite values", path)
    return Gaussians(
        means=t(means),
        log_scales=t(scales),
        quats=t(rots),
        opacity_logits=t(opacity),
        sh0=t(sh0),
        shN=t(shN),
        features=t(stack(obj)) if obj else None,
    )
