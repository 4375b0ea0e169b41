"""Helpers for tests: small scene folders in the Inpaint360GS layout, built from known cameras, images
and points, so tests can compare what the code returns against ground truth.

* :func:`simple_scene`: random images and points seen by orbit cameras (scene loader, training).
* :func:`box_scene`: the hand-made box scene with exact geometry (leak removal, validation, unseen
  masks). A floor (z = 0) sampled as a grid of sparse points, a box standing on it (the object to
  remove), cameras on a circle looking at the origin. Object-inclusive cameras do not observe floor
  points that the box hides from them; object-free ``test_`` cameras observe every floor point in
  their frame, so floor points under the box are observed by test views only: exactly the leaked
  points. Exact unseen masks come from ray-box intersection, independent of any sparse depth.
"""

from __future__ import annotations

import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from inpaint360gs.core.camera import Camera
from inpaint360gs.core.layout import is_test_name
from inpaint360gs.io import colmap
from inpaint360gs.io.images import write_image, write_mask

write_png = write_image  # RGB (float in [0, 1] or integer) -> file, by the package's image writer


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
    """COLMAP binary model: one camera per view (or ``params`` for a given ``model``), poses, unobserved points."""
    colmap.write_model(sparse, cameras, points, colors, shared_camera=False, camera_model=model, camera_params=params)


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


# --- the hand-made box scene -------------------------------------------------------------------

BOX_LO = np.array([-0.5, -0.5, 0.0])
BOX_HI = np.array([0.5, 0.5, 0.6])


@dataclass
class BoxScene:
    cameras: list[Camera]  # IMG_* object-inclusive, then test_* object-free; one set of intrinsics
    grid_step: float = 0.1
    extent: float = 2.0

    @property
    def width(self) -> int:
        return self.cameras[0].width

    @property
    def height(self) -> int:
        return self.cameras[0].height

    @property
    def K(self) -> np.ndarray:
        return self.cameras[0].K.double().numpy()


def pose(cam: Camera) -> tuple[np.ndarray, np.ndarray]:
    """(R, t) of ``cam`` as float64 numpy."""
    return cam.R.double().numpy(), cam.t.double().numpy()


def centre(cam: Camera) -> np.ndarray:
    R, t = pose(cam)
    return -R.T @ t


def box_scene(n_train: int = 8, n_test: int = 2, radius: float = 3.0, height: float = 2.2,
              width: int = 160, h: int = 120, focal: float = 110.0) -> BoxScene:
    cams = []
    for k in range(n_train + n_test):
        test = k >= n_train
        ang = 2 * np.pi * ((k - n_train + 0.5) / n_test if test else k / n_train)
        eye = (radius * np.cos(ang), radius * np.sin(ang), height + (0.3 if test else 0.0))
        name = f"test_{k - n_train:03d}.png" if test else f"IMG_{k:03d}.png"
        cams.append(Camera.look_at(eye, (0.0, 0.0, 0.2), (0.0, 0.0, 1.0), focal, focal, width / 2, h / 2, width, h, name=name))
    return BoxScene(cams)


def floor_points(scene: BoxScene) -> np.ndarray:
    g = np.arange(-scene.extent, scene.extent + 1e-9, scene.grid_step)
    xx, yy = np.meshgrid(g, g)
    return np.stack([xx.ravel(), yy.ravel(), np.zeros(xx.size)], 1)


def project(cam: Camera, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pixel coordinates (N, 2) (top-left pixel centre at (0.5, 0.5)) and depths (N,)."""
    R, t = pose(cam)
    xc = X @ R.T + t
    uv = xc @ cam.K.double().numpy().T
    return uv[:, :2] / uv[:, 2:3], xc[:, 2]


def in_frame(cam: Camera, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(pixel coordinates, whether each point is in front of ``cam`` and inside its image)."""
    uv, z = project(cam, X)
    return uv, (z > 0) & (uv[:, 0] >= 0) & (uv[:, 0] < cam.width) & (uv[:, 1] >= 0) & (uv[:, 1] < cam.height)


def segment_hits_box(a: np.ndarray, b: np.ndarray, lo=BOX_LO, hi=BOX_HI) -> np.ndarray:
    """For segments a[i] -> b (b one point), whether they cross the box strictly between the ends (slab test)."""
    d = b - a
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = (lo - a) / d
        t2 = (hi - a) / d
    tn = np.nanmax(np.minimum(t1, t2), axis=1)
    tf = np.nanmin(np.maximum(t1, t2), axis=1)
    return (tf >= tn) & (tf > 1e-9) & (tn < 1 - 1e-9)


def box_mask(cam: Camera) -> np.ndarray:
    """Exact silhouette of the box in ``cam`` (convex hull of its projected corners)."""
    corners = np.array([[x, y, z] for x in (BOX_LO[0], BOX_HI[0]) for y in (BOX_LO[1], BOX_HI[1])
                        for z in (BOX_LO[2], BOX_HI[2])])
    uv, _ = project(cam, corners)
    hull = cv2.convexHull((uv * 16).round().astype(np.int32))  # 4 fractional bits, pixel-centre convention
    m = np.zeros((cam.height, cam.width), np.uint8)
    cv2.fillConvexPoly(m, hull - 8, 1, lineType=cv2.LINE_8, shift=4)  # -8 = -0.5 px: centres at +0.5
    return m.astype(bool)


def exact_unseen_mask(scene: BoxScene, test_cam: Camera) -> np.ndarray:
    """Test-view pixels whose floor point every object-inclusive camera misses (out of frame or box in the way)."""
    jj, ii = np.meshgrid(np.arange(test_cam.width) + 0.5, np.arange(test_cam.height) + 0.5)
    R, _ = pose(test_cam)
    rays = np.stack([jj, ii, np.ones_like(jj)], -1).reshape(-1, 3) @ np.linalg.inv(scene.K).T @ R
    c = centre(test_cam)
    s = -c[2] / rays[:, 2]  # ray-floor intersection
    P = c + s[:, None] * rays
    seen = np.zeros(len(P), bool)
    for cam in scene.cameras:
        if not is_test_name(cam.name):
            seen |= in_frame(cam, P)[1] & ~segment_hits_box(P, centre(cam))
    return ~seen.reshape(test_cam.height, test_cam.width)


def box_reconstruction(scene: BoxScene):
    """``pycolmap.Reconstruction``: one PINHOLE camera, all images registered, floor points with exact observations."""
    X = floor_points(scene)
    inside_box = np.all((X[:, :2] > BOX_LO[:2]) & (X[:, :2] < BOX_HI[:2]), axis=1)
    keypoints, tracks = [], [[] for _ in range(len(X))]  # point -> [(camera index, keypoint index)]
    for i, cam in enumerate(scene.cameras):
        uv, vis = in_frame(cam, X)
        if not is_test_name(cam.name):
            vis &= ~segment_hits_box(X, centre(cam)) & ~inside_box  # the box hides these while present
        idx = np.flatnonzero(vis)
        keypoints.append(uv[idx])
        for k, p in enumerate(idx):
            tracks[p].append((i, k))
    keep = [p for p, track in enumerate(tracks) if len(track) >= 2]
    grey = np.full((len(keep), 3), 128, np.uint8)
    return colmap.build_model(scene.cameras, X[keep], grey, tracks=[tracks[p] for p in keep], keypoints=keypoints)


def write_box_scene(scene: BoxScene, out: Path, seed: int = 0):
    """A complete scene folder in the Inpaint360GS layout (noise images, exact unseen masks, leaks kept);
    returns its ``pycolmap.Reconstruction``."""
    rng = np.random.default_rng(seed)
    out = Path(out)
    for cam in scene.cameras:
        write_image(out / "images" / cam.name, rng.integers(0, 256, (cam.height, cam.width, 3), dtype=np.uint8))
        if is_test_name(cam.name):
            write_mask(out / "unseen_mask" / cam.name, exact_unseen_mask(scene, cam))
    rec = box_reconstruction(scene)
    (out / "sparse" / "0").mkdir(parents=True, exist_ok=True)
    rec.write(out / "sparse" / "0")
    scene_json = {"name": out.name, "objects": [{"id": 1, "label": "box"}], "removal_targets": [1]}
    (out / "scene.json").write_text(json.dumps(scene_json, indent=2) + "\n")
    return rec


# --- a scene made of Gaussians: a floor and blobs standing on it (object-field stages) --------------


def blobs_model(centres=((0.45, 0.0, 0.25), (-0.45, 0.15, 0.22)), radius: float = 0.2, seed: int = 0):
    """A Gaussian model of a textured floor (label 0) and solid balls of Gaussians standing on it
    (labels 1, 2, ...); returns (Gaussians, labels (N,) long)."""
    import torch

    from inpaint360gs.core.gaussians import Gaussians

    rng = np.random.default_rng(seed)
    g = np.linspace(-1.2, 1.2, 41)
    fx, fy = np.meshgrid(g, g)
    floor = np.stack([fx.ravel(), fy.ravel(), np.zeros(fx.size)], 1)
    checker = ((np.floor(fx.ravel() / 0.3) + np.floor(fy.ravel() / 0.3)) % 2)[:, None]
    floor_rgb = 0.35 + 0.3 * checker * np.array([[1.0, 0.8, 0.5]])
    pts, rgb, lab, scales = [floor], [floor_rgb], [np.zeros(len(floor))], [np.full(len(floor), 0.045)]
    palette = np.array([[0.9, 0.15, 0.1], [0.1, 0.3, 0.9], [0.2, 0.8, 0.2]])
    for k, c in enumerate(centres, start=1):
        d = rng.normal(size=(500, 3))
        d *= (radius * rng.uniform(0.2, 1.0, size=(500, 1)) ** (1 / 3)) / np.linalg.norm(d, axis=1, keepdims=True)
        pts.append(np.asarray(c) + d)
        rgb.append(np.repeat(palette[(k - 1) % 3][None], 500, 0))
        lab.append(np.full(500, k))
        scales.append(np.full(500, 0.035))
    P = torch.tensor(np.concatenate(pts), dtype=torch.float32)
    C = torch.tensor(np.concatenate(rgb), dtype=torch.float32)
    S = torch.tensor(np.concatenate(scales), dtype=torch.float32)
    model = Gaussians.from_points(P, C, sh_degree=0, init_opacity=0.95, scales=S)
    return model, torch.tensor(np.concatenate(lab), dtype=torch.long)


def blobs_scene(root: Path, *, n_views: int = 16, n_test: int = 2, width: int = 64, height: int = 48, f: float = 55.0, radius: float = 3.0, elevation: float = 1.6, **model_kw):
    """A scene folder whose images are renders of :func:`blobs_model` (test_ views without blob 1),
    with that model's centres as sparse points; returns (root, model, labels)."""
    import torch

    from inpaint360gs.render.api import render

    model, labels = blobs_model(**model_kw)
    cams = orbit_cameras(n_views, radius=radius, height=elevation, width=width, h=height, f=f) + orbit_cameras(
        n_test, radius=radius, height=elevation, width=width, h=height, f=f, prefix="test_", phase=0.3
    )
    free = model.subset(labels != 1)
    with torch.no_grad():
        for c in cams:
            m = free if is_test_name(c.name) else model
            write_image(root / "images" / c.name, render(m, c).color)
    colors = (model.sh0[:, 0] * 0.28209479177387814 + 0.5).clamp(0, 1).numpy()
    colmap.write_model(root / "sparse" / "0", cams, model.means.numpy()[labels.numpy() != 1], colors[labels.numpy() != 1])
    return root, model, labels


def textured_floor(step: float = 0.1, half: float = 1.6) -> Gaussians:
    """Flat opaque Gaussians on the plane z = 0 with a colour ramp and checker (degree 1 SH), ``step``
    apart over [-half, half]^2 (the 3D inpainting tests' floor)."""
    import torch

    from inpaint360gs.core.gaussians import Gaussians

    g = np.arange(-half, half + 1e-9, step)
    x, y = np.meshgrid(g, g)
    pts = np.stack([x.ravel(), y.ravel(), np.zeros(x.size)], 1)
    checker = (np.floor(x.ravel() / 0.3) + np.floor(y.ravel() / 0.3)) % 2
    rgb = np.stack([0.3 + 0.2 * checker + 0.1 * x.ravel(), 0.5 - 0.15 * y.ravel(), 0.2 + 0.5 * checker], 1).clip(0, 1)
    model = Gaussians.from_points(torch.tensor(pts, dtype=torch.float32), torch.tensor(rgb, dtype=torch.float32), sh_degree=1,
                                  init_opacity=0.99, scales=torch.full((len(pts),), 0.75 * step))  # fmt: skip
    model.log_scales[:, 2] = math.log(1e-3)
    return model
