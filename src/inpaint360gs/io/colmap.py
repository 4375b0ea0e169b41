"""The one COLMAP model reader and writer of the project (pycolmap), used by the scene loader, the
dataset tools and the tests.

Reading checks what pycolmap does not: the element counts at the head of binary files against the
file sizes (pycolmap trusts them, so a truncated or garbage file can make it allocate for minutes
before failing). Writing registers every camera at a given pose (pycolmap 4.x: each image gets its
camera's trivial rig and its own frame carrying the pose) with optional tracks.
"""

from __future__ import annotations

import contextlib
import struct
from collections.abc import Iterator, Sequence
from pathlib import Path

import numpy as np

from inpaint360gs.core.camera import Camera
from inpaint360gs.core.errors import InputError
from inpaint360gs.core.files import path_problem

# Camera models without lens distortion: the only ones the scene layout accepts.
PINHOLE_MODELS = ("PINHOLE", "SIMPLE_PINHOLE")

# Smallest record of each COLMAP binary file (bytes), for a cheap plausibility check of the counts.
_MIN_RECORD = {"cameras.bin": 24, "images.bin": 73, "points3D.bin": 51, "rigs.bin": 8, "frames.bin": 8}


def pycolmap_module():
    """``pycolmap``, imported so that it changes no signal handling: its import installs glog's
    failure handler for SIGTERM, which prints a native stack dump when a Python program using the
    library is stopped; the handler Python had is put back (main thread only: elsewhere Python
    cannot set handlers, and the CLI replaces it anyway, ``cli.common.install_signal_handlers``)."""
    import signal
    import threading

    main = threading.current_thread() is threading.main_thread()
    before = signal.getsignal(signal.SIGTERM) if main else None
    import pycolmap

    if main and before is not None:
        signal.signal(signal.SIGTERM, before)
    return pycolmap


@contextlib.contextmanager
def colmap_log(verbose: bool) -> Iterator[None]:
    """Silence COLMAP's INFO/WARNING log unless asked for."""
    pycolmap = pycolmap_module()

    old = pycolmap.logging.minloglevel
    pycolmap.logging.minloglevel = 0 if verbose else 2
    try:
        yield
    finally:
        pycolmap.logging.minloglevel = old


def read_model(path: str | Path):
    """Read a COLMAP model folder (binary or text) as a ``pycolmap.Reconstruction``.

    Raises :class:`InputError` naming the file for a missing folder, missing files, a truncated or
    corrupt binary file, or anything pycolmap cannot parse.
    """
    pycolmap = pycolmap_module()

    path = Path(path)
    if not path.is_dir():
        raise InputError("COLMAP model folder missing", path)
    for name in ("cameras", "images", "points3D"):
        for f in (path / f"{name}.bin", path / f"{name}.txt"):
            problem = path_problem(f)
            if problem is not None and problem != "file not found":  # a named pipe would block the reader
                raise InputError(problem, f)
    has_bin = all((path / f).is_file() for f in ("cameras.bin", "images.bin", "points3D.bin"))
    has_txt = all((path / f).is_file() for f in ("cameras.txt", "images.txt", "points3D.txt"))
    if not (has_bin or has_txt):
        raise InputError("no cameras/images/points3D .bin or .txt files in the COLMAP model folder", path)
    if has_bin:
        for name, min_rec in _MIN_RECORD.items():
            f = path / name
            if not f.is_file():
                continue
            size = f.stat().st_size
            if size < 8:
                raise InputError(f"truncated ({size} bytes)", f)
            with f.open("rb") as fh:
                (count,) = struct.unpack("<Q", fh.read(8))
            if count * min_rec > size - 8:
                raise InputError(f"corrupt: header claims {count} entries, the file holds at most {(size - 8) // min_rec}", f)
    try:
        with colmap_log(False):
            return pycolmap.Reconstruction(path)
    except (RuntimeError, ValueError, IndexError, MemoryError, OSError) as e:
        msg = str(e).strip().splitlines()[-1] if str(e).strip() else type(e).__name__
        raise InputError(f"unreadable COLMAP model ({msg})", path) from None


def pinhole_intrinsics(cam, where: str | Path) -> tuple[float, float, float, float]:
    """(fx, fy, cx, cy) of a PINHOLE / SIMPLE_PINHOLE ``pycolmap.Camera``; other models are refused."""
    model = cam.model_name
    if model == "PINHOLE":
        fx, fy, cx, cy = (float(x) for x in cam.params)
        return fx, fy, cx, cy
    if model == "SIMPLE_PINHOLE":
        f, cx, cy = (float(x) for x in cam.params)
        return f, f, cx, cy
    raise InputError(
        f"camera {cam.camera_id} uses model {model}, which has distortion or is not a pinhole; "
        "undistort the images first (`inpaint360gs-dataset build` does, or pycolmap.undistort_images) "
        "so the model is PINHOLE or SIMPLE_PINHOLE",
        where,
    )


def image_camera(rec, image, where: str | Path) -> Camera:
    """The :class:`Camera` (full resolution) of a registered ``pycolmap.Image`` of ``rec``."""
    cam = rec.cameras[image.camera_id]
    fx, fy, cx, cy = pinhole_intrinsics(cam, where)
    if not (min(fx, fy) > 0 and np.isfinite([fx, fy, cx, cy]).all() and cam.width > 0 and cam.height > 0):
        raise InputError(
            f"camera {cam.camera_id} of image {image.name} has invalid intrinsics "
            f"({cam.width}x{cam.height}, fx={fx:g}, fy={fy:g}, cx={cx:g}, cy={cy:g}); focal lengths must be finite and > 0",
            where,
        )
    import torch

    pose = np.asarray(image.cam_from_world().matrix(), dtype=np.float64)
    if not np.isfinite(pose).all():
        raise InputError(f"image {image.name} has a non-finite pose", Path(where).with_name("images" + Path(where).suffix))
    return Camera(
        R=torch.from_numpy(pose[:, :3]).float(), t=torch.from_numpy(pose[:, 3]).float(),
        fx=fx, fy=fy, cx=cx, cy=cy, width=int(cam.width), height=int(cam.height), name=image.name,
    )  # fmt: skip


def to_pinhole(rec) -> None:
    """Rewrite SIMPLE_PINHOLE cameras as PINHOLE (fx = fy = f), the model the scene layout writes."""
    pycolmap = pycolmap_module()

    for cam in rec.cameras.values():
        if cam.model_name == "SIMPLE_PINHOLE":
            f, cx, cy = cam.params
            new = pycolmap.Camera(model="PINHOLE", width=cam.width, height=cam.height, params=[f, f, cx, cy], camera_id=cam.camera_id)
            cam.model = new.model
            cam.params = new.params


def build_model(
    cameras: Sequence[Camera],
    points: np.ndarray,
    colors: np.ndarray,
    *,
    tracks: Sequence[Sequence[tuple[int, int]]] | None = None,
    keypoints: Sequence[np.ndarray] | None = None,
    shared_camera: bool = True,
    camera_model: str = "PINHOLE",
    camera_params: Sequence[float] | None = None,
):
    """A ``pycolmap.Reconstruction`` registering ``cameras`` (image ids 1.. in the given order).

    ``points`` (P, 3) world, ``colors`` (P, 3) uint8 or floats in [0, 1]. ``tracks[p]`` lists
    (camera index, keypoint index) observations of point p, with ``keypoints[i]`` the (K_i, 2) pixel
    positions of camera i; without tracks points are stored unobserved. ``shared_camera`` gives
    every image camera 1 (the intrinsics of ``cameras[0]``, as in the scene layout), else one camera
    per image. ``camera_params`` overrides the intrinsics for ``camera_model``.
    """
    pycolmap = pycolmap_module()

    def params_of(c: Camera) -> list[float]:
        if camera_params is not None:
            return list(camera_params)
        return [c.fx, c.cx, c.cy] if camera_model == "SIMPLE_PINHOLE" else [c.fx, c.fy, c.cx, c.cy]

    rec = pycolmap.Reconstruction()
    for i, c in enumerate(cameras):
        if not shared_camera or i == 0:
            cid = 1 if shared_camera else i + 1
            rec.add_camera_with_trivial_rig(pycolmap.Camera(model=camera_model, width=c.width, height=c.height, params=params_of(c), camera_id=cid))
    for i, c in enumerate(cameras):
        kp = np.zeros((0, 2)) if keypoints is None else np.asarray(keypoints[i], dtype=np.float64).reshape(-1, 2)
        img = pycolmap.Image(name=c.name, keypoints=np.ascontiguousarray(kp), camera_id=1 if shared_camera else i + 1, image_id=i + 1)
        R = np.ascontiguousarray(c.R.detach().cpu().double().numpy())
        t = np.ascontiguousarray(c.t.detach().cpu().double().numpy())
        rec.add_image_with_trivial_frame(img, pycolmap.Rigid3d(pycolmap.Rotation3d(R), t))
    xyz = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    rgb = np.asarray(colors)
    if rgb.dtype.kind == "f":
        rgb = np.round(np.clip(rgb, 0.0, 1.0) * 255.0)
    rgb = rgb.astype(np.uint8).reshape(-1, 3)
    for p in range(len(xyz)):
        elems = [] if tracks is None else [pycolmap.TrackElement(int(i) + 1, int(k)) for i, k in tracks[p]]
        rec.add_point3D(np.ascontiguousarray(xyz[p]), pycolmap.Track(elems), np.ascontiguousarray(rgb[p]))
    if tracks is not None:
        rec.update_point_3d_errors()
    return rec


def write_model(path: str | Path, cameras: Sequence[Camera], points: np.ndarray, colors: np.ndarray, **kw) -> None:
    """Write :func:`build_model`'s reconstruction as a binary COLMAP model into ``path``."""
    path = Path(path)
    path.mkdir(parents=True, exist_ok=True)
    build_model(cameras, points, colors, **kw).write_binary(str(path))
