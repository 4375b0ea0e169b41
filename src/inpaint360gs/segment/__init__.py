"""Floor 4 (docs/architecture.md, "Layers"): raw per-view 2D masks (paper Sec. 3.2) behind one segmenter
interface, and the segment stage writing them.

* :mod:`.base` — the interface and registry (``geometric`` default, ``oracle``, ``sam``);
* :mod:`.frame`, :mod:`.cluster3d`, :mod:`.geometric` — the default segmenter (no learned weights);
* :mod:`.oracle` — damaged ground-truth masks of synthetic scenes; :mod:`.sam` — SAM through ONNX;
* :mod:`.masks` — id-image helpers; :mod:`.stage` — ``segment_stage`` (the ``segment`` CLI stage).

Linking the per-view ids across views is the next floor's job (:mod:`inpaint360gs.associate`).
"""

from inpaint360gs.core.exports import lazy_exports

# name -> module: imported on first use, so that the registry (``segment.base``) loads without the stage
_EXPORTS = {"DEFAULT_SEGMENTER": "base", "SEGMENTERS": "base", "Segmenter": "base", "get_segmenter": "base", "segmenter_names": "base",
            "SEGMENT_JSON": "stage", "read_segments": "stage", "segment_stage": "stage"}  # fmt: skip
__all__ = sorted(_EXPORTS)

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
