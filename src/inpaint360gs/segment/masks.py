"""Id-image helpers every segmenter shares: per-view numbering, connected components, flattening
overlapping masks into one id image."""

from __future__ import annotations

from collections.abc import Sequence

import cv2
import numpy as np


def relabel_by_area(ids: np.ndarray) -> np.ndarray:
    """Renumber the segments of an id image 1..n by decreasing area (ties: by the old id); 0 stays 0."""
    old, counts = np.unique(ids[ids > 0], return_counts=True)
    order = np.lexsort((old, -counts))  # area descending, then old id
    lut = np.zeros(int(ids.max()) + 1 if ids.size else 1, np.uint16)
    lut[old[order]] = np.arange(1, len(old) + 1, dtype=np.uint16)
    return lut[ids]


def components(mask: np.ndarray) -> tuple[int, np.ndarray, np.ndarray]:
    """8-connected components of a boolean mask: (count, (H, W) int32 labels 0..count, areas (count,))."""
    n, lab, stats, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8), connectivity=8)
    return n - 1, lab, stats[1:, cv2.CC_STAT_AREA]


def split_components(labels: np.ndarray, min_area: int, min_fraction: float) -> np.ndarray:
    """Per-view segments of a label image: each label's connected components of at least
    ``min_area`` pixels and ``min_fraction`` of the label's largest component become segments;
    smaller fragments stay with the largest one (a label seen in pieces through an occluder keeps its
    crumbs). Numbered 1..n by decreasing area (:func:`relabel_by_area`); labels with no component of
    ``min_area`` pixels vanish."""
    out = np.zeros(labels.shape, np.int32)
    nxt = 1
    for lab in np.unique(labels[labels > 0]):
        n, cc, area = components(labels == lab)
        big = int(np.argmax(area))
        if area[big] < min_area:
            continue
        keep = (area >= min_area) & (area >= min_fraction * area[big])
        lut = np.zeros(n + 1, np.int32)
        for k in np.flatnonzero(keep):
            lut[k + 1] = nxt
            nxt += 1
        lut[1:][~keep] = lut[big + 1]
        out[cc > 0] = lut[cc[cc > 0]]
    return relabel_by_area(out)


def flatten_masks(masks: Sequence[np.ndarray], min_area: int = 1) -> np.ndarray:
    """One id image from overlapping boolean masks: larger masks first, smaller ones painted on top
    (so parts stay visible inside wholes); masks left with fewer than ``min_area`` visible pixels
    vanish; numbered by decreasing visible area."""
    if not len(masks):
        raise ValueError("flatten_masks needs at least one mask (or use an all-zero image)")
    out = np.zeros(masks[0].shape, np.int32)
    order = sorted(range(len(masks)), key=lambda i: (-int(masks[i].sum()), i))
    for k, i in enumerate(order, start=1):
        out[masks[i]] = k
    counts = np.bincount(out.ravel(), minlength=len(masks) + 1)
    out[counts[out] < min_area] = 0
    return relabel_by_area(out)


def remove_small_regions(mask: np.ndarray, min_area: int) -> tuple[np.ndarray, bool]:
    """Fill holes and drop islands smaller than ``min_area`` pixels (SAM's automatic mask generator
    post-processing); the largest island always stays. Returns (mask, whether it changed)."""
    changed = False
    n, lab, area = components(~mask)  # holes (the outside is one big "hole" that stays)
    small = np.flatnonzero(area < min_area) + 1
    if len(small):
        mask = mask | np.isin(lab, small)
        changed = True
    n, lab, area = components(mask)
    if n > 1:
        keep = np.flatnonzero((area >= min_area) | (np.arange(n) == np.argmax(area))) + 1
        if len(keep) < n:
            mask = np.isin(lab, keep)
            changed = True
    return mask, changed
