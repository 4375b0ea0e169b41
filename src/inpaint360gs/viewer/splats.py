"""The splats the page draws, from numpy alone (no torch: ``inpaint360gs view`` sends the trained
model's splats before torch is imported, so that the browser draws them while the rest loads;
README "Viewer").

* :func:`splat_arrays_np`: Gaussian parameters -> what viser's Gaussian splats take.
* :func:`most_opaque`: the ``max_splats`` most opaque of them (what the page draws at first).
* :func:`read_splats`: a Gaussian PLY's splats (the fields :func:`inpaint360gs.io.ply.read_ply` reads).
* :func:`send_splats`: a PLY's splats sent to a viser server as the page's 'before' node."""

from __future__ import annotations

from pathlib import Path

import numpy as np

SH_C0 = 0.28209479177387814  # inpaint360gs.core.gaussians.SH_C0 (that module imports torch); tests check they agree


def splat_arrays_np(means, log_scales, quats, opacity_logits, dc) -> dict[str, np.ndarray]:
    """``centers`` (N, 3), ``covariances`` (N, 3, 3) ``R S S^T R^T`` (Eq. 1's Sigma; quaternions
    (w, x, y, z), normalised), ``rgbs`` (N, 3) the degree-0 colour ``SH_C0 * dc + 0.5`` in [0, 1],
    ``opacities`` (N, 1) ``sigmoid(logit)``; float32, computed in float64."""
    q = np.asarray(quats, np.float64)
    q = q / np.maximum(np.linalg.norm(q, axis=1, keepdims=True), 1e-12)
    w, x, y, z = q.T
    R = np.stack([1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y),
                  2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x),
                  2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)], axis=1).reshape(-1, 3, 3)  # fmt: skip
    M = R * np.exp(np.asarray(log_scales, np.float64))[:, None, :]  # R S
    return {
        "centers": np.asarray(means, np.float32),
        "covariances": (M @ M.transpose(0, 2, 1)).astype(np.float32),
        "rgbs": np.clip(SH_C0 * np.asarray(dc, np.float64) + 0.5, 0.0, 1.0).astype(np.float32),
        "opacities": (1.0 / (1.0 + np.exp(-np.asarray(opacity_logits, np.float64)))).astype(np.float32)[:, None],
    }


def most_opaque(arr: dict[str, np.ndarray], max_splats: int) -> tuple[dict[str, np.ndarray], np.ndarray | None]:
    """(the ``max_splats`` most opaque of ``arr``, in their order; their indices), or (``arr``, None)
    when ``max_splats`` is 0 or not fewer than all."""
    n = len(arr["opacities"])
    if not 0 < max_splats < n:
        return arr, None
    keep = np.sort(np.argsort(-arr["opacities"][:, 0], kind="stable")[:max_splats])
    return {k: a[keep] for k, a in arr.items()}, keep


def read_splats(path: str | Path) -> dict[str, np.ndarray]:
    """:func:`splat_arrays_np` of the Gaussians in the PLY ``path`` (plyfile; ValueError / KeyError /
    OSError for a file that is not a Gaussian PLY: the caller falls back to the full reader)."""
    from plyfile import PlyData

    v = PlyData.read(str(path))["vertex"]

    def cols(*names: str) -> np.ndarray:
        return np.stack([np.asarray(v[n], np.float64) for n in names], axis=1)

    return splat_arrays_np(cols("x", "y", "z"), cols("scale_0", "scale_1", "scale_2"), cols("rot_0", "rot_1", "rot_2", "rot_3"),
                           np.asarray(v["opacity"], np.float64), cols("f_dc_0", "f_dc_1", "f_dc_2"))  # fmt: skip


def send_splats(server, path: str | Path, max_splats: int) -> tuple:
    """Send the PLY ``path``'s splats (the ``max_splats`` most opaque; 0: all) as the page's
    ``/splats/before`` node. Returns what :class:`inpaint360gs.viewer.app.ViewerApp` keeps of a
    sent node: (the PLY's mtime, ``max_splats``, the indices sent or None for all, the node)."""
    path = Path(path)
    stamp = path.stat().st_mtime
    arr, keep = most_opaque(read_splats(path), max_splats)
    return stamp, max_splats, keep, server.scene.add_gaussian_splats("/splats/before", **arr)
