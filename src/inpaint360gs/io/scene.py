"""Load a scene folder in the Inpaint360GS layout (:mod:`inpaint360gs.core.layout`) through pycolmap.

Splits follow :func:`inpaint360gs.core.layout.assign_splits`: ``test_*`` views are the inpainting
evaluation views; among the others, sorted by name, every ``llffhold``-th is held out for
reconstruction evaluation and the rest are training views (original 3DGS loader).

Policy for images on disk that the model does not register: an error by default (such a file is
usually a failed registration or a stray ground-truth capture, and silently ignoring it hides
leakage or missing data); ``unregistered="warn"`` downgrades it to a warning and lists the files in
``Scene.unregistered``.

Method stages never see test pixels by accident: a test view's camera is available like any other,
but :meth:`Scene.load_image` refuses it unless called with ``allow_test=True`` (evaluation only).
"""

from __future__ import annotations

import hashlib
import os
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

import numpy as np
import torch

from inpaint360gs.core import layout
from inpaint360gs.core.camera import Camera
from inpaint360gs.core.errors import InputError, TestPixelAccessError
from inpaint360gs.core.files import inside, path_problem, read_json_object, sha256_file
from inpaint360gs.core.layout import Split
from inpaint360gs.core.settings import check_value
from inpaint360gs.io.colmap import image_camera, read_model
from inpaint360gs.io.images import binary_mask, find_mask, image_size, read_image, read_mask, resize_image, resize_mask, to_float

MASK_KINDS = (layout.UNSEEN_MASK_DIR, layout.OBJECT_MASK_DIR)


@dataclass(frozen=True)
class View:
    """One registered capture: its camera at the scene's resize factor and where its pixels are."""

    name: str  # image name as in the COLMAP model, e.g. "IMG_0001.png"
    split: Split
    camera: Camera  # at the scene's resize factor
    image_path: Path  # the file pixels are read from (images_<r>/ when present, else images/)
    image_id: int
    camera_id: int
    resize_on_load: bool = False  # pixels come from images/ at full size and are downscaled on read
    full_size: tuple[int, int] | None = None  # (width, height) of the image in images/ (None: the camera's)

    @property
    def stem(self) -> str:
        """The image file name without its suffix."""
        return Path(self.name).stem

    @property
    def is_test(self) -> bool:
        """Whether the view is a test view."""
        return self.split == "test"


@dataclass
class Scene:
    """A loaded scene folder: views with cameras, sparse points, mask files and ``scene.json``."""

    root: Path
    resize: int
    views: list[View]  # sorted by name
    points: torch.Tensor  # (P, 3) float32 sparse SfM points (world)
    point_colors: torch.Tensor  # (P, 3) float32 in [0, 1]
    info: dict = field(default_factory=dict)  # scene.json ({} when absent)
    masks: dict[str, dict[str, Path]] = field(default_factory=dict)  # kind -> view name -> file
    unregistered: list[str] = field(default_factory=list)  # files in images/ not in the model
    _fingerprint: str | None = field(default=None, repr=False, compare=False)

    @property
    def name(self) -> str:
        """The scene folder's name."""
        return self.root.name

    def split(self, split: Split) -> list[View]:
        """The views of ``split``, in scene order."""
        return [v for v in self.views if v.split == split]

    @property
    def train_views(self) -> list[View]:
        """The training views."""
        return self.split("train")

    @property
    def holdout_views(self) -> list[View]:
        """The views held out of training (every ``llffhold``-th)."""
        return self.split("holdout")

    @property
    def test_views(self) -> list[View]:
        """Object-free evaluation views: cameras only, unless pixels are asked for explicitly."""
        return self.split("test")

    @property
    def has_ground_truth(self) -> bool:
        """Whether the scene has object-free ``test_`` views to score inpainting against. A scene
        built from object-inclusive photos only has none (``scene.json``: ``"ground_truth": false``);
        every method stage works without them (docs/architecture.md, "Scene format")."""
        return bool(self.test_views) and self.info.get(layout.GROUND_TRUTH_KEY) is not False

    def view(self, name: str) -> View:
        """The view named ``name`` (file name or stem); :class:`InputError` when there is none."""
        for v in self.views:
            if v.name == name or v.stem == name:
                return v
        raise InputError(f"no view named {name!r} in the scene", self.root)

    def load_image_raw(self, view: View, *, allow_test: bool = False) -> np.ndarray:
        """(H, W, 3) uint8/uint16 pixels of ``view`` at the scene's resolution."""
        if view.is_test and not allow_test:
            raise TestPixelAccessError(
                f"{view.image_path}: pixels of test view {view.name} are evaluation data; "
                "method stages may use its camera only (pass allow_test=True in evaluation code)"
            )
        img = read_image(view.image_path)
        cam = view.camera
        if view.resize_on_load:
            img = resize_image(img, cam.width, cam.height)
        if (img.shape[1], img.shape[0]) != (cam.width, cam.height):
            raise InputError(
                f"image is {img.shape[1]}x{img.shape[0]} but its camera expects {cam.width}x{cam.height}",
                view.image_path,
            )
        return img

    def load_image(self, view: View, *, allow_test: bool = False) -> torch.Tensor:
        """(H, W, 3) float32 RGB in [0, 1] at the scene's resolution; test views need ``allow_test``."""
        return to_float(self.load_image_raw(view, allow_test=allow_test))

    def has_mask(self, view: View, kind: str = "unseen_mask") -> bool:
        """Whether ``view`` has a mask of ``kind`` loaded."""
        return view.name in self.masks.get(kind, {})

    def load_mask(self, view: View, kind: str = "unseen_mask") -> np.ndarray:
        """Mask of ``view`` at the scene's resolution: bool for ``unseen_mask`` (255 = unseen),
        the stored integer labels for ``object_mask``."""
        path = self.masks.get(kind, {}).get(view.name)
        if path is None:
            raise InputError(f"no {kind} for view {view.name}", self.root / kind)
        m = read_mask(path)
        cam = view.camera
        m = resize_mask(m, cam.width, cam.height)
        return binary_mask(m) if kind == layout.UNSEEN_MASK_DIR else m

    def fingerprint(self) -> str:
        """sha256 over the content a method stage may read: the sparse model's files and the images/
        files of every non-test view (names and bytes; the originals, whatever ``resize`` reads, so
        that the hash does not depend on it). Identifies a scene by content, not by name
        (docs/architecture.md, "Provenance chain"); computed once per loaded scene."""
        if self._fingerprint is not None:
            return self._fingerprint
        h = hashlib.sha256()
        sparse = inside(self.root, layout.SPARSE_DIR)
        for p in sorted(sparse.iterdir()):
            if p.is_file():
                h.update(p.name.encode() + b"\0" + inside(self.root, p.relative_to(self.root)).read_bytes())
        for v in self.views:
            if not v.is_test:
                h.update(v.name.encode() + b"\0" + inside(self.root, f"{layout.IMAGES_DIR}/{v.name}").read_bytes())
        self._fingerprint = h.hexdigest()
        return self._fingerprint

    def read_fingerprint(self, extra: Sequence[str | Path] = ()) -> str:
        """sha256 over every file this loaded scene's stages read at its ``resize``: :meth:`fingerprint`,
        the ``images_<R>/`` copies its non-test views read, the mask files it loaded (names and
        bytes), and ``extra`` (files besides, e.g. ``gt/`` masks the oracle segmenter reads). What a
        rerun compares (``inpaint360gs run``'s signatures, a 3DGS checkpoint), so that a changed
        input reruns what depends on it (docs/architecture.md, "Reliability")."""
        h = hashlib.sha256(self.fingerprint().encode())
        files = [v.image_path for v in self.views if not v.is_test and v.image_path != self.root / layout.IMAGES_DIR / v.name]
        files += [p for kind in sorted(self.masks) for _, p in sorted(self.masks[kind].items())]
        for p in [*files, *map(Path, extra)]:
            rel = p.relative_to(self.root) if p.is_relative_to(self.root) else p
            h.update(str(rel).encode() + b"\0" + sha256_file(p).encode())
        return h.hexdigest()

    @property
    def extent(self) -> float:
        """Scene radius of the original 3DGS (``getNerfppNorm``): 1.1 x the largest distance of a
        training camera centre from their mean. Scales position learning rates and densification."""
        return nerf_radius([v.camera for v in self.train_views])


def nerf_radius(cameras: Sequence[Camera]) -> float:
    """1.1 x max distance of the camera centres from their mean (3DGS ``getNerfppNorm``)."""
    if not cameras:
        raise InputError("no cameras to compute the scene extent from")
    centers = torch.stack([c.center.double() for c in cameras])
    d = (centers - centers.mean(0)).norm(dim=1).max().item()
    return 1.1 * d if d > 0 else 1.0


def load_scene(
    root: str | Path,
    *,
    resize: int = layout.RESIZE,
    llffhold: int = layout.LLFFHOLD,
    load_masks: bool | Sequence[str] = True,
    unregistered: Literal["error", "warn"] = "error",
) -> Scene:
    """Read a scene folder (:mod:`inpaint360gs.core.layout`) at image downscale factor ``resize``.

    Only file headers are read here (sizes are checked); pixels are read by ``Scene.load_image``.
    ``llffhold <= 0`` puts every non-test view into training. Raises ``InputError`` naming the file
    for any inconsistency (see the module docstring for the unregistered-image policy).
    """
    if isinstance(root, os.PathLike):
        root = os.fspath(root)
    if not isinstance(root, str) or not root.strip() or "\0" in root:
        raise InputError(f"expected a scene folder's path, got {type(root).__name__} {root!r:.40}", setting="scene")
    root = Path(root)
    check_value(resize, int, "resize")
    check_value(llffhold, int, "llffhold")
    if resize < 1:
        raise InputError(f"resize factor must be an integer >= 1, got {resize}", setting="resize")
    if unregistered not in ("error", "warn"):
        raise InputError(f"expected 'error' or 'warn', got {unregistered!r:.40}", setting="unregistered")
    if not root.is_dir():
        raise InputError("scene folder not found", root)
    images_dir = inside(root, layout.IMAGES_DIR)  # every file read below: inside the scene, links included
    if not images_dir.is_dir():
        raise InputError("missing images/ folder", images_dir)
    sparse = inside(root, layout.SPARSE_DIR)
    for f in sorted(sparse.iterdir()) if sparse.is_dir() else ():
        inside(root, f.relative_to(root))
    rec = read_model(sparse)
    ext = ".bin" if (sparse / "cameras.bin").is_file() else ".txt"  # which files read_model read

    scaled_dir = inside(root, layout.scaled_images_dir(resize))
    use_scaled = resize > 1 and scaled_dir.is_dir()

    entries = []
    for image_id, im in sorted(rec.images.items(), key=lambda kv: kv[1].name):  # deterministic order
        if not im.has_pose:
            continue
        full = image_camera(rec, im, sparse / f"cameras{ext}")
        src = inside(root, f"{layout.IMAGES_DIR}/{im.name}")
        problem = path_problem(src)
        if problem is not None:
            what = "missing on disk" if problem == "file not found" else f"not readable ({problem})"
            raise InputError(f"image {im.name} is registered in sparse/0 but {what}", src)
        camera = full.scaled(resize) if resize > 1 else full
        if use_scaled:
            path = inside(root, f"{scaled_dir.name}/{im.name}")
            if not path.is_file():
                raise InputError(f"image {im.name} missing from {scaled_dir.name}/ (complete or delete that folder)", path)
            if image_size(path) != (camera.width, camera.height):
                w, h = image_size(path)
                raise InputError(f"image is {w}x{h} but {scaled_dir.name}/ needs {camera.width}x{camera.height}", path)
        else:
            path = src
            if image_size(src) != (full.width, full.height):
                w, h = image_size(src)
                raise InputError(f"image is {w}x{h} but camera {im.camera_id} is {full.width}x{full.height}", src)
        entries.append((im.name, camera, path, int(image_id), int(im.camera_id), resize > 1 and not use_scaled, (full.width, full.height)))

    registered = {e[0] for e in entries}
    twins = layout.same_stem(registered)
    if twins:
        raise InputError(f"views {twins[0]} and {twins[1]} share the stem {Path(twins[0]).stem!r}, which names every per-view output: rename one", images_dir / twins[1])
    extra = sorted(layout.image_files(images_dir) - registered)
    if extra:
        msg = f"{len(extra)} image(s) on disk are not registered in sparse/0 (first: {extra[0]})"
        if unregistered == "error":
            raise InputError(msg + "; register them or remove them", images_dir / extra[0])
        warnings.warn(f"{images_dir}: {msg}; they are ignored", stacklevel=2)

    entries.sort(key=lambda e: e[0])
    splits = layout.assign_splits([e[0] for e in entries], llffhold)
    views = [View(name, splits[name], camera, path, image_id, camera_id, on_load, size) for name, camera, path, image_id, camera_id, on_load, size in entries]
    if not any(v.split == "train" for v in views):
        n_test = sum(v.split == "test" for v in views)
        raise InputError(
            f"no training views ({len(entries)} registered images, {n_test} named test_*, "
            f"llffhold={llffhold})",
            sparse,
        )

    pts = [rec.points3D[i] for i in sorted(rec.points3D)]  # by point id: a deterministic order
    xyz = np.array([p.xyz for p in pts], dtype=np.float32).reshape(-1, 3)
    rgb = np.array([p.color for p in pts], dtype=np.float32).reshape(-1, 3) / 255.0
    bad = ~np.isfinite(xyz).all(axis=1)
    if bad.any():
        first = sorted(rec.points3D)[int(np.flatnonzero(bad)[0])]
        raise InputError(f"{int(bad.sum())} sparse point(s) have non-finite coordinates (first: point {first})", sparse / f"points3D{ext}")

    info: dict = {}
    info_path = inside(root, layout.SCENE_JSON)
    if os.path.lexists(info_path):  # a folder, a named pipe or a broken link there is an error, not "no scene.json"
        info = read_json_object(info_path)

    kinds = MASK_KINDS if load_masks is True else (() if load_masks is False else tuple(load_masks))
    masks: dict[str, dict[str, Path]] = {}
    for kind in kinds:
        mdir = inside(root, kind)
        if not mdir.is_dir():
            continue
        found = {}
        for v in views:
            p = find_mask(mdir, [v.name])
            if p is None:
                continue
            p = inside(root, p.relative_to(root))
            size = image_size(p)
            full_size = (rec.cameras[v.camera_id].width, rec.cameras[v.camera_id].height)
            if size not in (full_size, (v.camera.width, v.camera.height)):
                raise InputError(
                    f"mask is {size[0]}x{size[1]} but image {v.name} is {full_size[0]}x{full_size[1]}", p
                )
            found[v.name] = p
        masks[kind] = found

    return Scene(
        root=root,
        resize=resize,
        views=views,
        points=torch.from_numpy(xyz),
        point_colors=torch.from_numpy(rgb),
        info=info,
        masks=masks,
        unregistered=extra,
    )
