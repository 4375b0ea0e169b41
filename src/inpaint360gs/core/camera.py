"""Pinhole camera shared by the loader, the rasterizer backends and the dataset tools.

Convention (COLMAP/OpenCV, the same as gsplat): camera x right, y down, z forward;
``x_cam = R @ x_world + t`` (COLMAP's ``cam_from_world``); a point projects to
``u = fx * x / z + cx``, ``v = fy * y / z + cy`` in pixel units where pixel (row i, col j)
covers [j, j+1) x [i, i+1), so its centre is (j + 0.5, i + 0.5).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import torch


@dataclass
class Camera:
    R: torch.Tensor  # (3, 3) rotation, world -> camera
    t: torch.Tensor  # (3,) translation, world -> camera
    fx: float
    fy: float
    cx: float
    cy: float
    width: int
    height: int
    name: str = ""

    @property
    def center(self) -> torch.Tensor:
        """Camera centre in world coordinates, ``-R^T t``."""
        return -self.R.T @ self.t

    @property
    def viewmat(self) -> torch.Tensor:
        """4x4 world-to-camera matrix."""
        m = torch.eye(4, dtype=self.R.dtype, device=self.R.device)
        m[:3, :3] = self.R
        m[:3, 3] = self.t
        return m

    @property
    def K(self) -> torch.Tensor:
        """3x3 intrinsic matrix."""
        return torch.tensor(
            [[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]],
            dtype=self.R.dtype,
            device=self.R.device,
        )

    def scaled(self, factor: float) -> "Camera":
        """The same camera for an image downscaled by ``factor`` (e.g. 2, 4, 8).

        Image sizes round like the original 3DGS loader (``round(W / factor)``); intrinsics
        scale by the actual size ratio so pixel centres stay consistent.
        """
        w = max(1, round(self.width / factor))
        h = max(1, round(self.height / factor))
        sx, sy = w / self.width, h / self.height
        return replace(self, fx=self.fx * sx, fy=self.fy * sy, cx=self.cx * sx, cy=self.cy * sy, width=w, height=h)

    def to(self, device: torch.device | str | None = None, dtype: torch.dtype | None = None) -> "Camera":
        """A copy with R and t moved to ``device`` / cast to ``dtype``."""
        return replace(self, R=self.R.to(device=device, dtype=dtype), t=self.t.to(device=device, dtype=dtype))

    @staticmethod
    def look_at(
        eye, target, up, fx: float, fy: float, cx: float, cy: float, width: int, height: int, name: str = ""
    ) -> "Camera":
        """Camera at ``eye`` looking at ``target``; ``up`` is the world up direction (image y points away from it)."""
        eye = torch.as_tensor(eye, dtype=torch.float64)
        target = torch.as_tensor(target, dtype=torch.float64)
        up = torch.as_tensor(up, dtype=torch.float64)
        z = target - eye
        z = z / z.norm()
        x = torch.linalg.cross(z, up)
        if x.norm() < 1e-9:
            raise ValueError("look_at: viewing direction is parallel to the up vector")
        x = x / x.norm()
        y = torch.linalg.cross(z, x)
        R = torch.stack([x, y, z])  # rows: camera axes in world coordinates
        t = -R @ eye
        return Camera(R=R.float(), t=t.float(), fx=fx, fy=fy, cx=cx, cy=cy, width=width, height=height, name=name)


def camera_up(cameras) -> "np.ndarray":
    """World up from the cameras (a sequence of :class:`Camera`): −(mean of their image-down axes), normalised."""
    import numpy as np

    from inpaint360gs.core.errors import InputError

    ys = np.stack([c.R.double().numpy()[1] for c in cameras])
    up = -ys.mean(0)
    n = np.linalg.norm(up)
    if n < 1e-6:
        raise InputError("the training cameras' up directions cancel out; cannot find the scene's up direction")
    return up / n


def nearest_point_to_axes(cameras) -> "np.ndarray":
    """Least-squares point nearest every camera's optical axis (the orbit's look-at point)."""
    import numpy as np

    from inpaint360gs.core.errors import InputError

    A = np.zeros((3, 3))
    b = np.zeros(3)
    for c in cameras:
        d = c.R.double().numpy()[2]  # viewing direction in world coordinates
        P = np.eye(3) - np.outer(d, d)
        A += P
        b += P @ c.center.double().numpy()
    if np.linalg.cond(A) > 1e8:  # all axes parallel: no orbit
        raise InputError("the training cameras' optical axes are (nearly) parallel; the geometric segmenter needs an orbit around the scene")
    return np.linalg.solve(A, b)
