"""Floor 4 (docs/architecture.md, "Layers"): raw per-view 2D masks (paper Sec. 3.2) behind one segmenter
interface, and the segment stage writing them.

* :mod:`.base` — the interface and registry (``geometric`` default, ``oracle``, ``sam``);
* :mod:`.frame`, :mod:`.cluster3d`, :mod:`.geometric` — the default segmenter (no learned weights);
* :mod:`.oracle` — damaged ground-truth masks of synthetic scenes; :mod:`.sam` — SAM through ONNX;
* :mod:`.masks` — id-image helpers; :mod:`.stage` — ``segment_stage`` (the ``segment`` CLI stage).

Linking the per-view ids across views is the next floor's job (:mod:`inpaint360gs.associate`).
"""

from inpaint360gs.segment.base import DEFAULT_SEGMENTER, SEGMENTERS, Segmenter, get_segmenter, segmenter_names
from inpaint360gs.segment.stage import SEGMENT_JSON, read_segments, segment_stage

__all__ = ["DEFAULT_SEGMENTER", "SEGMENTERS", "SEGMENT_JSON", "Segmenter", "get_segmenter", "read_segments", "segment_stage", "segmenter_names"]
