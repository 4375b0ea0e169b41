"""Recursive conditional RGB-D inpainting along the virtual trajectory (paper Sec. 3.5 "Recursive
Conditional Inpainting", Eq. 6's targets; supp. B "Object Removal and 2D Inpainting").

The paper conditions LaMa on the previously inpainted frame by optimising LaMa's latents (Eq. 6).
Without a learned inpainter that can be conditioned, the condition here is geometric: the content
already inpainted in earlier views is kept as a cloud of small Gaussians (back-projected with its
inpainted depth) and rendered into the current view; inside the region to fill, the pixels it
covers take its colour and depth, and the 2D inpainter fills only what stays empty. View t+1
therefore agrees with view t (and every earlier view) wherever they see the same surface — the
texture consistency the paper's recursion aims at — and a view's freshly inpainted pixels join the
cloud for the views after it. ``condition=False`` (ablation d) inpaints every view on its own.

Depth is inpainted in the scene's own rendered depth (Eq. 5 divided by alpha: the depth of the
surface a pixel shows, which equals Eq. 5 wherever the surface is opaque); no monocular depth
model and no scale alignment.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import cv2
import numpy as np
import torch

from inpaint360gs.core.camera import Camera
from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.inpaint.inpainters import TeleaInpainter
from inpaint360gs.render.api import render
from inpaint360gs.views.unseen import backproject, normalised_depth


@dataclass
class InpaintedView:
    """One view's 2D inpainting result: the targets of the 3D stage."""

    camera: Camera
    color: np.ndarray  # (H, W, 3) float32: the edited scene's render, masked pixels inpainted
    depth: np.ndarray  # (H, W) float32: surface depth, masked pixels inpainted
    mask: np.ndarray  # (H, W) bool: the region that was filled
    valid: np.ndarray  # (H, W) bool: pixels whose target is meaningful (surface or filled; not a hole left by a temporarily removed occluder)
    from_condition: np.ndarray  # (H, W) bool: masked pixels filled from earlier views (the rest by the 2D inpainter)


def pixel_gaussians(camera: Camera, color: np.ndarray, depth: np.ndarray, rows: np.ndarray, cols: np.ndarray, opacity: float = 0.95) -> Gaussians:
    """One isotropic Gaussian per pixel (rows, cols) at its depth, sized to the pixel's footprint
    so that rendering them back into nearby views covers the surface without gaps."""
    d = depth[rows, cols].astype(np.float64)
    pts = backproject(camera, d, rows, cols)
    scale = 0.75 * d / min(camera.fx, camera.fy)  # about one pixel wide
    return Gaussians.from_points(
        torch.from_numpy(pts).float(), torch.from_numpy(color[rows, cols]).float(), sh_degree=0, init_opacity=opacity,
        scales=torch.from_numpy(scale).float(),
    )  # fmt: skip


def _cat(a: Gaussians | None, b: Gaussians) -> Gaussians:
    if a is None:
        return b
    return Gaussians(**{k: torch.cat([getattr(a, k), getattr(b, k)], 0) for k in ("means", "log_scales", "quats", "opacity_logits", "sh0", "shN")})


@torch.no_grad()
def inpaint_views(
    edited: Gaussians,
    cameras: Sequence[Camera],
    masks: Sequence[np.ndarray],
    fill_rgb: Callable[[np.ndarray, np.ndarray], np.ndarray],
    fill_depth: Callable[[np.ndarray, np.ndarray], np.ndarray],
    *,
    condition: bool = True,
    min_alpha: float = 0.5,
    backend: str = "auto",
    fills: dict[int, tuple[Callable, Callable]] | None = None,
    blend: bool = True,
    planes: dict[int, np.ndarray] | None = None,
) -> list[InpaintedView]:
    """Inpaint the region ``masks[i]`` of ``edited``'s render at ``cameras[i]``, in order (see the
    module docstring), with the 2D inpainters ``fill_rgb(image, mask)`` and ``fill_depth(depth, mask)``
    (:mod:`.inpainters`); ``fills`` gives view ``i`` its own pair instead (either may be None: the
    default). ``blend``: what a view takes from earlier views is fitted to its own surroundings
    (:func:`blend_into_view`). ``planes``: view ``i``'s (H, W) depth of a known planar surface (inf
    where its rays do not meet it): there a view takes the earlier views' fill through the homography
    the plane induces (:func:`plane_transfer`), exact and as sharp as the earlier image, instead of
    rendering the cloud of pixel splats."""
    cloud: Gaussians | None = None
    out = []
    fills = fills or {}
    planes = planes or {}
    for i, (cam, mask) in enumerate(zip(cameras, masks)):
        view_rgb, view_depth = fills.get(i, (None, None))
        o = render(edited, cam, backend=backend)
        color = o.color.clamp(0, 1).numpy().astype(np.float32)
        depth = normalised_depth(o).numpy().astype(np.float32)
        alpha = o.alpha.numpy()
        mask = mask.astype(bool)
        valid = (alpha >= min_alpha) | mask
        # the colour is Σ cαT over a black background (Eq. 1): where the removal left a surface thinned
        # beside the hole (0.5 <= alpha < 1 within 5 % of the image size of it), its colour is the
        # render over alpha, not a darkening the fills would copy; farther out the render stays as the
        # 3DGS has it (its own half-transparent edges are no part of the removal)
        r = max(1, round(0.05 * max(mask.shape)))
        near = cv2.dilate(mask.astype(np.uint8), cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))) > 0
        thin = valid & ~mask & near & (alpha < 1.0)
        color[thin] = (color[thin] / alpha[thin][:, None]).clip(0.0, 1.0)
        cond = np.zeros_like(mask)
        if condition and out and mask.any() and i in planes:
            cond = plane_transfer(cam, planes[i], mask, [(v, planes[j]) for j, v in enumerate(out) if j in planes], color, depth)
        if condition and cloud is not None and (mask & ~cond).any():
            c = render(cloud, cam, backend=backend)
            a = c.alpha.numpy()
            cov = mask & ~cond & (a >= min_alpha)
            # the surface's colour: Σ cαT over a black background divided by alpha, like the depth
            color[cov] = (c.color.numpy()[cov] / a[cov][:, None]).clip(0, 1)
            depth[cov] = normalised_depth(c).numpy()[cov]
            cond |= cov
        hole = mask & ~cond
        if blend and cond.any():
            color = blend_into_view(color, cond, mask | ~valid)
        # outside the mask, pixels without a surface (holes left by occluders taken out, background the
        # scene never reconstructed) carry no target the 3D stage uses: they are marked invalid and
        # filled first by a cheap diffusion (OpenCV Telea; their depth too), so that the hole's
        # inpainters find no black pixels to copy; then the hole is filled
        free = ~valid
        if free.any():
            unknown = free | mask  # what the conditioning brought in is not a source here, so the free pixels do not depend on it
            color[free] = TeleaInpainter().rgb(color, unknown)[free]
            depth[free] = TeleaInpainter().depth(np.where(unknown, 0.0, depth).astype(np.float32), unknown)[free]
        if hole.any():
            color = (view_rgb or fill_rgb)(color, hole)
            depth = (view_depth or fill_depth)(np.where(hole, 0.0, depth).astype(np.float32), hole)
        if hole.any():
            rows, cols = np.nonzero(hole)
            new = pixel_gaussians(cam, color, depth, rows, cols)
            cloud = _cat(cloud, new)
        out.append(InpaintedView(cam, color, depth, mask, valid, cond))
    return out


def plane_transfer(camera: Camera, z: np.ndarray, mask: np.ndarray, earlier: list, color: np.ndarray, depth: np.ndarray) -> np.ndarray:
    """Fill ``mask`` pixels lying on a known plane (``z`` finite: their depth on it) from ``earlier``
    views ((InpaintedView, its plane depth)) in order: a pixel's plane point is projected into an
    earlier view, and where it lands inside that view's filled region, on the same plane (its pixel's
    plane depth within 5%), its colour is sampled there (bilinear), its depth is ``z``. Writes into ``color``
    and ``depth``; returns the pixels filled. Exact for a plane: the mapping between two views of a
    plane is a homography, and only the earlier image's resampling blurs."""
    from inpaint360gs.views.unseen import backproject, project

    todo = mask & np.isfinite(z)
    done = np.zeros_like(mask)
    if not todo.any():
        return done
    rows, cols = np.nonzero(todo)
    pts = backproject(camera, z[rows, cols], rows, cols)
    left = np.ones(len(rows), dtype=bool)
    for v, zv in earlier:
        if not left.any():
            break
        u, w, d = project(v.camera, pts[left])
        h, wd = v.mask.shape
        inside = (d > 1e-6) & (u >= 0.5) & (u < wd - 0.5) & (w >= 0.5) & (w < h - 0.5)
        iu, iw = np.clip(u.astype(np.int64), 0, wd - 1), np.clip(w.astype(np.int64), 0, h - 1)
        ok = inside & v.mask[iw, iu] & (np.abs(zv[iw, iu] - d) <= 0.05 * d)
        if not ok.any():
            continue
        sample = _bilinear(v.color, u[ok] - 0.5, w[ok] - 0.5)
        idx = np.flatnonzero(left)[ok]
        color[rows[idx], cols[idx]] = sample
        depth[rows[idx], cols[idx]] = z[rows[idx], cols[idx]]
        done[rows[idx], cols[idx]] = True
        left[idx] = False
    return done


def _bilinear(img: np.ndarray, x: np.ndarray, y: np.ndarray) -> np.ndarray:
    """``img`` (H, W, C) sampled bilinearly at pixel coordinates (x, y) (OpenCV remap, edge pixels
    repeated); the points go in rows of at most 4096 (remap's maps must be under 32767 a side)."""
    n = len(x)
    cols = 4096
    rows = -(-n // cols)
    pad = rows * cols - n
    mx = np.pad(x.astype(np.float32), (0, pad)).reshape(rows, cols)
    my = np.pad(y.astype(np.float32), (0, pad)).reshape(rows, cols)
    out = cv2.remap(img, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    return out.reshape(rows * cols, -1)[:n]


def _smooth(img: np.ndarray, where: np.ndarray, sigma: float) -> np.ndarray:
    """Gaussian blur of ``img`` over the pixels ``where`` only (normalised convolution)."""
    w = where.astype(np.float64)
    num = cv2.GaussianBlur(img * w[..., None], (0, 0), sigma, borderType=cv2.BORDER_REFLECT)
    den = cv2.GaussianBlur(w, (0, 0), sigma, borderType=cv2.BORDER_REFLECT)
    return num / np.maximum(den, 1e-12)[..., None]


def blend_into_view(color: np.ndarray, taken: np.ndarray, unknown: np.ndarray, sigma: float = 2.0) -> np.ndarray:
    """``color`` with the pixels ``taken`` from earlier views shifted by the membrane interpolation
    of their mismatch with the view's own pixels along their border (Poisson image blending,
    Perez et al. 2003): the texture and structure stay the earlier views' (consistency), the
    brightness and tint near the border become this view's (a surface looks lighter or darker
    from another direction; 3DGS's colour is view-dependent). ``unknown`` (a superset of
    ``taken``): pixels whose own colour is not yet known (the rest of the hole, no surface)."""
    from inpaint360gs.inpaint.inpainters import harmonic_fill

    ys, xs = np.nonzero(unknown)
    h, w = taken.shape
    y0, y1, x0, x1 = max(ys.min() - 2, 0), min(ys.max() + 3, h), max(xs.min() - 2, 0), min(xs.max() + 3, w)
    t, u = taken[y0:y1, x0:x1], unknown[y0:y1, x0:x1]
    crop = color[y0:y1, x0:x1].astype(np.float64)
    # the nearest taken pixel of every pixel (OpenCV labels each zero of the input with its own index)
    _, label = cv2.distanceTransformWithLabels((~t).astype(np.uint8), cv2.DIST_L2, 5, labelType=cv2.DIST_LABEL_PIXEL)
    ty, tx = np.nonzero(t)
    lut = np.zeros((label.max() + 1, 2), dtype=np.int64)
    lut[label[ty, tx]] = np.stack([ty, tx], 1)
    near = lut[label]
    # compared through a Gaussian of ``sigma`` px taken within each side (normalised convolution): the
    # border pixels' texture differs pixel by pixel, their brightness does not
    own, mine = _smooth(crop, ~u, sigma), _smooth(crop, t, sigma)
    diff = own - mine[near[..., 0], near[..., 1]]  # known pixels: own colour minus the nearest taken one
    if (u.all()) or not (~u).any():
        return color
    corr = harmonic_fill(np.where(u[..., None], 0.0, diff), u)
    out = color.copy()
    out[y0:y1, x0:x1][t] = np.clip(crop[t] + corr[t], 0.0, 1.0).astype(color.dtype)
    return out


def reprojection_error(views: Sequence[InpaintedView], max_depth_diff: float = 0.03) -> float:
    """Multi-view consistency of the filled regions: mean absolute colour difference between each
    view's filled pixels and the next view's filled pixels at the same 3D point (back-projected with
    the inpainted depth, projected into the next view, kept where it lands in that view's filled
    region and its depth agrees within ``max_depth_diff`` of the distance). Lower is more consistent."""
    from inpaint360gs.views.unseen import project

    errs, n = 0.0, 0
    for a, b in zip(views[:-1], views[1:]):
        rows, cols = np.nonzero(a.mask)
        if not len(rows):
            continue
        pts = backproject(a.camera, a.depth[rows, cols].astype(np.float64), rows, cols)
        u, v, z = project(b.camera, pts)
        cam = b.camera
        ok = (z > 1e-6) & (u >= 0) & (u < cam.width) & (v >= 0) & (v < cam.height)
        ui, vi = u[ok].astype(np.int64), v[ok].astype(np.int64)
        agree = (np.abs(b.depth[vi, ui] - z[ok]) <= max_depth_diff * z[ok]) & b.mask[vi, ui]
        diff = np.abs(a.color[rows[ok][agree], cols[ok][agree]] - b.color[vi[agree], ui[agree]]).mean(axis=1)
        errs += float(diff.sum())
        n += int(diff.size)
    return errs / n if n else float("nan")
