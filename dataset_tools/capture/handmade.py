"""Small scenes built by hand with exact geometry: closed-form cases for leak removal, validation and unseen masks.

A textured-free floor (z = 0) sampled as a grid of sparse points, a box standing on it (the object to
remove), cameras on a circle looking at the origin. Object-inclusive cameras do not observe floor
points that the box hides from them; object-free ``test_`` cameras observe every floor point in
their frame, so floor points under the box are observed by test views only: exactly the leaked
points. Exact unseen masks come from ray-box intersection, independent of any sparse depth.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import cv2
import numpy as np
import pycolmap

from dataset_tools.capture.layout import write_json, write_mask

BOX_LO = np.array([-0.5, -0.5, 0.0])
BOX_HI = np.array([0.5, 0.5, 0.6])


@dataclass
class HandmadeCamera:
    name: str
    R: np.ndarray
    t: np.ndarray

    @property
    def center(self) -> np.ndarray:
        return -self.R.T @ self.t


@dataclass
class HandmadeScene:
    width: int = 160
    height: int = 120
    focal: float = 110.0
    grid_step: float = 0.1
    extent: float = 2.0
    cameras: list[HandmadeCamera] = field(default_factory=list)

    @property
    def K(self) -> np.ndarray:
        return np.array([[self.focal, 0, self.width / 2], [0, self.focal, self.height / 2], [0, 0, 1.0]])


def look_at(eye: np.ndarray, target: np.ndarray, up=np.array([0.0, 0.0, 1.0])) -> tuple[np.ndarray, np.ndarray]:
    """World->camera (R, t), COLMAP convention (x right, y down, z forward)."""
    z = target - eye
    z = z / np.linalg.norm(z)
    x = np.cross(z, up)
    x = x / np.linalg.norm(x)
    y = np.cross(z, x)
    R = np.stack([x, y, z])
    return R, -R @ eye


def make_scene(n_train: int = 8, n_test: int = 2, radius: float = 3.0, height: float = 2.2) -> HandmadeScene:
    scene = HandmadeScene()
    for k in range(n_train + n_test):
        test = k >= n_train
        ang = 2 * np.pi * ((k - n_train + 0.5) / n_test if test else k / n_train)
        h = height + (0.3 if test else 0.0)
        R, t = look_at(np.array([radius * np.cos(ang), radius * np.sin(ang), h]), np.array([0.0, 0.0, 0.2]))
        name = f"test_{k - n_train:03d}.png" if test else f"IMG_{k:03d}.png"
        scene.cameras.append(HandmadeCamera(name, R, t))
    return scene


def floor_points(scene: HandmadeScene) -> np.ndarray:
    g = np.arange(-scene.extent, scene.extent + 1e-9, scene.grid_step)
    xx, yy = np.meshgrid(g, g)
    return np.stack([xx.ravel(), yy.ravel(), np.zeros(xx.size)], 1)


def project(scene: HandmadeScene, cam: HandmadeCamera, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pixel coordinates (N, 2) (top-left pixel centre at (0.5, 0.5)) and depths (N,)."""
    xc = X @ cam.R.T + cam.t
    uv = xc @ scene.K.T
    return uv[:, :2] / uv[:, 2:3], xc[:, 2]


def segment_hits_box(a: np.ndarray, b: np.ndarray, lo=BOX_LO, hi=BOX_HI) -> np.ndarray:
    """For segments a[i] -> b (b one point), whether they cross the box strictly between the ends (slab test)."""
    d = b - a
    with np.errstate(divide="ignore", invalid="ignore"):
        t1 = (lo - a) / d
        t2 = (hi - a) / d
    tn = np.nanmax(np.minimum(t1, t2), axis=1)
    tf = np.nanmin(np.maximum(t1, t2), axis=1)
    return (tf >= tn) & (tf > 1e-9) & (tn < 1 - 1e-9)


def box_mask(scene: HandmadeScene, cam: HandmadeCamera) -> np.ndarray:
    """Exact silhouette of the box in ``cam`` (convex hull of its projected corners)."""
    corners = np.array([[x, y, z] for x in (BOX_LO[0], BOX_HI[0]) for y in (BOX_LO[1], BOX_HI[1])
                        for z in (BOX_LO[2], BOX_HI[2])])
    uv, _ = project(scene, cam, corners)
    hull = cv2.convexHull((uv * 16).round().astype(np.int32))  # 4 fractional bits, pixel-centre convention
    m = np.zeros((scene.height, scene.width), np.uint8)
    cv2.fillConvexPoly(m, hull - 8, 1, lineType=cv2.LINE_8, shift=4)  # -8 = -0.5 px: centres at +0.5
    return m.astype(bool)


def exact_unseen_mask(scene: HandmadeScene, test_cam: HandmadeCamera) -> np.ndarray:
    """Test-view pixels whose floor point every object-inclusive camera misses (out of frame or box in the way)."""
    jj, ii = np.meshgrid(np.arange(scene.width) + 0.5, np.arange(scene.height) + 0.5)
    rays = np.stack([jj, ii, np.ones_like(jj)], -1).reshape(-1, 3) @ np.linalg.inv(scene.K).T @ test_cam.R
    c = test_cam.center
    s = -c[2] / rays[:, 2]  # ray-floor intersection
    P = c + s[:, None] * rays
    seen = np.zeros(len(P), bool)
    for cam in scene.cameras:
        if cam.name.startswith("test_"):
            continue
        uv, z = project(scene, cam, P)
        inside = (z > 0) & (uv[:, 0] >= 0) & (uv[:, 0] < scene.width) & (uv[:, 1] >= 0) & (uv[:, 1] < scene.height)
        seen |= inside & ~segment_hits_box(P, cam.center)
    return ~seen.reshape(scene.height, scene.width)


def build_reconstruction(scene: HandmadeScene) -> pycolmap.Reconstruction:
    """One PINHOLE camera, all images registered, floor points with exact observations."""
    rec = pycolmap.Reconstruction()
    f, W, H = scene.focal, scene.width, scene.height
    rec.add_camera_with_trivial_rig(pycolmap.Camera(model="PINHOLE", width=W, height=H,
                                                    params=[f, f, W / 2, H / 2], camera_id=1))
    X = floor_points(scene)
    obs: list[list[tuple[int, int]]] = [[] for _ in range(len(X))]  # point -> [(image_id, point2D_idx)]
    for iid, cam in enumerate(scene.cameras, start=1):
        uv, z = project(scene, cam, X)
        vis = (z > 0) & (uv[:, 0] >= 0) & (uv[:, 0] < W) & (uv[:, 1] >= 0) & (uv[:, 1] < H)
        inside_box = np.all((X[:, :2] > BOX_LO[:2]) & (X[:, :2] < BOX_HI[:2]), axis=1)
        if not cam.name.startswith("test_"):
            vis &= ~segment_hits_box(X, cam.center) & ~inside_box  # the box hides these while present
        idx = np.flatnonzero(vis)
        image = pycolmap.Image(name=cam.name, keypoints=uv[idx], camera_id=1, image_id=iid)
        rec.add_image_with_trivial_frame(image, pycolmap.Rigid3d(pycolmap.Rotation3d(cam.R), cam.t))
        for k, p in enumerate(idx):
            obs[p].append((iid, k))
    for p, track in enumerate(obs):
        if len(track) >= 2:
            rec.add_point3D(X[p], pycolmap.Track([pycolmap.TrackElement(i, k) for i, k in track]),
                            np.array([128, 128, 128], np.uint8))
    return rec


def write_scene_folder(scene: HandmadeScene, out: Path, seed: int = 0) -> pycolmap.Reconstruction:
    """A complete scene folder in the Inpaint360GS layout (noise images, exact unseen masks, leaks kept)."""
    rng = np.random.default_rng(seed)
    out = Path(out)
    (out / "images").mkdir(parents=True, exist_ok=True)
    for cam in scene.cameras:
        img = rng.integers(0, 256, (scene.height, scene.width, 3), dtype=np.uint8)
        cv2.imwrite(str(out / "images" / cam.name), img)
        if cam.name.startswith("test_"):
            write_mask(out / "unseen_mask" / cam.name, exact_unseen_mask(scene, cam))
    rec = build_reconstruction(scene)
    (out / "sparse" / "0").mkdir(parents=True, exist_ok=True)
    rec.write(out / "sparse" / "0")
    write_json(out / "scene.json", {"name": out.name, "objects": [{"id": 1, "label": "box"}], "removal_targets": [1]})
    return rec
