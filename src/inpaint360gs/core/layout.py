"""Names of the scene folder and of the method's outputs: the one place they are spelled.

Scene folder (docs/architecture.md, "Scene format"; compatible with the released Inpaint360GS
dataset)::

    <scene>/images/          all captures; object-free ground-truth captures are named test_*
    <scene>/images_<r>/      optional copies downscaled by r
    <scene>/sparse/0/        one COLMAP model registering ALL images, points from training views only
    <scene>/unseen_mask/     per test_ image: 255 = hidden by the removed objects from every training camera
    <scene>/object_mask/     associated per-view object-id masks (written by the association stage)
    <scene>/scene.json       objects, removal targets with a click each, provenance
    <scene>/gt/              synthetic scenes only: true poses, instance masks, depth, object list

Splits (paper supp. Sec. B, "evaluation mode" of 3DGS): ``test_*`` views are the inpainting
evaluation views; the other views, sorted by name, alternate so that every ``llffhold``-th one
(index 0, 8, 16, ...) is held out for reconstruction evaluation and the rest train.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Literal

IMAGES_DIR = "images"
SPARSE_DIR = "sparse/0"
UNSEEN_MASK_DIR = "unseen_mask"
OBJECT_MASK_DIR = "object_mask"
SCENE_JSON = "scene.json"
# what `inpaint360gs render` writes under its output folder: color/<stem>.png, depth/, render.json
RENDER_COLOR_DIR = "color"
GT_DIR = "gt"

# The JSON each stage writes into its output folder (docs/architecture.md, "Stage outputs"): its
# settings, timings and provenance record ("Provenance chain"), keyed by the stage's name.
STAGE_RECORDS = {
    "train": "metrics.json",
    "segment": "segment.json",
    "associate": "objects.json",
    "distill": "distill.json",
    "remove": "removal.json",
    "inpaint": "inpaint.json",
    "render": "render.json",
}

TEST_PREFIX = "test_"
# Image files a scene folder or a capture folder may hold (what OpenCV, PIL and COLMAP all read).
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg", ".tif", ".tiff", ".bmp")
# Mask files are looked up by the image's stem with one of these suffixes (or the image's own name).
MASK_SUFFIXES = (".png", ".PNG", ".jpg", ".jpeg", ".JPG", ".tif", ".tiff")
LLFFHOLD = 8
RESIZE = 1  # load_scene's default downscale factor (the CLIs' --resize)

# ``scene.json`` key saying whether the scene has object-free ground truth (``test_`` views, unseen
# masks). ``false`` for a scene built from object-inclusive photos only (the method's real use: the
# object is still there); absent means the scene is expected to have test_ views.
GROUND_TRUTH_KEY = "ground_truth"
GROUND_TRUTH_REASON_KEY = "ground_truth_reason"
NO_GROUND_TRUTH = "no ground truth: the scene has no object-free test_ views"

Split = Literal["train", "holdout", "test"]


def is_test_name(name: str, prefix: str = TEST_PREFIX) -> bool:
    """True for object-free ground-truth views: the file name starts with ``test_``."""
    return Path(name).name.startswith(prefix)


def is_image_name(name: str) -> bool:
    """Whether ``name`` has an image suffix (case-insensitive)."""
    return Path(name).suffix.lower() in IMAGE_SUFFIXES


def image_files(images_dir: str | Path) -> set[str]:
    """Image files under ``images_dir`` (names relative to it, sub-folders included, hidden files and
    folders skipped): what a scene's ``images/`` holds, for the loader and ``validate`` alike."""
    images_dir = Path(images_dir)
    out = set()
    for p in images_dir.rglob("*"):
        rel = p.relative_to(images_dir)
        if p.is_file() and is_image_name(p.name) and not any(s.startswith(".") for s in rel.parts):
            out.add(rel.as_posix())
    return out


def same_stem(names) -> tuple[str, str] | None:
    """Two of ``names`` (image names, as registered) sharing a stem, or None. Per-view outputs are
    named by stem (``segment/<stem>.png``, masks), so ``a/IMG_1.png`` and ``b/IMG_1.png``, or
    ``IMG_1.png`` and ``IMG_1.jpg``, would share one: a scene refuses them (the loader and
    ``validate`` alike)."""
    seen: dict[str, str] = {}
    for n in sorted(names):
        stem = Path(n).stem
        if stem in seen:
            return seen[stem], n
        seen[stem] = n
    return None


def scaled_images_dir(resize: int) -> str:
    """Name of the folder of the images downscaled by ``resize`` (``images_<resize>``)."""
    return f"{IMAGES_DIR}_{resize}"


def assign_splits(names: list[str], llffhold: int = LLFFHOLD) -> dict[str, Split]:
    """Split of every image name (see the module docstring); ``llffhold <= 0`` holds nothing out."""
    others = sorted(n for n in names if not is_test_name(n))
    held = {n for i, n in enumerate(others) if llffhold > 0 and i % llffhold == 0}
    return {n: ("test" if is_test_name(n) else "holdout" if n in held else "train") for n in names}


@dataclass(frozen=True)
class RunLayout:
    """Output folders of ``inpaint360gs run SCENE OUT``: one sub-folder per method stage."""

    root: Path

    @property
    def gs(self) -> Path:  # trained 3DGS (point_cloud.ply, metrics.json, ...)
        """The trained 3DGS folder."""
        return self.root / "3dgs"

    @property
    def segment(self) -> Path:  # raw per-view 2D masks
        """The segment stage's folder."""
        return self.root / "segment"

    @property
    def associate(self) -> Path:  # view-consistent object masks + object list
        """The association stage's folder."""
        return self.root / "associate"

    @property
    def distill(self) -> Path:  # Gaussians with identity features + classifier
        """The distillation stage's folder."""
        return self.root / "distill"

    @property
    def removed(self) -> Path:  # edited scene after removal, AMCR masks
        """The removal stage's folder."""
        return self.root / "removed"

    @property
    def inpainted(self) -> Path:  # final scene after 2D/3D inpainting
        """The inpainting stage's folder."""
        return self.root / "inpainted"

    @property
    def renders(self) -> Path:  # renders of the final scene at the test_ cameras
        """Renders of the final scene at the test cameras."""
        return self.inpainted / "renders" / "test"

    @property
    def model(self) -> Path:  # the 3DGS model the later stages read
        """The trained 3DGS PLY."""
        return self.gs / "point_cloud.ply"
