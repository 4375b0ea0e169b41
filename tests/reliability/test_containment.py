"""Containment: every file a stage reads lies inside the scene it was given, after every symbolic link
is followed, and ``validate`` applies the same rule (docs/architecture.md, "Reliability"; the helper
``core.files.inside``). A registered image name with ``..``, an absolute name, a link from the scene
to a file, a folder or another scene outside it: each CLI that reads the scene refuses it with one
line naming the path, exit status 2, before any work and without writing (the harness hashes every
tree); ``validate`` fails on the same scene. The file outside is a valid picture of the right size,
so a loader that follows the name would run to exit 0 on it."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import numpy as np
import pytest

import scene_builder as sb
from cli_harness import Case, check, ids_unique, restore_threads  # noqa: F401
from reliability.scene_cases import model, rename_in_model, scene_copy

T, D = "inpaint360gs", "inpaint360gs-dataset"
VIEW = "IMG_003.png"  # a training view of the chain scenes
OUTSIDE = "outside the scene"


def moved_out(root: Path, name: str = VIEW) -> Path:
    """Move the scene's ``images/<name>`` out of the scene (beside its folder); return where it went."""
    dst = root.parent.parent / "outside" / name
    dst.parent.mkdir(parents=True, exist_ok=True)
    shutil.move(root / "images" / name, dst)
    return dst


def linked_out(root: Path, rel: str) -> Path:
    """Replace ``root/rel`` (a file or a folder) by a link to a copy of it outside the scene."""
    src = root / rel
    dst = root.parent.parent / "outside" / rel.replace("/", "_")
    dst.parent.mkdir(parents=True, exist_ok=True)
    shutil.copytree(src, dst) if src.is_dir() else shutil.copy2(src, dst)
    shutil.rmtree(src) if src.is_dir() else src.unlink()
    src.symlink_to(dst, target_is_directory=dst.is_dir())
    return src


# --- ways a scene leads outside itself: root -> the path (or text) the error must name ------------


def name_dotdot(root: Path):
    dst = moved_out(root)
    rename_in_model(root, VIEW, os.path.relpath(dst, root / "images"))
    return OUTSIDE


def name_absolute(root: Path):
    rename_in_model(root, VIEW, str(moved_out(root)))
    return OUTSIDE


def name_etc_passwd(root: Path):
    (root / "images" / VIEW).unlink()
    rename_in_model(root, VIEW, "../" * 12 + "etc/passwd")
    return OUTSIDE


def name_subfolder_dotdot(root: Path):
    dst = moved_out(root)
    rename_in_model(root, VIEW, "sub/../" + os.path.relpath(dst, root / "images"))
    return OUTSIDE


def image_link(root: Path):
    return linked_out(root, f"images/{VIEW}")


def image_link_other_scene(root: Path):
    """A link to the same photo of another scene beside this one (the toys chain's data folder)."""
    other = root.parent / "toys"
    shutil.copytree(root, other)
    (root / "images" / VIEW).unlink()
    (root / "images" / VIEW).symlink_to(os.path.relpath(other / "images" / VIEW, root / "images"))
    return root / "images" / VIEW


def images_folder_link(root: Path):
    return linked_out(root, "images")


def sparse_file_link(root: Path):
    return linked_out(root, "sparse/0/points3D.bin")


def sparse_folder_link(root: Path):
    return linked_out(root, "sparse")


def scene_json_link(root: Path):
    (root / "scene.json").write_text('{"clicks": []}')
    return linked_out(root, "scene.json")


def unseen_mask_link(root: Path):
    return linked_out(root, "unseen_mask/test_000.png")


def image_link_dotdot_inside_out(root: Path):
    """A link whose text climbs out and back in under another name: it resolves outside."""
    outside = moved_out(root)
    (root / "images" / VIEW).symlink_to(os.path.relpath(outside, root / "images"))
    return root / "images" / VIEW


BREAKS = {
    "name-dotdot": name_dotdot,
    "name-absolute": name_absolute,
    "name-etc-passwd": name_etc_passwd,
    "name-subfolder-dotdot": name_subfolder_dotdot,
    "image-link-out": image_link,
    "image-link-other-scene": image_link_other_scene,
    "image-link-relative-out": image_link_dotdot_inside_out,
    "images-folder-link-out": images_folder_link,
    "sparse-file-link-out": sparse_file_link,
    "sparse-folder-link-out": sparse_folder_link,
    "scene-json-link-out": scene_json_link,
}
MASKS = {"unseen-mask-link-out": unseen_mask_link}  # read by the CLIs that load the scene's masks


def scaled(root: Path, factor: int = 2) -> None:
    """images_<factor>/ copies of every photo (what --resize reads)."""
    from PIL import Image

    (root / f"images_{factor}").mkdir()
    for p in (root / "images").iterdir():
        with Image.open(p) as im:
            w, h = im.size
            im.resize(((w + factor - 1) // factor, (h + factor - 1) // factor)).save(root / f"images_{factor}" / p.name)


def scaled_link(root: Path):
    scaled(root)
    return linked_out(root, f"images_2/{VIEW}")


def gt_link(root: Path):
    from inpaint360gs.io.scene import load_scene

    for v in load_scene(root).views:
        sb.write_mask(root / "gt" / "instance" / f"{v.stem}.png", np.zeros((v.camera.height, v.camera.width), bool))
    return linked_out(root, f"gt/instance/{Path(VIEW).stem}.png")


CLIS = {  # CLI -> argv given the broken scene and the case
    "train": lambda r, c: ["train", str(r), c.path("out"), "--iterations", "2", "--no-progress", "--threads", "2"],
    "segment": lambda r, c: ["segment", str(r), model(c), c.path("out"), "--no-progress", "--threads", "2"],
    "render": lambda r, c: ["render", model(c), str(r), c.path("out"), "--no-progress", "--threads", "2"],
    "run": lambda r, c: ["run", str(r), c.path("out"), "--model", model(c), "--id", "1", "--until", "segment", "--no-progress", "--threads", "2"],
    "validate": lambda r, c: ["validate", str(r)],
}
LOADS_MASKS = ("train", "validate")


def case(cli: str, name: str, brk, *extra: str) -> Case:
    def make(c):
        root = scene_copy(c)
        named = brk(root)
        if cli == "validate" and isinstance(named, Path):  # its report names paths inside the scene
            named = (str(named.relative_to(root)), OUTSIDE)
        return [*CLIS[cli](root, c), *extra], named if isinstance(named, tuple) else str(named)

    return Case(f"{cli}-{name}", D if cli == "validate" else T, make)


CASES = [case(cli, name, brk) for cli in CLIS for name, brk in BREAKS.items()]
CASES += [case(cli, name, brk) for cli in LOADS_MASKS for name, brk in MASKS.items()]
CASES += [case(cli, "scaled-image-link-out", scaled_link, *(("--resize", "2") if cli != "validate" else ())) for cli in ("train", "segment", "render", "run", "validate")]
CASES += [case("segment", "oracle-gt-link-out", gt_link, "--segmenter", "oracle"), case("run", "oracle-gt-link-out", gt_link, "--segmenter", "oracle")]


@pytest.mark.parametrize("case", ids_unique(CASES))
def test_nothing_outside_the_scene_is_read(case, tmp_path, request, capsys):
    check(case, tmp_path, request, capsys)


def test_links_and_sub_folders_inside_the_scene_are_read(chains, tmp_path):
    """The rule is about where a path leads, not about links as such: a photo linked to another file
    inside the scene, and photos in a sub-folder of images/, are read by the loader and pass validate."""
    from dataset_tools.capture.validate import validate_scene
    from inpaint360gs.io.scene import load_scene

    root = shutil.copytree(chains["cone"].scene, tmp_path / "cone")
    (root / "store").mkdir()
    shutil.move(root / "images" / VIEW, root / "store" / VIEW)
    (root / "images" / VIEW).symlink_to(Path("..") / "store" / VIEW)
    (root / "images" / "sub").mkdir()
    shutil.move(root / "images" / "IMG_005.png", root / "images" / "sub" / "IMG_005.png")
    rename_in_model(root, "IMG_005.png", "sub/IMG_005.png")
    scene = load_scene(root)
    assert {v.name for v in scene.views} >= {VIEW, "sub/IMG_005.png"}
    assert scene.load_image(scene.view(VIEW)).shape == (24, 32, 3)
    report = {c.name: c.status for c in validate_scene(root).checks}
    assert report["inside the scene"] == report["registration"] == report["image files"] == report["distinct stems"] == "pass", report
