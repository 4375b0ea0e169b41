"""Importers: 360-USID and SPIn-NeRF layouts built from the exact hand-made scene -> valid, leak-free scenes."""

from __future__ import annotations

import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest

import scene_builder as sb
from dataset_tools.capture.importers import import_360usid, import_spinnerf
from dataset_tools.capture.leaks import leaked_point_ids
from dataset_tools.capture.validate import validate_scene
from dataset_tools.cli import main as dataset_main
from inpaint360gs.core.errors import InputError
from inpaint360gs.io.colmap import read_model


def _source(tmp_path: Path, rename) -> tuple[Path, int, dict]:
    """A hand-made scene whose files/model names are mapped by ``rename(name) -> (folder, new name)``."""
    geo = sb.box_scene()
    rec = sb.box_reconstruction(geo)
    n_leaked = len(leaked_point_ids(rec))
    src = tmp_path / "src"
    rng = np.random.default_rng(0)
    exact = {}
    for iid in rec.reg_image_ids():
        im = rec.image(iid)
        folder, new = rename(im.name)
        (src / folder).mkdir(parents=True, exist_ok=True)
        cv2.imwrite(str(src / folder / new), rng.integers(0, 256, (geo.height, geo.width, 3), dtype=np.uint8))
        if im.name.startswith("test_"):
            cam = next(c for c in geo.cameras if c.name == im.name)
            exact[new] = sb.exact_unseen_mask(geo, cam)
        im.name = new
    (src / "sparse" / "0").mkdir(parents=True)
    rec.write(src / "sparse" / "0")
    return src, n_leaked, exact


def _usid_name(name: str) -> tuple[str, str]:
    return ("test_images", name.removeprefix("test_")) if name.startswith("test_") else ("images", name)


def test_360usid_import_removes_the_leak_and_validates(tmp_path, capsys):
    src, n_leaked, exact = _source(tmp_path, _usid_name)
    for name, m in exact.items():
        (src / "unseen_masks").mkdir(exist_ok=True)
        cv2.imwrite(str(src / "unseen_masks" / name), m.astype(np.uint8) * 255)
    assert n_leaked > 0
    assert dataset_main(["import", "360usid", str(src), str(tmp_path / "out")]) == 0
    assert f"removed {n_leaked} of" in capsys.readouterr().out
    out = tmp_path / "out"
    assert sorted(p.name for p in (out / "images").glob("test_*")) == ["test_000.png", "test_001.png"]
    rec = read_model(out / "sparse" / "0")
    assert {rec.image(i).name for i in rec.reg_image_ids()} == {p.name for p in (out / "images").iterdir()}
    assert leaked_point_ids(rec) == []
    assert ((cv2.imread(str(out / "unseen_mask" / "test_001.png"), 0) > 127) == exact["001.png"]).all()
    report = validate_scene(out)
    assert report.ok, report.format()


def test_360usid_missing_mask_and_name_clash(tmp_path):
    src, _, exact = _source(tmp_path, _usid_name)
    (src / "unseen_masks").mkdir()
    cv2.imwrite(str(src / "unseen_masks" / "000.png"), exact["000.png"].astype(np.uint8) * 255)
    with pytest.raises(InputError, match="no unseen mask for 001.png"):
        import_360usid(src, tmp_path / "out")
    cv2.imwrite(str(src / "unseen_masks" / "001.png"), np.zeros((10, 10), np.uint8))
    with pytest.raises(InputError, match="10x10"):
        import_360usid(src, tmp_path / "out")
    assert not (tmp_path / "out").exists()


def test_spinnerf_import_uses_sorted_order_and_downscaled_labels(tmp_path):
    # object-free views sort first (the release's first 40 images); labels at half size, value 1
    def rename(name):
        return ("images", "A" + name.removeprefix("test_")) if name.startswith("test_") else ("images", "B" + name)

    src, n_leaked, exact = _source(tmp_path, rename)
    labels = src / "images_2" / "label"
    labels.mkdir(parents=True)
    for name, m in exact.items():
        small = cv2.resize(m.astype(np.uint8), (80, 60), interpolation=cv2.INTER_NEAREST)
        cv2.imwrite(str(labels / name), small)  # 0/1 like the release
    report = import_spinnerf(src, tmp_path / "out", n_test=2)
    assert report.test_images == 2 and report.unseen_masks == 2 and report.leak_removal["removed"] == n_leaked
    out = tmp_path / "out"
    assert sorted(p.name for p in (out / "images").glob("test_*")) == ["test_A000.png", "test_A001.png"]
    m = cv2.imread(str(out / "unseen_mask" / "test_A000.png"), 0) > 127
    assert m.shape == (120, 160) and abs(int(m.sum()) - int(exact["A000.png"].sum())) < 0.1 * exact["A000.png"].sum()
    assert validate_scene(out).ok
    with pytest.raises(InputError, match="cannot hold"):
        import_spinnerf(src, tmp_path / "out2", n_test=50)


def test_import_refuses_distorted_models(tmp_path):
    src, _, exact = _source(tmp_path, _usid_name)
    (src / "unseen_masks").mkdir()
    for name, m in exact.items():
        cv2.imwrite(str(src / "unseen_masks" / name), m.astype(np.uint8) * 255)
    rec = read_model(src / "sparse" / "0")
    import pycolmap

    cam = rec.cameras[1]
    cam.model = pycolmap.Camera(model="SIMPLE_RADIAL", width=160, height=120, params=[110, 80, 60, 0.0]).model
    cam.params = [110, 80, 60, 0.01]
    shutil.rmtree(src / "sparse" / "0")
    (src / "sparse" / "0").mkdir()
    rec.write(src / "sparse" / "0")
    with pytest.raises(InputError, match="distortion"):
        import_360usid(src, tmp_path / "out")
