"""Ablation a) of paper Tab. 3 ("w/o object association"): ids carried from one view to the next by
2D IoU of the segments, like a video tracker, without the Gaussians."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from inpaint360gs.associate.config import MAX_OBJECTS, AssociationConfig
from inpaint360gs.associate.kom import segment_ids


def track(segs: Sequence[np.ndarray], cfg: AssociationConfig) -> list[np.ndarray]:
    """Ablation a): carry ids between consecutive views by 2D IoU, like a video tracker."""
    out, prev, next_id = [], None, 1
    for seg in segs:
        ids, counts = segment_ids(seg, cfg.min_segment_pixels)
        lut = np.zeros(int(seg.max()) + 1, dtype=np.uint8)
        taken: set[int] = set()
        for s, area in sorted(zip(ids, counts), key=lambda sc: -sc[1]):  # larger segments choose first
            best, best_iou = 0, 0.0
            if prev is not None:
                region = seg == s
                cand, inter = np.unique(prev[region], return_counts=True)
                for c, i in zip(cand, inter):
                    if c == 0 or c in taken:
                        continue
                    iou = i / (area + (prev == c).sum() - i)
                    if iou > best_iou:
                        best, best_iou = int(c), iou
            if best and best_iou >= cfg.tracker_iou:
                lut[s] = best
                taken.add(best)
            elif next_id <= MAX_OBJECTS:
                lut[s] = next_id
                next_id += 1
        prev = lut[seg]
        out.append(prev)
    return out
