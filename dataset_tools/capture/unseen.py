"""Unseen masks of the object-free test views: derive them from the reconstruction, or import the user's.

An unseen pixel of a test_ view shows a surface that no object-inclusive (training) view saw while
the objects were present (``unseen_mask/`` of the scene layout: 255 = unseen). The paper prepares
these masks for its dataset (supp. Sec. A) without saying how; here is a geometric derivation that needs
only the built scene and an object mask per training view:

1. depth of every test pixel: inverse depth interpolated linearly (exact on planes) between the
   sparse points that test view observes, nearest-neighbour outside their convex hull;
2. back-project each pixel to its surface point X;
3. a training view sees X when X projects in front of it, inside its frame and outside its object
   mask (optionally also not behind the surface that view's own sparse depth shows);
4. X is unseen when no training view sees it and at least one has it inside its frame under the object
   mask: the objects hid it. Surface outside every training frame is no inpainting target (the same rule
   as the synthetic generator's exact masks, docs/architecture.md "Scene format").

Limits (scored against the synthetic generator's exact masks, see the README here): the sparse
depth is only as good as the points around the hole: it is exact for a planar floor, but smooths
over depth edges, so masks bleed near silhouettes. Without ``depth_test``, only the objects in the
masks count as occluders; other occluders make the derived mask too small. Object masks that are
too tight make it too small as well (dilate them with ``mask_dilate_px``).
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np
import pycolmap
from scipy.interpolate import LinearNDInterpolator, NearestNDInterpolator

from dataset_tools.capture.colmap import undistort_mask
from dataset_tools.capture.layout import read_mask
from inpaint360gs.core.errors import InputError
from inpaint360gs.core.layout import TEST_PREFIX, is_image_name, is_test_name
from inpaint360gs.io.atomic import atomic_dir
from inpaint360gs.io.colmap import PINHOLE_MODELS, read_model
from inpaint360gs.io.images import find_mask, write_mask


@dataclass
class UnseenConfig:
    """Options of the geometric derivation (see module docstring)."""

    mask_dilate_px: int = 0  # grow the object masks (for tight hand/SAM masks); exact masks need none
    depth_test: bool = False  # also treat X as hidden behind a training view's own sparse surface
    depth_tolerance: float = 0.05  # relative depth margin of that test
    max_point_error_px: float = 2.0  # ignore sparse points with a larger mean reprojection error
    min_points: int = 8  # a test view needs at least this many observed points for a depth map


@dataclass
class _View:
    name: str
    R: np.ndarray
    t: np.ndarray
    K: np.ndarray
    width: int
    height: int
    obs_xy: np.ndarray  # (M, 2) observed keypoints
    obs_xyz: np.ndarray  # (M, 3) their 3D points


def _views(rec: pycolmap.Reconstruction, max_err: float) -> dict[str, _View]:
    views = {}
    for iid in rec.reg_image_ids():
        im = rec.image(iid)
        cam = rec.camera(im.camera_id)
        if cam.model_name not in PINHOLE_MODELS:
            raise InputError(f"camera model {cam.model_name} has distortion; build undistorts to PINHOLE", im.name)
        m = np.asarray(im.cam_from_world().matrix(), float)
        xy, xyz = [], []
        for p2d in im.points2D:
            if p2d.has_point3D():
                pt = rec.point3D(p2d.point3D_id)
                if pt.error <= max_err:
                    xy.append(p2d.xy)
                    xyz.append(pt.xyz)
        views[im.name] = _View(
            name=im.name, R=m[:, :3], t=m[:, 3], K=np.asarray(cam.calibration_matrix(), float),
            width=cam.width, height=cam.height,
            obs_xy=np.asarray(xy, float).reshape(-1, 2), obs_xyz=np.asarray(xyz, float).reshape(-1, 3),
        )
    return views


def sparse_depth(view: _View, min_points: int = 8) -> np.ndarray:
    """(H, W) depth from the view's observed sparse points: linear in inverse depth, nearest outside the hull."""
    z = (view.obs_xyz @ view.R.T + view.t)[:, 2]
    keep = z > 1e-9
    xy, inv = view.obs_xy[keep], 1.0 / z[keep]
    if len(inv) < min_points:
        raise InputError(f"only {len(inv)} sparse points observed, too few for a depth map", view.name)
    jj, ii = np.meshgrid(np.arange(view.width) + 0.5, np.arange(view.height) + 0.5)
    q = np.stack([jj.ravel(), ii.ravel()], 1)
    lin = LinearNDInterpolator(xy, inv)(q)
    hole = ~np.isfinite(lin)
    if hole.any():
        lin[hole] = NearestNDInterpolator(xy, inv)(q[hole])
    return (1.0 / np.maximum(lin, 1e-9)).reshape(view.height, view.width)


def _backproject(view: _View, depth: np.ndarray) -> np.ndarray:
    jj, ii = np.meshgrid(np.arange(view.width) + 0.5, np.arange(view.height) + 0.5)
    rays = np.stack([jj, ii, np.ones_like(jj)], -1) @ np.linalg.inv(view.K).T
    cam = rays * depth[..., None]
    return (cam - view.t) @ view.R  # R^T (x_cam - t), row-vector form


def derive_unseen_masks(
    scene: str | Path, object_masks: Mapping[str, np.ndarray], config: UnseenConfig | None = None
) -> dict[str, np.ndarray]:
    """Unseen mask (bool, H x W) of every registered test_ view, keyed by image name.

    ``object_masks`` maps each registered object-inclusive image name to a boolean mask of the
    objects that are removed in the object-free capture.
    """
    cfg = config or UnseenConfig()
    scene = Path(scene)
    rec = read_model(scene / "sparse" / "0")
    views = _views(rec, cfg.max_point_error_px)
    tests = [v for n, v in sorted(views.items()) if is_test_name(n)]
    trains = [v for n, v in sorted(views.items()) if not is_test_name(n)]
    if not tests:
        raise InputError("no registered test_ view", scene / "sparse" / "0")
    kernel = np.ones((2 * cfg.mask_dilate_px + 1,) * 2, np.uint8) if cfg.mask_dilate_px > 0 else None
    occluders = {}
    for v in trains:
        m = object_masks.get(v.name)
        if m is None:
            raise InputError(f"no object mask for training view {v.name}", scene)
        if m.shape != (v.height, v.width):
            raise InputError(f"object mask is {m.shape[1]}x{m.shape[0]}, image {v.name} is {v.width}x{v.height}", v.name)
        occluders[v.name] = cv2.dilate(m.astype(np.uint8), kernel) > 0 if kernel is not None else m.astype(bool)
    train_depth = {v.name: sparse_depth(v, cfg.min_points) for v in trains} if cfg.depth_test else {}

    out = {}
    for tv in tests:
        X = _backproject(tv, sparse_depth(tv, cfg.min_points)).reshape(-1, 3)
        seen = np.zeros(len(X), bool)
        hidden = np.zeros(len(X), bool)  # under some in-frame view's object mask
        for v in trains:
            xc = X @ v.R.T + v.t
            z = xc[:, 2]
            front = z > 1e-6
            uvw = xc @ v.K.T
            u = np.floor(uvw[:, 0] / np.where(front, z, 1.0)).astype(np.int64)
            w = np.floor(uvw[:, 1] / np.where(front, z, 1.0)).astype(np.int64)
            ok = front & (u >= 0) & (u < v.width) & (w >= 0) & (w < v.height) & ~seen
            idx = np.flatnonzero(ok)
            under = occluders[v.name][w[idx], u[idx]]
            hidden[idx[under]] = True
            vis = ~under
            if cfg.depth_test:
                vis &= z[idx] <= train_depth[v.name][w[idx], u[idx]] * (1.0 + cfg.depth_tolerance)
            seen[idx[vis]] = True
        out[tv.name] = (hidden & ~seen).reshape(tv.height, tv.width)
    return out


def _capture_camera(scene: Path) -> pycolmap.Camera | None:
    """The distorted camera of the original photos when ``build`` undistorted them (from build_report.json)."""
    rep = scene / "build_report.json"
    if not rep.is_file():
        return None
    try:
        data = json.loads(rep.read_text())
        if not data["output"]["undistorted"]:
            return None
        c = data["registration"]["camera"]
        return pycolmap.Camera(model=c["model"], width=c["width"], height=c["height"], params=c["params"])
    except (KeyError, TypeError, ValueError):
        return None


def _fit_mask(scene: Path, mask: np.ndarray, path: Path, image: Path) -> np.ndarray:
    """``mask`` at the size of ``image``: masks drawn on the original (distorted) photos are undistorted
    exactly like the photos were; any other size is an error."""
    from PIL import Image

    with Image.open(image) as im:
        w, h = im.size
    if mask.shape == (h, w):
        return mask
    cam = _capture_camera(scene)
    if cam is not None and mask.shape == (cam.height, cam.width):
        m = undistort_mask(mask, cam)
        if m.shape == (h, w):
            return m
    raise InputError(f"mask is {mask.shape[1]}x{mask.shape[0]}, image {image.name} is {w}x{h}", path)


def load_object_masks(scene: str | Path, mask_dir: str | Path) -> dict[str, np.ndarray]:
    """Object masks (255 = removed object) for every non-test image of the scene, by image name.

    Masks may have the size of the scene's images or of the original photos (then undistorted).
    """
    scene, mask_dir = Path(scene), Path(mask_dir)
    if not mask_dir.is_dir():
        raise InputError("object-mask folder does not exist", mask_dir)
    masks = {}
    for p in sorted((scene / "images").iterdir()):
        if is_image_name(p.name) and not is_test_name(p.name):
            path = find_mask(mask_dir, [p.name])
            if path is None:
                raise InputError(f"no object mask for {p.name} (expected {p.stem}.png)", mask_dir)
            masks[p.name] = _fit_mask(scene, read_mask(path), path, p)
    return masks


def import_unseen_masks(scene: str | Path, mask_dir: str | Path) -> tuple[dict[str, np.ndarray], list[str]]:
    """The user's unseen masks for every test_ image, checked for size; returns (masks by stem, ignored files).

    A mask may be named like the test image (``test_X.png``) or like the original photo (``X.png``),
    and have the size of the scene's images or of the original photos (then undistorted like them).
    """
    scene, mask_dir = Path(scene), Path(mask_dir)
    if not mask_dir.is_dir():
        raise InputError("unseen-mask folder does not exist", mask_dir)
    masks, used = {}, set()
    tests = [p for p in sorted((scene / "images").iterdir()) if is_image_name(p.name) and is_test_name(p.name)]
    if not tests:
        raise InputError("no test_ images", scene / "images")
    for p in tests:
        path = find_mask(mask_dir, [p.name, p.name.removeprefix(TEST_PREFIX)])
        if path is None:
            raise InputError(f"no unseen mask for {p.name} (expected {p.stem}.png)", mask_dir)
        masks[p.stem] = _fit_mask(scene, read_mask(path), path, p)
        used.add(path.name)
    ignored = sorted(q.name for q in mask_dir.iterdir() if q.is_file() and q.name not in used)
    return masks, ignored


def write_unseen_masks(scene: str | Path, masks: Mapping[str, np.ndarray], overwrite: bool = False) -> Path:
    """Write ``scene/unseen_mask/<stem>.png`` (255 = unseen) atomically; keys may be names or stems."""
    target = Path(scene) / "unseen_mask"
    with atomic_dir(target, overwrite=overwrite) as tmp:
        for key, m in masks.items():
            write_mask(tmp / f"{Path(key).stem}.png", m)
    return target


def mask_iou(a: np.ndarray, b: np.ndarray) -> float:
    """Intersection over union of two boolean masks (1.0 when both are empty)."""
    union = np.logical_or(a, b).sum()
    return 1.0 if union == 0 else float(np.logical_and(a, b).sum() / union)
