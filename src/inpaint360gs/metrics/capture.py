"""Scores for a capture without ground truth: photos with the object only, nothing to compare the
filled region with (docs/architecture.md, "Real captures"). What can be scored:

- **outside the hole nothing changes**: PSNR against the photos over the pixels outside the removed
  object's footprint grown by a margin (:func:`psnr_outside`);
- **nothing stands where the object stood**: of the Gaussians whose centres lie in the object's
  footprint column (its centres projected onto the support plane), the opacity-weighted share
  standing higher above the plane than a fraction of the object's height (:func:`standing_share`);
- **the fill belongs**: texture energy (mean absolute Laplacian of the luminance) and mean
  luminance inside the hole against a ring around it (:func:`texture_ratios`);
- **nothing of the object is left beside it**: the pixels just outside the footprint that show the
  object's colours and none of the colours around it (:func:`object_beside`);
- **nothing of the object is left in the fill**: the same colour rule over the footprint itself,
  the specks of a part the removal missed drawn into the filled region (:func:`object_in_fill`).

Pure functions on arrays (the footprint's geometry is :mod:`inpaint360gs.core.support`'s); the
benchmark script ``benchmarks/bench_capture.py`` applies them to a run.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
import torch

from inpaint360gs.core.support import Footprint
from inpaint360gs.metrics.masked import roi_psnr

LUMA = np.array([0.299, 0.587, 0.114])  # ITU-R BT.601 weights


def grow(mask: np.ndarray, px: int) -> np.ndarray:
    """``mask`` grown by ``px`` pixels: every pixel within Euclidean distance ``px`` of it."""
    if px <= 0 or not mask.any():
        return mask.astype(bool)
    dist = cv2.distanceTransform((~mask.astype(bool)).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)
    return dist <= px


def psnr_outside(render: np.ndarray, photo: np.ndarray, footprint: np.ndarray, grow_px: int = 15) -> float:
    """PSNR (images in [0, 1]) over the pixels outside ``footprint`` grown by ``grow_px``; NaN when
    no pixel is left."""
    keep = ~grow(footprint, grow_px)
    value = roi_psnr(torch.as_tensor(np.asarray(render)), torch.as_tensor(np.asarray(photo)), torch.from_numpy(keep))
    return float("nan") if value is None else value


@dataclass
class TextureRatios:
    laplacian: float  # mean |Laplacian| inside the hole / in the ring
    luminance: float  # mean luminance inside / in the ring
    ring_laplacian: float = float("nan")  # mean |Laplacian| in the ring itself (how much texture there is to compare with)


def texture_ratios(image: np.ndarray, hole: np.ndarray, ring_px: int = 20) -> TextureRatios | None:
    """Texture energy and brightness of ``image`` (H, W, 3 in [0, 1]) inside ``hole`` against the
    ring of ``ring_px`` pixels around it; None when the hole or the ring is empty. The Laplacian is
    taken on the luminance (3x3 kernel), so a flat fill scores near 0 and a fill as detailed as its
    surroundings near 1."""
    hole = hole.astype(bool)
    ring = grow(hole, ring_px) & ~hole
    if not hole.any() or not ring.any():
        return None
    luma = image.astype(np.float64) @ LUMA
    lap = np.abs(cv2.Laplacian(luma, cv2.CV_64F, ksize=1))
    ring_lap, ring_luma = lap[ring].mean(), luma[ring].mean()
    return TextureRatios(
        laplacian=float(lap[hole].mean() / ring_lap) if ring_lap > 0 else float("nan"),
        luminance=float(luma[hole].mean() / ring_luma) if ring_luma > 0 else float("nan"),
        ring_laplacian=float(ring_lap),
    )


def _object_coloured(render: np.ndarray, photo: np.ndarray, hole: np.ndarray, region: np.ndarray, ring_px: tuple[int, int],
                     min_distance: float, samples: int) -> float | None:  # fmt: skip
    """Pixels of ``region`` in ``render`` coloured like the object and like nothing around it, over
    ``hole``'s area (:func:`object_beside`'s rule); None when the hole, the region or the ring is empty."""
    from scipy.spatial import cKDTree

    ring = grow(hole, ring_px[1]) & ~grow(hole, ring_px[0])
    if not hole.any() or not region.any() or not ring.any():
        return None

    def lab(img: np.ndarray) -> np.ndarray:
        return cv2.cvtColor(np.clip(img, 0, 1).astype(np.float32), cv2.COLOR_RGB2Lab)

    photo_lab = lab(photo)
    rng = np.random.default_rng(0)

    def sample(pixels: np.ndarray) -> cKDTree:
        return cKDTree(pixels[rng.choice(len(pixels), samples, replace=False)] if len(pixels) > samples else pixels)

    inside, around = sample(photo_lab[hole]), sample(photo_lab[ring])
    colours = lab(render)[region]
    d_obj, _ = inside.query(colours)
    d_around, _ = around.query(colours)
    return float(((d_around > min_distance) & (d_obj < 0.5 * d_around)).sum() / hole.sum())


def object_beside(render: np.ndarray, photo: np.ndarray, footprint: np.ndarray, band_px: int = 10, ring_px: tuple[int, int] = (20, 40),
                  min_distance: float = 12.0, samples: int = 4000) -> float | None:  # fmt: skip
    """The object's parts left beside its footprint in ``render`` (H, W, 3 in [0, 1]), as a share of
    the footprint's area: the pixels of the band ``band_px`` wide just outside ``footprint`` whose
    colour (CIE Lab) lies farther than ``min_distance`` from every colour of ``photo`` in the ring
    ``ring_px`` outside it (the support and whatever else lies round the object) and less than half
    as far from a colour of ``photo`` inside it (the object as photographed). A piece of the object
    left at its edge (the flat corners of a cone's base, a toy's feet, a dark contact rim) scores its
    area; support that looks like its surroundings scores 0. Each colour set is a fixed-seed sample of at most ``samples``
    pixels. None when the footprint, the band or the ring is empty."""
    hole = footprint.astype(bool)
    return _object_coloured(render, photo, hole, grow(hole, band_px) & ~hole, ring_px, min_distance, samples)


def object_in_fill(render: np.ndarray, photo: np.ndarray, footprint: np.ndarray, ring_px: tuple[int, int] = (20, 40),
                   min_distance: float = 12.0, samples: int = 4000) -> float | None:  # fmt: skip
    """The object's colours inside its footprint in the filled ``render``, as a share of the
    footprint's area: :func:`object_beside`'s rule over the footprint itself. Specks of a part the
    removal missed (a bucket's teeth left standing on a mat) or a fill that copies the object score
    their area; a fill in the colours around the hole scores 0, however its texture runs. Only
    meaningful after the inpainting: before it the hole shows whatever lies behind the object. None
    when the footprint or the ring is empty."""
    hole = footprint.astype(bool)
    return _object_coloured(render, photo, hole, hole, ring_px, min_distance, samples)


OPAQUE_ABOVE_TOP = 0.5  # over the object's top only Gaussians at least this opaque count as standing (see standing_share)


def _column(means: np.ndarray, opacities: np.ndarray, footprint: Footprint) -> tuple[np.ndarray, np.ndarray]:
    """(in the column, heights): the Gaussians from one object height below the plane to twice
    above inside the outline, faint ones over the object's top left out."""
    h = footprint.heights(means)
    col = footprint.inside(means) & (h > -footprint.height) & (h < 2.0 * footprint.height)
    return col & ((h <= footprint.height) | (opacities >= OPAQUE_ABOVE_TOP)), h


def standing_share(means: np.ndarray, opacities: np.ndarray, footprint: Footprint, height_frac: float = 0.1,
                   reference: float | None = None, exclude: np.ndarray | None = None) -> tuple[float, int]:  # fmt: skip
    """(opacity-weighted share, count) of the Gaussians in the footprint column (any height from
    one object height below the plane to twice above) that stand higher above the plane than
    ``height_frac`` x the object's height. The share is of everything in the column (0 when it
    holds nothing), or, given ``reference`` (:func:`standing_mass` of the model before the removal:
    the object), of that: the part of the object still standing, which an emptied column (the
    removal takes the support under the object too) cannot inflate.

    Over the object's top (its height is its opaque centres' 99th percentile) Gaussians fainter than
    :data:`OPAQUE_ABOVE_TOP` are not counted. The band over the top catches a part of the object the removal missed
    (the footprint then measures only the removed part), an opaque surface; the faint Gaussians over
    a removed object are the room's floaters, which the removal leaves by design (outside the
    object's silhouette, docs/architecture.md "The footprint column"). ``exclude`` ((N,) bool): left
    out of the column (a neighbouring object reaching into it, :func:`neighbour_gaussians`)."""
    opacities = np.asarray(opacities).reshape(-1)
    col, h = _column(means, opacities, footprint)
    if exclude is not None:
        col &= ~np.asarray(exclude, dtype=bool)
    w = opacities[col].astype(np.float64)
    up = h[col] > height_frac * footprint.height
    total = reference if reference is not None else w.sum()
    if not total > 0:
        return 0.0, 0
    return float(w[up].sum() / total), int(up.sum())


def standing_mass(means: np.ndarray, opacities: np.ndarray, footprint: Footprint, height_frac: float = 0.1,
                  exclude: np.ndarray | None = None) -> float:  # fmt: skip
    """The opacity summed over what stands in the footprint column (as :func:`standing_share` counts it)."""
    opacities = np.asarray(opacities).reshape(-1)
    col, h = _column(means, opacities, footprint)
    if exclude is not None:
        col &= ~np.asarray(exclude, dtype=bool)
    return float(opacities[col & (h > height_frac * footprint.height)].astype(np.float64).sum())


def neighbour_gaussians(means: np.ndarray, opacities: np.ndarray, footprint: Footprint, members: np.ndarray,
                        height_frac: float = 0.1) -> np.ndarray:  # fmt: skip
    """(N,) bool: the Gaussians of the objects ``members`` ((N, K) bool: Gaussian i belongs to
    object k) that stand mostly outside the footprint column: when fewer than half of an object's
    Gaussians standing above the plane (``height_frac`` x the object's height, as
    :func:`standing_share` counts) stand in the column, it is a neighbour that reaches into it (the
    outline is convex: a teapot's spout and handle span a corner of the box behind it). An object
    standing mostly in the column is no neighbour, whatever its label (a piece of the removed
    object the field labelled otherwise): it counts as standing where the object stood."""
    col, h = _column(means, np.asarray(opacities).reshape(-1), footprint)
    stand = h > height_frac * footprint.height
    out = np.zeros(len(means), dtype=bool)
    for k in range(members.shape[1]):
        m = members[:, k] & stand
        if m.any() and (m & col).sum() < 0.5 * m.sum():
            out |= members[:, k]
    return out
