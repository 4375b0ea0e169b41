"""The segmenter interface and its registry (paper Sec. 3.2: raw 2D masks per training view).

A segmenter turns one training view — its camera, its RGB image and, through :meth:`Segmenter.prepare`,
the trained 3DGS it may render — into an id image: (H, W) uint16, 0 = no segment, ids arbitrary per
view (they need not agree between views: linking them is the association stage's work, Sec. 3.2
"2D segmentation mask association"). The paper uses HQ-SAM's automatic mask generation; the default
here needs no learned weights (docs/architecture.md, "Decisions the paper leaves open").

Registered names: ``geometric`` (default; clusters of the trained Gaussians above the support plane,
rendered per view), ``oracle`` (synthetic scenes only: damaged ground-truth instance masks), ``sam``
(SAM / HQ-SAM / MobileSAM from ONNX files the user supplies). Each module is imported only when its
segmenter is asked for.
"""

from __future__ import annotations

import importlib
from abc import ABC, abstractmethod
from pathlib import Path
from typing import TYPE_CHECKING, ClassVar

import numpy as np

from inpaint360gs.core.errors import InputError

if TYPE_CHECKING:
    import torch

    from inpaint360gs.core.gaussians import Gaussians
    from inpaint360gs.io.scene import Scene, View

# name -> "module:Class"
SEGMENTERS: dict[str, str] = {
    "geometric": "inpaint360gs.segment.geometric:GeometricSegmenter",
    "oracle": "inpaint360gs.segment.oracle:OracleSegmenter",
    "sam": "inpaint360gs.segment.sam:SamSegmenter",
}
DEFAULT_SEGMENTER = "geometric"


class Segmenter(ABC):
    """One view in, one id image out; optional one-time preparation on the whole scene and model."""

    name: ClassVar[str]
    uses_model: ClassVar[bool] = False  # whether prepare() needs the trained Gaussians
    reads_ground_truth: ClassVar[bool] = False  # whether it reads the scene's gt/ (oracle only)

    def prepare(self, scene: Scene, model: Gaussians | None) -> None:
        """One-time work on the whole scene (and model, when :attr:`uses_model`) before any view.

        Must check every input it will read and raise :class:`InputError` naming the file otherwise.
        """

    @abstractmethod
    def segment(self, view: View, image: torch.Tensor) -> np.ndarray:
        """(H, W) uint16 id image of ``view`` (``image``: (H, W, 3) float RGB in [0, 1])."""

    def input_files(self, scene: Scene) -> list[Path]:
        """Files besides the scene's photos that :meth:`prepare` and :meth:`segment` read (the oracle's
        ``gt/`` masks, SAM's ONNX files): their content is part of the segmentation's signature and
        record, so that a changed one reruns it. Those inside the scene are checked to stay inside
        it (``core.files.inside``)."""
        return []

    def input_digests(self, scene: Scene) -> dict[str, str]:
        """sha256 of each of :meth:`input_files` (by its name inside the scene, or its path);
        :class:`InputError` naming a file that cannot be read."""
        from inpaint360gs.core.files import check_readable, sha256_file

        out = {}
        for f in self.input_files(scene):
            check_readable(f, f"a file the {self.name} segmenter reads")
            out[str(f.relative_to(scene.root) if f.is_relative_to(scene.root) else f)] = sha256_file(f)
        return out

    def settings(self) -> dict:
        """What segment.json records about this segmenter's configuration."""
        return {}

    def summary(self) -> dict:
        """What segment.json records about what :meth:`prepare` found (e.g. the objects in 3D)."""
        return {}


def segmenter_names() -> list[str]:
    """Every registered segmenter name."""
    return list(SEGMENTERS)


def get_segmenter(name: str, **options) -> Segmenter:
    """Instantiate the segmenter registered as ``name`` with its options."""
    if name not in SEGMENTERS:
        raise InputError(f"unknown segmenter {name!r} (known: {', '.join(SEGMENTERS)})", setting="segmenter")
    module, cls = SEGMENTERS[name].split(":")
    segmenter = getattr(importlib.import_module(module), cls)
    try:
        return segmenter(**options)
    except (TypeError, AttributeError) as e:  # an unknown option, or an option of the wrong type
        raise InputError(f"options {options!r:.60} do not fit segmenter {name!r} ({e})", setting="segmenter_options") from None


def check_id_image(ids: np.ndarray, view: View, who: str) -> np.ndarray:
    """The segmenter's output as a contiguous (H, W) uint16 array of ``view``'s size, or a clear error."""
    ids = np.asarray(ids)
    cam = view.camera
    if ids.shape != (cam.height, cam.width):
        raise RuntimeError(f"segmenter {who} returned shape {ids.shape} for view {view.name}, expected {(cam.height, cam.width)}")
    if ids.dtype != np.uint16:
        if ids.size and (ids.min() < 0 or ids.max() > np.iinfo(np.uint16).max):
            raise RuntimeError(f"segmenter {who} returned ids outside 0..65535 for view {view.name}")
        ids = ids.astype(np.uint16)
    return np.ascontiguousarray(ids)
