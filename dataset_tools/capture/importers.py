"""Import released inpainting datasets into the Inpaint360GS layout (docs/architecture.md, "Scene format"),
removing their point leaks.

Source layouts (from the public loaders of the two projects):

* **360-USID** (AuraFusion360): ``images/`` object-inclusive photos, ``test_images/`` object-free
  photos, ``unseen_masks/<stem>.*`` for the object-free photos, ``sparse/0`` registering both by
  file name. Its sparse model keeps points seen only by the object-free photos (the leak the
  Inpaint360GS paper points out); the import removes them.
* **SPIn-NeRF**: ``images/`` holding both captures, sorted by name the first ``n_test`` (40 in the
  release) object-free and the rest object-inclusive; masks in ``images_<f>/label/<stem>.png``
  (1 or 255 = object region) at a downscaled size; ``sparse/0``. Its masks of the object-free views
  mark where the object stood, which is used as the unseen mask (an approximation: it also covers
  surfaces the training views saw around the object).

Either way the result holds ``images/`` (object-free photos renamed ``test_*``), ``sparse/0``
(PINHOLE, leak-free), ``unseen_mask/``, ``scene.json`` and ``import_report.json``.
"""

from __future__ import annotations

import shutil
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from dataset_tools.capture.captures import decode_image, read_image_size, refuse_duplicates
from dataset_tools.capture.layout import provenance, read_mask, write_json
from dataset_tools.capture.leaks import recolor_from_inclusive_views, remove_leaked_points
from inpaint360gs.core.errors import InputError
from inpaint360gs.core.layout import TEST_PREFIX, is_image_name, is_test_name
from inpaint360gs.io.atomic import atomic_dir
from inpaint360gs.io.colmap import PINHOLE_MODELS, read_model, to_pinhole
from inpaint360gs.io.images import find_mask, write_mask

LAYOUTS = ("360usid", "spinnerf")


@dataclass
class ImportReport:
    layout: str
    images: int
    test_images: int
    unseen_masks: int
    leak_removal: dict
    dropped: dict  # name -> reason

    def format(self) -> str:
        lr = self.leak_removal
        lines = [f"imported {self.layout}: {self.images - self.test_images} object-inclusive + {self.test_images} "
                 f"test_ images, {self.unseen_masks} unseen masks; removed {lr['removed']} of {lr['points_before']} "
                 f"points seen only by object-free views"]
        lines += [f"  dropped {n}: {why}" for n, why in self.dropped.items()]
        return "\n".join(lines)


def _images(folder: Path) -> list[Path]:
    if not folder.is_dir():
        raise InputError("folder missing", folder)
    return sorted(p for p in folder.iterdir() if p.is_file() and is_image_name(p.name))


def _write_scene(
    out: Path, layout: str, src: Path, sources: dict[str, tuple[Path, str]], masks: dict[str, np.ndarray],
    overwrite: bool,
) -> ImportReport:
    """``sources``: model image name -> (file, output name). Writes OUT atomically."""
    digests = {name: decode_image(path) for name, (path, new) in sources.items()}  # every input decoded first
    refuse_duplicates((path, digests[name][1], is_test_name(new)) for name, (path, new) in sources.items())
    rec = read_model(src / "sparse" / "0")
    bad = {c.model_name for c in rec.cameras.values()} - set(PINHOLE_MODELS)
    if bad:
        raise InputError(f"camera model {', '.join(sorted(bad))} has distortion; run `build` on the photos instead",
                         src / "sparse" / "0")
    dropped: dict[str, str] = {}
    for iid in list(rec.reg_image_ids()):
        im = rec.image(iid)
        if im.name not in sources:
            dropped[im.name] = "in sparse/0 but no image file"
            rec.deregister_frame(im.frame_id)
            continue
        path, new = sources[im.name]
        w, h = digests[im.name][0]
        cam = rec.camera(im.camera_id)
        if (w, h) != (cam.width, cam.height):
            raise InputError(f"image is {w}x{h}, its camera in sparse/0 is {cam.width}x{cam.height}", path)
        im.name = new
    registered = {rec.image(i).name for i in rec.reg_image_ids()}
    for name, (path, new) in sources.items():
        if new not in registered:
            dropped[name] = "not registered in sparse/0"
    if not any(is_test_name(n) for n in registered):
        raise InputError("no object-free image is registered in sparse/0", src)
    to_pinhole(rec)
    leak = remove_leaked_points(rec)
    with atomic_dir(out, overwrite=overwrite) as tmp:
        (tmp / "images").mkdir()
        for path, new in sources.values():
            if new in registered:
                shutil.copyfile(path, tmp / "images" / new)
        recolor_from_inclusive_views(rec, tmp / "images")  # colours from object-inclusive images only
        (tmp / "sparse" / "0").mkdir(parents=True)
        rec.write(tmp / "sparse" / "0")
        n_masks = 0
        for new, m in masks.items():
            if new in registered:
                write_mask(tmp / "unseen_mask" / f"{Path(new).stem}.png", m)
                n_masks += 1
        report = ImportReport(layout, len(registered), sum(is_test_name(n) for n in registered), n_masks,
                              leak.to_dict(), dropped)
        write_json(tmp / "scene.json", {
            "name": out.name, "objects": [], "removal_targets": [], "source": layout,
            "provenance": provenance(f"inpaint360gs-dataset import {layout}", source=str(src.resolve())),
        })
        write_json(tmp / "import_report.json", report.__dict__)
    return report


def _fit(mask: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """Nearest-neighbour resize of a boolean mask to (w, h) (released masks are often downscaled)."""
    if mask.shape == (size[1], size[0]):
        return mask
    return cv2.resize(mask.astype(np.uint8), size, interpolation=cv2.INTER_NEAREST) > 0


def import_360usid(src: str | Path, out: str | Path, overwrite: bool = False) -> ImportReport:
    """360-USID scene folder -> Inpaint360GS scene folder (see module docstring)."""
    src, out = Path(src), Path(out)
    sources: dict[str, tuple[Path, str]] = {}
    for p in _images(src / "images"):
        if is_test_name(p.name):
            raise InputError(f"object-inclusive image starts with '{TEST_PREFIX}'", p)
        sources[p.name] = (p, p.name)
    masks: dict[str, np.ndarray] = {}
    for p in _images(src / "test_images"):
        new = p.name if is_test_name(p.name) else TEST_PREFIX + p.name
        if p.name in sources or new in {v[1] for v in sources.values()}:
            raise InputError("the same file name is in images/ and test_images/", p)
        sources[p.name] = (p, new)
        mpath = find_mask(src / "unseen_masks", [p.name]) if (src / "unseen_masks").is_dir() else None
        if mpath is None:
            raise InputError(f"no unseen mask for {p.name}", src / "unseen_masks")
        m = read_mask(mpath)
        w, h = read_image_size(p)
        if m.shape != (h, w):
            raise InputError(f"mask is {m.shape[1]}x{m.shape[0]}, image {p.name} is {w}x{h}", mpath)
        masks[new] = m
    return _write_scene(out, "360usid", src, sources, masks, overwrite)


def import_spinnerf(src: str | Path, out: str | Path, n_test: int = 40, overwrite: bool = False) -> ImportReport:
    """SPIn-NeRF scene folder -> Inpaint360GS scene folder (see module docstring)."""
    src, out = Path(src), Path(out)
    files = _images(src / "images")
    if not 0 < n_test < len(files) - 1:
        raise InputError(f"{len(files)} images cannot hold --n-test {n_test} object-free views and 2 object-inclusive ones", src / "images")
    label_dirs = sorted(src.glob("images_*/label"))
    if not label_dirs:
        raise InputError("no images_<f>/label/ mask folder", src)
    labels = label_dirs[0]
    sources: dict[str, tuple[Path, str]] = {}
    masks: dict[str, np.ndarray] = {}
    for k, p in enumerate(files):
        test = k < n_test
        new = (p.name if is_test_name(p.name) else TEST_PREFIX + p.name) if test else p.name
        if not test and is_test_name(p.name):
            raise InputError(f"object-inclusive image starts with '{TEST_PREFIX}'", p)
        sources[p.name] = (p, new)
        if test:
            mpath = find_mask(labels, [p.name])
            if mpath is None:
                raise InputError(f"no label mask for object-free view {p.name}", labels)
            masks[new] = _fit(read_mask(mpath), read_image_size(p))  # labels are 1 (or 255) inside
    return _write_scene(out, "spinnerf", src, sources, masks, overwrite)
