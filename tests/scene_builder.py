"""Helpers for tests: write small scene folders in the Inpaint360GS layout with pycolmap.

Scenes are built from known cameras, images and points, so tests can compare what the loader
returns against ground truth.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path

import cv2
import numpy as np
import pycolmap
import torch

from inpaint360gs.core.camera import Camera


def orbit_cameras(n: int, *, radius: float = 4.0, height: float = 1.0, width: int = 64, h: int = 48, f: float = 60.0, prefix: str = "IMG_", phase: float = 0.0) -> list[Camera]:
    """``n`` cameras on a circle around the origin looking at it (z up)."""
    cams = []
    for i in range(n):
        a = 2 * math.pi * i / n + phase
        eye = (radius * math.cos(a), radius * math.sin(a), height)
        cams.append(Camera.look_at(eye, (0, 0, 0), (0, 0, 1), f, f, width / 2, h / 2, width, h, name=f"{prefix}{i:03d}.png"))
    return cams


def write_model(
    sparse: Path,
    cameras: Sequence[Camera],
    points: np.ndarray,
    colors: np.ndarray,
    *,
    model: str = "PINHOLE",
    params: Sequence[float] | None = None,
) -> None:
    """COLMAP binary model: one camera per view (or ``params`` for a given ``model``), poses, points."""
    rec = pycolmap.Reconstruction()
    for i, cam in enumerate(cameras, start=1):
        if params is not None:
            p = list(params)
        elif model == "SIMPLE_PINHOLE":
            p = [cam.fx, cam.cx, cam.cy]
        else:
            p = [cam.fx, cam.fy, cam.cx, cam.cy]
        rec.add_camera_with_trivial_rig(pycolmap.Camera(model=model, width=cam.width, height=cam.height, params=p, camera_id=i))
        R = cam.R.double().numpy()
        t = cam.t.double().numpy()
        pose = pycolmap.Rigid3d(pycolmap.Rotation3d(R), t)
        rec.add_image_with_trivial_frame(pycolmap.Image(name=cam.name, camera_id=i, image_id=i), pose)
    for xyz, rgb in zip(np.asarray(points, dtype=np.float64), np.asarray(colors)):
        rec.add_point3D(xyz, pycolmap.Track(), np.asarray(np.round(np.asarray(rgb) * 255), dtype=np.uint8))
    sparse.mkdir(parents=True, exist_ok=True)
    rec.write_binary(str(sparse))


def write_png(path: Path, rgb: np.ndarray | torch.Tensor) -> None:
    a = rgb.detach().cpu().numpy() if isinstance(rgb, torch.Tensor) else np.asarray(rgb)
    if a.dtype.kind == "f":
        a = (np.clip(a, 0, 1) * 255 + 0.5).astype(np.uint8)
    path.parent.mkdir(parents=True, exist_ok=True)
    assert cv2.imwrite(str(path), cv2.cvtColor(a, cv2.COLOR_RGB2BGR) if a.ndim == 3 else a)


def simple_scene(
    root: Path,
    *,
    n_train: int = 10,
    n_test: int = 3,
    width: int = 64,
    height: int = 48,
    images: dict[str, np.ndarray] | None = None,
    points: np.ndarray | None = None,
    colors: np.ndarray | None = None,
    seed: int = 0,
) -> tuple[list[Camera], np.ndarray]:
    """A scene with ``n_train`` IMG_* and ``n_test`` test_* orbit views; random images unless given."""
    rng = np.random.default_rng(seed)
    cams = orbit_cameras(n_train, width=width, h=height) + orbit_cameras(n_test, width=width, h=height, prefix="test_", phase=0.3)
    if points is None:
        points = rng.uniform(-1, 1, size=(50, 3))
        colors = rng.uniform(0, 1, size=(50, 3))
    write_model(root / "sparse" / "0", cams, points, colors)
    for c in cams:
        img = images[c.name] if images is not None else rng.integers(0, 256, size=(height, width, 3), dtype=np.uint8)
        write_png(root / "images" / c.name, img)
    return cams, points
