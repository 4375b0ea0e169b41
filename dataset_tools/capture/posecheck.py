"""Pose accuracy of a reconstruction against known true poses, after a similarity (Sim(3)) alignment.

SfM recovers poses only up to a similarity transform, so the estimated camera centres are first
aligned to the true ones (least squares, Umeyama, via pycolmap.estimate_sim3d); then the camera-centre
error is reported in percent of the orbit radius and the rotation error in degrees.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import asdict, dataclass

import numpy as np
import pycolmap

from inpaint360gs.core.errors import InputError

Pose = tuple[np.ndarray, np.ndarray]  # (R world->camera (3, 3), t (3,)), COLMAP convention


@dataclass
class PoseAccuracy:
    matched: int
    missing: list[str]  # true cameras absent from the reconstruction
    orbit_radius: float
    scale: float  # true units per reconstruction unit
    center_err_max_pct: float
    center_err_mean_pct: float
    rot_err_max_deg: float
    rot_err_mean_deg: float
    worst_center: str
    worst_rotation: str

    def to_dict(self) -> dict:
        return asdict(self)

    def passes(self, center_pct: float = 1.0, rot_deg: float = 0.5) -> bool:
        """The targets of the COLMAP path: centre error <= 1% of the orbit radius, rotation error <= 0.5°."""
        return not self.missing and self.center_err_max_pct <= center_pct and self.rot_err_max_deg <= rot_deg


def rotation_angle_deg(Ra: np.ndarray, Rb: np.ndarray) -> float:
    """Angle of the relative rotation Ra Rb^T in degrees (numerically safe near 0)."""
    c = np.clip((np.trace(Ra @ Rb.T) - 1.0) / 2.0, -1.0, 1.0)
    s = np.linalg.norm(Ra @ Rb.T - Rb @ Ra.T) / (2.0 * np.sqrt(2.0))  # |sin|, accurate for small angles
    return float(np.degrees(np.arctan2(s, c)))


def reconstruction_poses(rec: pycolmap.Reconstruction) -> dict[str, Pose]:
    """name -> (R, t) world->camera of every registered image."""
    out = {}
    for iid in rec.reg_image_ids():
        im = rec.image(iid)
        m = im.cam_from_world().matrix()
        out[im.name] = (np.asarray(m[:, :3], float), np.asarray(m[:, 3], float))
    return out


def pose_accuracy(
    estimated: Mapping[str, Pose], true: Mapping[str, Pose], orbit_radius: float | None = None
) -> PoseAccuracy:
    """Align ``estimated`` camera centres to ``true`` ones with a similarity; report the residual errors.

    ``orbit_radius`` defaults to the mean distance of the true camera centres from their centroid.
    """
    names = sorted(set(estimated) & set(true))
    if len(names) < 3:
        raise InputError(f"only {len(names)} cameras in common with the true poses (need >= 3)", "poses")
    c_est = np.array([-estimated[n][0].T @ estimated[n][1] for n in names])
    c_true = np.array([-true[n][0].T @ true[n][1] for n in names])
    if orbit_radius is None:
        orbit_radius = float(np.linalg.norm(c_true - c_true.mean(0), axis=1).mean())
    sim = pycolmap.estimate_sim3d(c_est, c_true)
    if sim is None:
        raise InputError("similarity alignment to the true poses failed (degenerate camera centres)", "poses")
    M = np.asarray(sim.matrix())  # [s R | t], true_from_est
    s = float(sim.scale)
    R_sim = M[:, :3] / s
    aligned = c_est @ M[:, :3].T + M[:, 3]
    c_err = np.linalg.norm(aligned - c_true, axis=1) / orbit_radius * 100.0
    # cam_from_true = cam_from_est ∘ est_from_true, whose rotation is R_est R_sim^T
    r_err = np.array([rotation_angle_deg(estimated[n][0] @ R_sim.T, true[n][0]) for n in names])
    return PoseAccuracy(
        matched=len(names),
        missing=sorted(set(true) - set(estimated)),
        orbit_radius=orbit_radius,
        scale=s,
        center_err_max_pct=float(c_err.max()),
        center_err_mean_pct=float(c_err.mean()),
        rot_err_max_deg=float(r_err.max()),
        rot_err_mean_deg=float(r_err.mean()),
        worst_center=names[int(c_err.argmax())],
        worst_rotation=names[int(r_err.argmax())],
    )


def similarity_to_true(estimated: Mapping[str, Pose], true: Mapping[str, Pose]) -> np.ndarray:
    """The 3x4 [sR | t] mapping reconstruction coordinates to the true frame (for checking points)."""
    names = sorted(set(estimated) & set(true))
    c_est = np.array([-estimated[n][0].T @ estimated[n][1] for n in names])
    c_true = np.array([-true[n][0].T @ true[n][1] for n in names])
    sim = pycolmap.estimate_sim3d(c_est, c_true)
    if sim is None:
        raise InputError("similarity alignment to the true poses failed", "poses")
    return np.asarray(sim.matrix())
