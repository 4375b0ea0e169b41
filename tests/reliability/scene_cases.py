"""What the scene-breaking cases of the reliability suite share (``test_containment.py``,
``test_scene_rules.py``): a private copy of the ``cone`` chain's scene, its model (watched: never
written) and a registered image renamed in the scene's model."""

from __future__ import annotations

import shutil
from pathlib import Path


def scene_copy(c) -> Path:
    """A private copy of the chain's ``cone`` scene, as ``<case>/data/cone``."""
    return shutil.copytree(c.request.getfixturevalue("chains")["cone"].scene, c.tmp / "data" / "cone")


def model(c) -> str:
    """The chain's model (its folder is watched: never written)."""
    ch = c.request.getfixturevalue("chains")["cone"]
    c.watched.append(ch.model.parent)
    return str(ch.model)


def rename_in_model(root: Path, old: str, new: str) -> None:
    """Register the image ``old`` of the scene ``root`` as ``new`` (the file is not moved)."""
    import pycolmap

    rec = pycolmap.Reconstruction(root / "sparse" / "0")
    next(im for im in rec.images.values() if im.name == old).name = new
    rec.write(root / "sparse" / "0")
