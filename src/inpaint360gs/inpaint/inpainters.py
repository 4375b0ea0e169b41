"""2D inpainters for the RGB and the depth of a view (paper Sec. 3.5 "Recursive Conditional
Inpainting" and "Depth-Guided Gaussian Initialization"; supp. B).

After removal, renders of the virtual views have holes; a 2D inpainter fills the colour image and
the rendered depth (``Σ z α T``, paper Eq. 5: the scene's own depth, no monocular depth model and
no scale alignment), and the inpainted depth is back-projected into the new Gaussians. The paper
uses LaMa for both. Conditioning on earlier views (part of a hole already filled) and the
back-projection rely on the contract every inpainter here keeps:

- ``inpaint_rgb(image (H, W, 3) float in [0, 1], mask (H, W) bool) -> (H, W, 3)`` and
  ``inpaint_depth(depth (H, W) float, metres > 0 where known, mask) -> (H, W)``, same dtype as given;
- exactly the masked pixels are filled, every other pixel is returned bit-identical (the methods
  compute a fill, :class:`Inpainter` copies only its masked pixels into a copy of the input);
- an empty mask returns a copy of the input; a mask covering every pixel, a shape mismatch, NaN or
  infinite known values, or known depth <= 0 are an :class:`~inpaint360gs.core.errors.InputError`
  (masked pixels may hold anything, NaN included: they are never read);
- seeded where the method is random (``seed``), so the same inputs give the same bytes.

Methods (``INPAINTERS``; ``make_inpainter(name, **options)``; each class says how it fills): ``telea``,
``ns``, ``harmonic``, ``plane`` (depth only), ``patchmatch``, ``patchmatch_harmonic``, ``shiftmap``, ``lama``.
The defaults (``DEFAULT_RGB``, ``DEFAULT_DEPTH``) were chosen on the embedded benchmark's ground truth
(``benchmarks/bench_inpainters.py``; the figures: CHANGELOG.md, "History").
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import cv2
import numpy as np

from inpaint360gs.core.errors import InputError

DEFAULT_RGB = "patchmatch_harmonic"
DEFAULT_DEPTH = "plane"
_STRETCH = 65535.0  # known range of a channel before cv2.inpaint (see CvInpainter)


# ----------------------------------------------------------------------------------------------
# input checks and the composition that keeps unmasked pixels bit-identical


def _check_mask(mask, shape: tuple[int, int]) -> np.ndarray:
    m = np.asarray(mask)
    if m.ndim != 2 or m.shape != shape:
        raise InputError(f"mask has shape {m.shape}, expected {shape} (the image's height and width)", "mask")
    if m.dtype != bool:
        if not (np.issubdtype(m.dtype, np.integer) or np.issubdtype(m.dtype, np.floating)):
            raise InputError(f"mask must be bool (or 0/nonzero numbers), got {m.dtype}", "mask")
        m = m != 0
    if m.size and m.all():
        raise InputError("mask covers every pixel: nothing to condition the inpainting on", "mask")
    return m


def _check_float(a, name: str) -> np.ndarray:
    a = np.asarray(a)
    if not np.issubdtype(a.dtype, np.floating):
        raise InputError(f"expected a float array, got {a.dtype}", name)
    return a


def check_rgb(image, mask) -> tuple[np.ndarray, np.ndarray]:
    """(image, bool mask) after the contract's checks (module docstring)."""
    img = _check_float(image, "image")
    if img.ndim != 3 or img.shape[2] != 3:
        raise InputError(f"expected an (H, W, 3) image, got shape {img.shape}", "image")
    m = _check_mask(mask, img.shape[:2])
    if not np.isfinite(img[~m]).all():
        raise InputError("NaN or infinite values at known (unmasked) pixels", "image")
    return img, m


def check_depth(depth, mask) -> tuple[np.ndarray, np.ndarray]:
    """(depth, bool mask) after the contract's checks (module docstring)."""
    d = _check_float(depth, "depth")
    if d.ndim != 2:
        raise InputError(f"expected an (H, W) depth map, got shape {d.shape}", "depth")
    m = _check_mask(mask, d.shape)
    known = d[~m]
    if not np.isfinite(known).all():
        raise InputError("NaN or infinite values at known (unmasked) pixels", "depth")
    if known.size and known.min() <= 0:
        raise InputError(f"known depth must be > 0 (min {float(known.min()):.4g}); put pixels without a surface in the mask", "depth")
    return d, m


def _compose(src: np.ndarray, mask: np.ndarray, fill: np.ndarray) -> np.ndarray:
    out = src.copy()
    out[mask] = fill[mask].astype(src.dtype, copy=False)
    return out


# ----------------------------------------------------------------------------------------------
# methods: each computes a fill for a float64 (H, W, C) array; only its masked pixels are used


def _cv_fill(x: np.ndarray, mask: np.ndarray, flag: int, radius: float) -> np.ndarray:
    """cv2.inpaint per channel on float32 with the known range stretched to [0, 65535]."""
    m8 = mask.astype(np.uint8)
    out = np.empty_like(x)
    for c in range(x.shape[2]):
        ch = x[..., c]
        known = ch[~mask]
        lo, hi = float(known.min()), float(known.max())
        if hi - lo <= 0:
            out[..., c] = lo
            continue
        s = np.where(mask, 0.0, (ch - lo) * (_STRETCH / (hi - lo))).astype(np.float32)
        r = cv2.inpaint(s, m8, float(radius), flag)
        out[..., c] = r.astype(np.float64) * ((hi - lo) / _STRETCH) + lo
    return out


def harmonic_fill(x: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """Solution of Laplace's equation in the hole with the known pixels as Dirichlet values
    (4-neighbour stencil, Neumann at the image border); x (H, W, C) float64."""
    import scipy.sparse as sp
    from scipy.sparse.linalg import spsolve

    h, w = mask.shape
    idx = -np.ones((h, w), dtype=np.int64)
    ys, xs = np.nonzero(mask)
    n = ys.size
    idx[ys, xs] = np.arange(n)
    rows, cols, vals = [np.arange(n)], [np.arange(n)], []
    deg = np.zeros(n)
    rhs = np.zeros((n, x.shape[2]))
    for dy, dx in ((-1, 0), (1, 0), (0, -1), (0, 1)):
        ny, nx = ys + dy, xs + dx
        inside = (ny >= 0) & (ny < h) & (nx >= 0) & (nx < w)
        deg += inside
        p, qy, qx = np.nonzero(inside)[0], ny[inside], nx[inside]
        q = idx[qy, qx]
        unk = q >= 0
        rows.append(p[unk])
        cols.append(q[unk])
        vals.append(-np.ones(int(unk.sum())))
        np.add.at(rhs, p[~unk], x[qy[~unk], qx[~unk]])
    a = sp.csr_matrix((np.concatenate([deg, *vals]), (np.concatenate(rows), np.concatenate(cols))), shape=(n, n))
    sol = spsolve(a.tocsc(), rhs)
    out = x.copy()
    out[ys, xs] = sol.reshape(n, -1)
    return out


def _ransac_plane(design: np.ndarray, vals: np.ndarray, tol: np.ndarray, rng: np.random.Generator, trials: int = 64) -> np.ndarray | None:
    """Inliers of the best plane through ``vals`` (RANSAC on 3 points with inlier threshold ``tol``,
    then least-squares refits on the inliers, the threshold tightened to 3 robust standard deviations
    of their residuals, until they stop changing), or None when no 3 of the points span a plane."""
    n = vals.size
    if n < 3 or np.linalg.matrix_rank(design) < 3:
        return None
    best, best_count = None, -1
    for _ in range(trials):
        pick = rng.choice(n, 3, replace=False)
        a = design[pick]
        if abs(np.linalg.det(a)) < 1e-12:
            continue
        inl = np.abs(design @ np.linalg.solve(a, vals[pick]) - vals) <= tol
        if inl.sum() > best_count:
            best, best_count = inl, int(inl.sum())
    if best is None:
        return None
    for _ in range(10):
        if best.sum() < 3 or np.linalg.matrix_rank(design[best]) < 3:
            break
        coef = np.linalg.lstsq(design[best], vals[best], rcond=None)[0]
        res = np.abs(design @ coef - vals)
        # tighten to 3 robust standard deviations of the inliers' residuals: points of another
        # surface near the planes' intersection pass ``tol`` but would tilt the fit
        thr = np.minimum(tol, np.maximum(3.0 * 1.4826 * np.median(res[best]), 1e-6 * np.abs(vals)))
        new = res <= thr
        if new.sum() < 3 or np.array_equal(new, best):
            break
        best = new
    return best


def relative_noise(x: np.ndarray, mask: np.ndarray) -> float:
    """Robust noise level of ``x`` relative to its value: 1.4826 x the median of |x - median3x3(x)| / |x|
    over the known pixels whose 3x3 neighbourhood is known (0 for a piecewise-smooth exact map,
    ~1.1 sigma for multiplicative noise of standard deviation sigma)."""
    inner = cv2.erode((~mask).astype(np.uint8), np.ones((3, 3), np.uint8), borderType=cv2.BORDER_CONSTANT, borderValue=0).astype(bool)
    if inner.sum() < 9:
        return 0.0
    med = cv2.medianBlur(x.astype(np.float32), 3).astype(np.float64)
    rel = np.abs(x[inner] - med[inner]) / np.maximum(np.abs(x[inner]), 1e-12)
    return float(1.4826 * np.median(rel))


def plane_fill(
    inv: np.ndarray, mask: np.ndarray, ring: int = 6, planes: int = 3, tol: float = 0.01, min_share: float = 0.15, seed: int = 0
) -> np.ndarray:
    """Per 8-connected hole, planes fitted to ``inv`` (H, W) over the known pixels within ``ring``
    pixels, evaluated in the hole and clamped to the ring's range (see PlaneInpainter).

    Up to ``planes`` planes are fitted one after the other (RANSAC, inliers within a relative error
    of ``tol`` or 3 times the image's noise level, whichever is larger; refined by least squares) on the ring pixels the previous planes leave, while at least
    ``min_share`` of the ring is left; each hole pixel takes the plane of its nearest inlier ring
    pixel. Fewer than 3 non-collinear ring pixels: the median of the ring.
    """
    from scipy.spatial import cKDTree

    h, w = mask.shape
    out = inv.copy()
    rng = np.random.default_rng(seed)
    tol = max(tol, 3.0 * relative_noise(inv, mask))
    count, labels, stats, _ = cv2.connectedComponentsWithStats(mask.astype(np.uint8), connectivity=8)
    kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * ring + 1, 2 * ring + 1))
    for k in range(1, count):
        x0, y0, bw, bh = stats[k, :4]
        ya, yb = max(0, y0 - ring), min(h, y0 + bh + ring)
        xa, xb = max(0, x0 - ring), min(w, x0 + bw + ring)
        comp = labels[ya:yb, xa:xb] == k
        near = cv2.dilate(comp.astype(np.uint8), kernel).astype(bool) & ~mask[ya:yb, xa:xb]
        ry, rx = np.nonzero(near)
        hy, hx = np.nonzero(comp)
        vals = inv[ya:yb, xa:xb][near]
        if vals.size == 0:  # a hole always borders known pixels unless the mask is full (refused)
            continue
        cy, cx, sc = ry.mean(), rx.mean(), max(1.0, float(max(bh, bw)))  # well-conditioned coordinates
        design = np.stack([(rx - cx) / sc, (ry - cy) / sc, np.ones(rx.size)], axis=1)
        hole = np.stack([(hx - cx) / sc, (hy - cy) / sc, np.ones(hx.size)], axis=1)
        free = np.ones(vals.size, dtype=bool)
        owner = -np.ones(vals.size, dtype=np.int64)
        coefs = []
        while len(coefs) < planes and free.sum() >= max(3, min_share * vals.size if coefs else 3):
            idx = np.nonzero(free)[0]
            inl = _ransac_plane(design[idx], vals[idx], tol * np.abs(vals[idx]), rng)
            if inl is None or inl.sum() < 3:
                break
            sel = idx[inl]
            coefs.append(np.linalg.lstsq(design[sel], vals[sel], rcond=None)[0])
            owner[sel] = len(coefs) - 1
            free[sel] = False
        if not coefs:
            pred = np.full(hy.size, float(np.median(vals)))
        else:
            have = owner >= 0
            _, nearest = cKDTree(np.stack([ry[have], rx[have]], 1)).query(np.stack([hy, hx], 1))
            which = owner[have][nearest]
            pred = np.einsum("ij,ij->i", hole, np.asarray(coefs)[which])
        out[ya + hy, xa + hx] = np.clip(pred, vals.min(), vals.max())
    return out


def _patchmatch(img255: np.ndarray, mask: np.ndarray, seed: int, patch_size: int) -> np.ndarray:
    try:
        from patchmatch_cython import inpaint_pyramid
    except ImportError:
        raise InputError("the patchmatch inpainter needs patchmatch-cython (pip install patchmatch-cython)", "patchmatch") from None
    try:
        return inpaint_pyramid(img255.astype(np.float32), mask, patch_size=patch_size, seed=int(seed)).astype(np.float64)
    except ValueError:
        # too few known pixels for one whole source patch at some pyramid level: no exemplar to
        # copy, so diffuse the known border inward instead (Telea), the only fill that still works
        return _cv_fill(img255.astype(np.float64), mask, cv2.INPAINT_TELEA, 3.0)


# ----------------------------------------------------------------------------------------------
# the interface and the registry


@dataclass
class Inpainter:
    """Base class: ``rgb(image, mask)`` and ``depth(depth, mask)`` check the inputs, call the
    method's ``_fill_rgb`` / ``_fill_depth`` (float64 in, a full-frame fill out) and copy only the
    masked pixels of the fill into a copy of the input."""

    name: ClassVar[str] = ""
    supports_rgb: ClassVar[bool] = True
    supports_depth: ClassVar[bool] = True

    def rgb(self, image, mask) -> np.ndarray:
        """Fill the ``mask`` pixels of (H, W, 3) ``image`` in [0, 1]; returns a float copy. :class:`InputError` for a
        depth-only inpainter or bad inputs."""
        img, m = check_rgb(image, mask)
        if not self.supports_rgb:
            raise InputError(f"the {self.name} inpainter fills depth only", "method")
        if not m.any():
            return img.copy()
        src = np.where(m[..., None], 0.0, img.astype(np.float64))
        return _compose(img, m, self._fill_rgb(src, m))

    def depth(self, depth, mask) -> np.ndarray:
        """Fill the ``mask`` pixels of (H, W) ``depth``; returns a float copy. :class:`InputError` for a colour-only
        inpainter or bad inputs."""
        d, m = check_depth(depth, mask)
        if not self.supports_depth:
            raise InputError(f"the {self.name} inpainter fills colour only", "method")
        if not m.any():
            return d.copy()
        src = np.where(m, 1.0, d.astype(np.float64))
        return _compose(d, m, self._fill_depth(src, m))

    def _fill_rgb(self, img: np.ndarray, mask: np.ndarray) -> np.ndarray:
        raise NotImplementedError

    def _fill_depth(self, depth: np.ndarray, mask: np.ndarray) -> np.ndarray:
        raise NotImplementedError


@dataclass
class CvInpainter(Inpainter):
    """OpenCV's ``cv2.inpaint``: Telea's fast marching (``flag`` 1) or Navier-Stokes (``flag`` 0) with
    inpainting radius ``radius``, per channel on float32 with the known range stretched to
    [0, 65535]: OpenCV's fast-marching update is off by up to
    ~1.5 units of the sample value whatever the type (a constant 8-bit image of 100 comes back
    with 99..105 in the hole, a float image of 0.3 with -1.2..1.8), so it needs a wide value range;
    stretched, that error is ~2e-5 of the range, and nothing is quantised to 8 bit. Depth is
    inpainted as depth."""

    radius: float = 3.0
    flag: ClassVar[int] = cv2.INPAINT_TELEA

    def _fill_rgb(self, img, mask):
        return _cv_fill(img, mask, self.flag, self.radius)

    def _fill_depth(self, depth, mask):
        return _cv_fill(depth[..., None], mask, self.flag, self.radius)[..., 0]


@dataclass
class TeleaInpainter(CvInpainter):
    name: ClassVar[str] = "telea"
    flag: ClassVar[int] = cv2.INPAINT_TELEA


@dataclass
class NSInpainter(CvInpainter):
    name: ClassVar[str] = "ns"
    flag: ClassVar[int] = cv2.INPAINT_NS


@dataclass
class HarmonicInpainter(Inpainter):
    """Membrane (Laplace) fill; depth in inverse depth.

    Membrane fill: the solution of Laplace's equation in the hole with the known pixels as
    boundary values (4-neighbour, Neumann at the image border; one sparse solve). Reproduces any
    image that is linear in the pixel coordinates exactly. Depth is filled in inverse depth: a 3D
    plane seen by a pinhole camera has an inverse depth linear in the pixel coordinates
    (``n·X = c`` with ``X = z K⁻¹ (u, v, 1)`` gives ``1/z = n·K⁻¹(u, v, 1)/c``), so a planar
    surface around a hole is continued exactly, without the intrinsics."""

    name: ClassVar[str] = "harmonic"

    def _fill_rgb(self, img, mask):
        return harmonic_fill(img, mask)

    def _fill_depth(self, depth, mask):
        return 1.0 / harmonic_fill((1.0 / depth)[..., None], mask)[..., 0]


@dataclass
class PlaneInpainter(Inpainter):
    """Robust planes per hole in inverse depth, fitted within ``ring`` pixels of the hole.

    Per connected hole (8-connected), planes ``1/z = a u + b v + c`` fitted to the known pixels
    within ``ring`` (6) pixels of the hole: up to ``planes`` (3) one after the other on the pixels
    the previous ones leave (seeded RANSAC, inliers within 1% relative error or 3x the map's own
    noise level, least-squares refits), each hole pixel taking the plane of its nearest inlier ring
    pixel, so a hole across a floor and a wall continues both. The fill is clamped to the range of
    inverse depth on the ring (an affine function never leaves that range inside the ring; the
    clamp only acts where the fit extrapolates, at holes touching the image border, and keeps the
    depth positive past a horizon). Exact for planar surroundings; the holes are mostly floor
    under removed objects."""

    name: ClassVar[str] = "plane"
    supports_rgb: ClassVar[bool] = False
    ring: int = 6
    planes: int = 3
    tol: float = 0.01
    seed: int = 0

    def _fill_depth(self, depth, mask):
        return 1.0 / plane_fill(1.0 / depth, mask, ring=self.ring, planes=self.planes, tol=self.tol, seed=self.seed)


@dataclass
class PatchMatchInpainter(Inpainter):
    """Multi-scale PatchMatch (patchmatch-cython), seeded.

    Exemplar-based PatchMatch (Barnes et al. 2009), multi-scale, from ``patchmatch-cython``
    (``inpaint_pyramid``, 5x5 patches, its seam blending); it returns 8 bit, so its fill is 8-bit
    quantised (in [0, 1] steps of 1/255). Depth goes through it as inverse depth stretched to
    0..255 (8-bit quantised as well). Seeded."""

    name: ClassVar[str] = "patchmatch"
    seed: int = 0
    patch_size: int = 5

    def _fill_rgb(self, img, mask):
        return _patchmatch(np.clip(img, 0.0, 1.0) * 255.0, mask, self.seed, self.patch_size) / 255.0

    def _fill_depth(self, depth, mask):
        inv = 1.0 / depth
        lo, hi = float(inv[~mask].min()), float(inv[~mask].max())
        if hi - lo <= 0:
            return np.full_like(depth, 1.0 / lo)
        s = (inv - lo) * (255.0 / (hi - lo))
        f = _patchmatch(s[..., None], mask, self.seed, self.patch_size)[..., 0]
        return 1.0 / (f * ((hi - lo) / 255.0) + lo)


@dataclass
class PatchMatchHarmonicInpainter(PatchMatchInpainter):
    """PatchMatch's texture on the membrane fill's low frequencies: ``pm + G_sigma * (harmonic - pm)``
    with a Gaussian of ``sigma`` (3) pixels, over the whole frame (outside the hole the difference
    is zero, so the correction fades out at the hole's border). A copied patch brings texture and
    also its own brightness; a hole across a shading gradient or a highlight gets patches that
    are too dark or too bright, which PSNR punishes and the eye sees as a blotch. The membrane
    fill has the right low frequencies and no texture; the sum keeps what each gets right (the
    structure/texture split of image inpainting). Depth goes through plain PatchMatch."""

    name: ClassVar[str] = "patchmatch_harmonic"
    sigma: float = 3.0  # pixels; the Gaussian that splits low from high frequencies

    def _fill_rgb(self, img, mask):
        pm = _compose(img, mask, super()._fill_rgb(img, mask))
        low = cv2.GaussianBlur(harmonic_fill(img, mask) - pm, (0, 0), self.sigma, borderType=cv2.BORDER_REFLECT)
        return np.clip(pm + low, 0.0, 1.0)


# ----------------------------------------------------------------------------------------------
# shift-map completion from the statistics of patch offsets (He and Sun 2012)

_UNIT = np.array([[-1, 0], [1, 0], [0, -1], [0, 1]])


def _boxsum(a, r):
    """sum of a over [y:y+r, x:x+r] for every top-left (y, x) that fits; a (H, W[, C])."""
    c = np.zeros((a.shape[0] + 1, a.shape[1] + 1) + a.shape[2:], np.float64)
    c[1:, 1:] = a
    c = c.cumsum(0).cumsum(1)
    return c[r:, r:] - c[:-r, r:] - c[r:, :-r] + c[:-r, :-r]


def _dominant_offsets(lab, known, patch, n_labels, stride=2):
    """The ``n_labels`` dominant offsets (dy, dx) of the known patches' nearest neighbours at least
    ``max(patch, max(H, W) / 15)`` away (peaks of the smoothed, symmetrised offset histogram),
    or None when there are too few known patches."""
    from scipy.ndimage import gaussian_filter, maximum_filter
    from scipy.spatial import cKDTree

    h, w = known.shape
    if h <= patch or w <= patch:
        return None
    ok = _boxsum(known.astype(np.float64), patch) == patch * patch  # (h-p+1, w-p+1): patch fully known
    ys, xs = np.nonzero(ok)
    if ys.size < 16:
        return None
    half = patch // 2
    lc = _boxsum(lab[..., :1], 2) / 4.0
    abc = _boxsum(lab[..., 1:], half) / float(half * half)
    feats = [lc[ys + 2 * i, xs + 2 * j] for i in range(half) for j in range(half)]
    feats += [abc[ys + half * i, xs + half * j] for i in range(2) for j in range(2)]
    f = np.concatenate(feats, axis=1)
    tau = max(float(patch), max(h, w) / 15.0)
    q = np.nonzero((ys % stride == 0) & (xs % stride == 0))[0]
    tree = cKDTree(f)
    pos = np.stack([ys, xs], 1)
    off = np.zeros((q.size, 2), np.int64)
    found = np.zeros(q.size, bool)
    todo = np.arange(q.size)
    for k in (16, 128):
        k = min(k, ys.size)
        _, nb = tree.query(f[q[todo]], k=k, workers=1)
        nb = nb.reshape(todo.size, k)
        d = pos[nb] - pos[q[todo]][:, None, :]
        far = (d[..., 0] ** 2 + d[..., 1] ** 2) > tau * tau
        first = np.argmax(far, axis=1)
        has = far[np.arange(todo.size), first]
        off[todo[has]] = d[np.arange(todo.size), first][has]
        found[todo[has]] = True
        todo = todo[~has]
        if todo.size == 0:
            break
    off = off[found]
    if off.shape[0] < 8:
        return None
    hist = np.zeros((2 * h - 1, 2 * w - 1))
    np.add.at(hist, (off[:, 0] + h - 1, off[:, 1] + w - 1), 1.0)
    np.add.at(hist, (-off[:, 0] + h - 1, -off[:, 1] + w - 1), 1.0)
    hs = gaussian_filter(hist, np.sqrt(2.0), mode="constant")
    peak = (hs == maximum_filter(hs, size=3, mode="constant")) & (hs > 0)
    dy, dx = np.nonzero(peak)
    dy, dx = dy - (h - 1), dx - (w - 1)
    keep = dy * dy + dx * dx > tau * tau
    dy, dx, v = dy[keep], dx[keep], hs[peak][keep]
    order = np.lexsort((dx, dy, -v))[:n_labels]
    if order.size < 2:
        return None
    return np.stack([dy[order], dx[order]], 1)


def _refine_offsets(lab, known, offs, r):
    """each offset moved within +-r to the one with the least mean squared difference between the
    known image and its shifted copy (where both are known); duplicates dropped, order kept."""
    h, w = known.shape
    out = []
    for dy, dx in offs:
        best = None
        for ey in range(-r, r + 1):
            for ex in range(-r, r + 1):
                oy, ox = dy + ey, dx + ex
                ys0, ys1 = max(0, -oy), min(h, h - oy)
                xs0, xs1 = max(0, -ox), min(w, w - ox)
                if ys1 - ys0 < 2 or xs1 - xs0 < 2:
                    continue
                a, b = lab[ys0:ys1:2, xs0:xs1:2], lab[ys0 + oy:ys1 + oy:2, xs0 + ox:xs1 + ox:2]
                m = known[ys0:ys1:2, xs0:xs1:2] & known[ys0 + oy:ys1 + oy:2, xs0 + ox:xs1 + ox:2]
                c = m.sum()
                if c == 0:
                    continue
                e = ((a - b) ** 2).sum(-1)[m].sum() / c
                if best is None or e < best[0]:
                    best = (e, oy, ox)
        if best is not None and (best[1], best[2]) not in out:
            out.append((best[1], best[2]))
    return np.array(out, np.int64) if len(out) >= 2 else None


def _crossing_lines(lab, hole, min_length=0.3, min_contrast=20.0, max_lines=8, max_gap=0.5, band=0.25):
    """Straight boundaries of the known image that run into the hole: (angle, rho) of lines
    x cos(a) + y sin(a) = rho (image x right, y down) whose collinear line segments (OpenCV's LSD on
    each CIELab channel; within 3 degrees and 2.5 px, the same colours on each side) add up to at
    least ``min_length`` x the hole's size (square root of its area), separate mean colours at least
    ``min_contrast`` apart (CIELab, over a band from 2.5 px to ``band`` x the size on each side, so
    the stripes of a texture do not count), come within ``max_gap`` x the size of the hole and cross
    it. A weaker line within a tenth of the size of a stronger one across the hole is the same
    boundary; the ``max_lines`` strongest (length x contrast), strongest first."""
    h, w = hole.shape
    size = float(np.sqrt(hole.sum()))
    if size < 4:
        return []
    near = cv2.dilate(hole.astype(np.uint8), np.ones((7, 7), np.uint8)) > 0
    lsd = cv2.createLineSegmentDetector(cv2.LSD_REFINE_STD)
    lab8 = np.clip(np.round(lab), 0, 255).astype(np.uint8)
    segs = []
    for ch in range(3):
        found = lsd.detect(cv2.GaussianBlur(np.ascontiguousarray(lab8[..., ch]), (0, 0), 1.0))[0]
        if found is not None:
            segs += [tuple(map(float, r)) for r in found.reshape(-1, 4)]

    band = max(6.0, band * size)

    def side_mean(p0, p1, nrm, sign):
        """mean colour of a band beside the segment (2.5 px to ``band`` away)"""
        t = np.linspace(0.0, 1.0, 20)[:, None, None]
        off = sign * np.linspace(2.5, band, 6)[None, :, None] * nrm
        q = np.round(p0 + t * (p1 - p0) + off).reshape(-1, 2).astype(np.int64)
        q = q[(q[:, 0] >= 0) & (q[:, 0] < w) & (q[:, 1] >= 0) & (q[:, 1] < h)]
        q = q[~near[q[:, 1], q[:, 0]]]
        return lab[q[:, 1], q[:, 0]].mean(0) if len(q) >= 20 else None

    pieces = []
    for x0, y0, x1, y1 in segs:
        p0, p1 = np.array([x0, y0]), np.array([x1, y1])
        length = float(np.linalg.norm(p1 - p0))
        if length < 6:
            continue
        q = np.clip(np.round(p0 + np.linspace(0, 1, int(length) + 1)[:, None] * (p1 - p0)).astype(np.int64), 0, [w - 1, h - 1])
        if near[q[:, 1], q[:, 0]].mean() > 0.1:  # an edge of the hole, not of the image
            continue
        d = (p1 - p0) / length
        if d[0] < 0 or (d[0] == 0 and d[1] < 0):
            d = -d
        nrm = np.array([-d[1], d[0]])
        a, b = side_mean(p0, p1, nrm, 1.0), side_mean(p0, p1, nrm, -1.0)
        if a is not None and b is not None:
            pieces.append((length, float(np.linalg.norm(a - b)), p0, p1, nrm, a, b))
    pieces.sort(key=lambda r: (-r[0] * r[1], r[2][0], r[2][1]))
    groups = []  # [normal, rho, colour a, colour b, [pieces]]
    for pc in pieces:
        mid = (pc[2] + pc[3]) / 2
        for g in groups:
            if abs(float(pc[4] @ g[0])) > np.cos(np.radians(3)) and abs(float(mid @ g[0]) - g[1]) < 2.5 and np.linalg.norm(pc[5] - g[2]) < 25 and np.linalg.norm(pc[6] - g[3]) < 25:
                g[4].append(pc)
                break
        else:
            groups.append([pc[4], float(mid @ pc[4]), pc[5], pc[6], [pc]])
    ys, xs = np.nonzero(hole)
    hp = np.stack([xs, ys], 1).astype(np.float64)
    to_hole = cv2.distanceTransform((~hole).astype(np.uint8), cv2.DIST_L2, cv2.DIST_MASK_PRECISE)  # each pixel's distance to the hole
    lines = []
    for _, _, _, _, members in groups:
        length = sum(m[0] for m in members)
        contrast = sum(m[0] * m[1] for m in members) / length
        # the line through all its pieces (total least squares on their end points, weighted by length)
        pts = np.concatenate([[m[2], m[3]] for m in members])
        wts = np.repeat([m[0] for m in members], 2)
        centre = (pts * wts[:, None]).sum(0) / wts.sum()
        nrm = np.linalg.eigh(((pts - centre) * wts[:, None]).T @ (pts - centre))[1][:, 0]
        rho = float(centre @ nrm)
        dist = hp @ nrm - rho
        if length < min_length * size or contrast < min_contrast or not (dist.min() < -1 and dist.max() > 1):
            continue
        ends = np.clip(np.round(pts).astype(np.int64), 0, [w - 1, h - 1])
        if to_hole[ends[:, 1], ends[:, 0]].min() <= max_gap * size:
            lines.append((length * contrast, float(np.arctan2(nrm[1], nrm[0])), rho))
    lines.sort(key=lambda r: -r[0])
    kept = []  # a weaker line that stays within a tenth of the hole's size of a kept one across the hole is the same boundary
    for _, a, r in lines:
        n, d = np.array([np.cos(a), np.sin(a)]), np.array([-np.sin(a), np.cos(a)])
        t = hp @ d
        ends = r * n + np.array([t.min(), t.max()])[:, None] * d  # the line's piece across the hole
        if all(np.abs(ends @ np.array([np.cos(b), np.sin(b)]) - q).max() > 0.1 * size for b, q in kept):
            kept.append((a, r))
    return kept[:max_lines]


def _cells(shape, lines, known, min_known=256):
    """Label of each pixel: which side of every line it lies on (a bit per line); -1 (any) for
    the pixels of a cell with fewer than ``min_known`` known pixels."""
    h, w = shape
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float64)
    cell = np.zeros(shape, np.int64)
    for i, (a, rho) in enumerate(lines):
        cell |= ((xx * np.cos(a) + yy * np.sin(a) - rho) > 0).astype(np.int64) << i
    counts = np.bincount(cell[known], minlength=1 << len(lines))
    return np.where(counts[cell] >= min_known, cell, -1)


def _shift_labels(lab, known, offsets, sweeps=4, miss=300.0, wr=3, wwin=4.0, cells=None):
    """Shift-map labelling of the hole (``~known``): each hole pixel takes one of ``offsets`` (or, only
    where none is allowed, a unit step) whose source is known or lies in an earlier layer of the
    hole (L1 distance to the known region), so copies chain inward without cycles. Greedy layer by
    layer from the border inward (window agreement + seam cost), then ICM sweeps on the seam cost
    (red-black order). Returns, for every pixel, the flat index of the known pixel it copies."""
    h, w = known.shape
    labs = np.concatenate([offsets, _UNIT])
    K = labs.shape[0]
    penalty = np.zeros(K)
    penalty[len(offsets):] = 1e7
    hole = ~known
    layer = cv2.distanceTransform(hole.astype(np.uint8), cv2.DIST_L1, 3).astype(np.int64)
    layer[known] = 0
    py, px = np.nonzero(hole)
    order = np.lexsort((px, py, layer[py, px]))
    py, px = py[order], px[order]
    n = py.size
    pl = layer[py, px]
    flat = lab.reshape(-1, 3)
    # sources, validity
    sy = py[:, None] + labs[None, :, 0]
    sx = px[:, None] + labs[None, :, 1]
    inb = (sy >= 0) & (sy < h) & (sx >= 0) & (sx < w)
    syc, sxc = np.clip(sy, 0, h - 1), np.clip(sx, 0, w - 1)
    valid = inb & (layer[syc, sxc] < pl[:, None])
    sidx = syc * w + sxc
    base = np.repeat(penalty[None, :], n, axis=0)
    if cells is not None:  # a copy crosses no structure line (the source on the pixel's side of each), unless it must
        cp, cs = cells[py, px][:, None], cells[syc, sxc]
        base[(cp >= 0) & (cs >= 0) & (cs != cp)] += 1e8
    base[~valid] = np.inf
    # index of each hole pixel in the list
    hidx = -np.ones(h * w, np.int64)
    hidx[py * w + px] = np.arange(n)
    S = np.arange(h * w)  # source (known pixel) each pixel copies
    assigned = known.reshape(-1).copy()
    lbl = -np.ones(n, np.int64)
    bounds = np.searchsorted(pl, np.arange(pl.max() + 2))

    def cost(sel):
        """costs (len(sel), K) for hole pixels sel, with the current S / assigned."""
        c = base[sel].copy()
        yy, xx = py[sel], px[sel]
        Fa = flat[S[sidx[sel]]]  # (m, K, 3)
        for dy_, dx_ in _UNIT:
            qy, qx = yy + dy_, xx + dx_
            qin = (qy >= 0) & (qy < h) & (qx >= 0) & (qx < w)
            qyc, qxc = np.clip(qy, 0, h - 1), np.clip(qx, 0, w - 1)
            q = qyc * w + qxc
            qa = assigned[q] & qin
            if not qa.any():
                continue
            # term 2: F(q + a) vs F(q)
            ty, tx = qyc[:, None] + labs[None, :, 0], qxc[:, None] + labs[None, :, 1]
            tin = (ty >= 0) & (ty < h) & (tx >= 0) & (tx < w)
            t = np.clip(ty, 0, h - 1) * w + np.clip(tx, 0, w - 1)
            tok = tin & assigned[t]
            d2 = ((flat[S[t]] - flat[S[q]][:, None, :]) ** 2).sum(-1)
            c += np.where(qa[:, None], np.where(tok, d2, miss), 0.0)
            # term 1: F(p + a) vs F(p + b), b = label of q (hole q only)
            qh = qa & ~known.reshape(-1)[q]
            if qh.any():
                b = np.where(qh, lbl[np.maximum(hidx[q], 0)], 0)
                b = np.maximum(b, 0)
                by, bx = yy + labs[b, 0], xx + labs[b, 1]
                bin_ = (by >= 0) & (by < h) & (bx >= 0) & (bx < w)
                bi = np.clip(by, 0, h - 1) * w + np.clip(bx, 0, w - 1)
                bok = qh & bin_ & assigned[bi]
                d1 = ((Fa - flat[S[bi]][:, None, :]) ** 2).sum(-1)
                c += np.where(bok[:, None], d1, 0.0)
        return c

    rr = wr
    dys, dxs = np.mgrid[-rr:rr + 1, -rr:rr + 1]
    dys, dxs = dys.ravel(), dxs.ravel()

    def wincost(sel):
        yy, xx = py[sel], px[sel]
        wy, wx = yy[:, None] + dys[None], xx[:, None] + dxs[None]  # (m, W)
        win_ = (wy >= 0) & (wy < h) & (wx >= 0) & (wx < w)
        wi = np.clip(wy, 0, h - 1) * w + np.clip(wx, 0, w - 1)
        wok = win_ & assigned[wi]
        Fw = flat[S[wi]]  # (m, W, 3)
        ty = wy[:, None, :] + labs[None, :, 0, None]
        tx = wx[:, None, :] + labs[None, :, 1, None]  # (m, K, W)
        tin = (ty >= 0) & (ty < h) & (tx >= 0) & (tx < w)
        ti = np.clip(ty, 0, h - 1) * w + np.clip(tx, 0, w - 1)
        ok = wok[:, None, :] & tin & assigned[ti]
        d = ((flat[S[ti]] - Fw[:, None]) ** 2).sum(-1)
        cnt = ok.sum(-1)
        return np.where(cnt > 0, (d * ok).sum(-1) / np.maximum(cnt, 1), miss)

    for L in range(1, pl.max() + 1):
        sel = np.arange(bounds[L], bounds[L + 1])
        if sel.size == 0:
            continue
        c = cost(sel) + wwin * wincost(sel)
        lbl[sel] = np.argmin(c, axis=1)
        S[py[sel] * w + px[sel]] = S[sidx[sel, lbl[sel]]]
        assigned[py[sel] * w + px[sel]] = True

    def propagate():
        for L in range(1, pl.max() + 1):
            sel = np.arange(bounds[L], bounds[L + 1])
            S[py[sel] * w + px[sel]] = S[sidx[sel, lbl[sel]]]

    par = (py + px) % 2
    for _ in range(sweeps):
        changed = 0
        for colour in (0, 1):
            sel = np.nonzero(par == colour)[0]
            c = cost(sel)
            cur = c[np.arange(sel.size), lbl[sel]]
            new = np.argmin(c, axis=1)
            better = c[np.arange(sel.size), new] < cur
            changed += better.sum()
            lbl[sel[better]] = new[better]
            propagate()
        if changed == 0:
            break
    return S


@dataclass
class ShiftMapInpainter(Inpainter):
    """Shift-map completion from the statistics of patch offsets (He and Sun, "Statistics of Patch
    Offsets for Image Completion", ECCV 2012), in numpy/scipy: the nearest neighbours of the known
    8x8 patches (8-bit CIELab, a k-d tree on pooled patch features) give an offset histogram whose
    ``n_labels`` dominant peaks are the labels; every hole pixel copies the known pixel at one of
    these offsets (chained inward through already filled pixels), chosen by a greedy border-inward
    pass and ICM sweeps on the shift-map seam cost, so stationary textures and straight structures
    (stripes, a border) continue across the hole. The offsets are gathered from the hole's bounding
    box grown by ``context`` x its size on every side (0: the whole image). Copies the input's own
    colours (no quantisation). With too few known patches for statistics it falls back to
    ``cv2.inpaint`` TELEA (as ``telea``). With ``structure`` (the default), the straight boundaries
    between regions that cross the hole (:func:`_crossing_lines`: a mat's border, not the stripes of
    a texture) are continued first, as in structure propagation (Sun et al., "Image Completion with
    Structure Propagation", SIGGRAPH 2005): they split the hole, each part copies only from the
    context on its own side of every line, and offsets along each line join the labels. Deterministic
    (no randomness, single-threaded k-d tree queries); colour only. Replaces OpenCV's ``xphoto``
    SHIFTMAP, whose output varies between processes."""

    name: ClassVar[str] = "shiftmap"
    supports_depth: ClassVar[bool] = False
    context: float = 0.5
    structure: bool = True

    def _fill_rgb(self, img, mask):
        if self.context > 0:
            ys, xs = np.nonzero(mask)
            gy, gx = self.context * (np.ptp(ys) + 1), self.context * (np.ptp(xs) + 1)
            y0, y1 = max(0, int(ys.min() - gy)), min(mask.shape[0], int(ys.max() + gy) + 1)
            x0, x1 = max(0, int(xs.min() - gx)), min(mask.shape[1], int(xs.max() + gx) + 1)
            out = img.copy()
            out[y0:y1, x0:x1] = self._shiftmap(img[y0:y1, x0:x1], mask[y0:y1, x0:x1], self.structure)
            return out
        return self._shiftmap(img, mask, self.structure)

    @staticmethod
    def _shiftmap(img, mask, structure=True, patch=8, n_labels=40):
        h, w = mask.shape
        rgb8 = np.clip(np.round(img * 255.0), 0, 255).astype(np.uint8)
        lab = cv2.cvtColor(rgb8, cv2.COLOR_RGB2Lab).astype(np.float64)
        known = ~mask
        f = 1  # offset statistics at a scale of <= 160 pixels, offsets refined at full scale
        while max(h, w) // f > 160:
            f *= 2
        if f > 1:
            hc, wc = h // f, w // f
            labc = lab[: hc * f, : wc * f].reshape(hc, f, wc, f, 3).mean(axis=(1, 3))
            knc = known[: hc * f, : wc * f].reshape(hc, f, wc, f).all(axis=(1, 3))
            offs = _dominant_offsets(labc, knc, patch, n_labels)
            if offs is not None:
                offs = _refine_offsets(lab, known, offs * f, f // 2)
        else:
            offs = _dominant_offsets(lab, known, patch, n_labels)
        if offs is None:
            return _cv_fill(img, mask, cv2.INPAINT_TELEA, 3.0)
        cells = None
        lines = _crossing_lines(lab, mask) if structure else []
        if lines:
            cells = _cells(mask.shape, lines, known)
            # copies along each line (half, one and one and a half times the hole's extent), so that
            # what runs beside it continues
            ys, xs = np.nonzero(mask)
            extent = max(np.ptp(ys), np.ptp(xs)) + 1
            along = np.array([np.round(sign * k * extent * np.array([np.cos(a), -np.sin(a)])) for a, _ in lines for k in (0.5, 1.0, 1.5) for sign in (1, -1)], np.int64)
            offs = np.unique(np.concatenate([offs, along[np.abs(along).sum(1) > 0]]), axis=0)
        src = _shift_labels(lab, known, offs, cells=cells)
        return img.reshape(-1, 3)[src].reshape(img.shape)


@dataclass
class LamaInpainter(Inpainter):
    """LaMa from an ONNX checkpoint (``lama_onnx`` or ``$INPAINT360GS_LAMA_ONNX``), loaded on creation.

    LaMa from a user-supplied ONNX checkpoint (:mod:`inpaint360gs.inpaint.lama`; ``lama_onnx`` or
    ``$INPAINT360GS_LAMA_ONNX``). Depth through LaMa is how this package does the paper's "depth
    inpainted by LaMa": the known depth is normalised to [0, 1] by its minimum and maximum over the
    known pixels, replicated to three channels, inpainted as an image, the channels averaged and
    the normalisation undone (the fill stays within the known depth range)."""

    name: ClassVar[str] = "lama"
    lama_onnx: str | Path | None = None
    output_range: str = "auto"

    def __post_init__(self):
        from inpaint360gs.inpaint.lama import LamaOnnx

        self._model = LamaOnnx(self.lama_onnx, output_range=self.output_range)

    def _fill_rgb(self, img, mask):
        return self._model(img.astype(np.float32), mask).astype(np.float64)

    def _fill_depth(self, depth, mask):
        known = depth[~mask]
        lo, hi = float(known.min()), float(known.max())
        if hi - lo <= 0:
            return np.full_like(depth, lo)
        n = np.where(mask, 0.0, (depth - lo) / (hi - lo)).astype(np.float32)
        pred = self._model(np.repeat(n[..., None], 3, axis=2), mask).astype(np.float64).mean(axis=2)
        return pred * (hi - lo) + lo


INPAINTERS: dict[str, type[Inpainter]] = {
    cls.name: cls
    for cls in (TeleaInpainter, NSInpainter, HarmonicInpainter, PlaneInpainter, PatchMatchInpainter, PatchMatchHarmonicInpainter, ShiftMapInpainter, LamaInpainter)
}
RGB_METHODS = tuple(n for n, c in INPAINTERS.items() if c.supports_rgb)
DEPTH_METHODS = tuple(n for n, c in INPAINTERS.items() if c.supports_depth)


def make_inpainter(name: str, **options) -> Inpainter:
    """The inpainter ``name`` (``INPAINTERS``) with its options (``radius``, ``ring``, ``seed``,
    ``patch_size``, ``sigma``, ``context``, ``structure``, ``lama_onnx``, ``output_range``); options only another method takes are
    ignored, so one option set can serve an RGB and a depth method; an option no method takes is
    an InputError."""
    cls = INPAINTERS.get(name)
    if cls is None:
        raise InputError(f"unknown inpainter {name!r} (choose from {', '.join(INPAINTERS)})", "method")
    unknown = sorted(set(options) - {f for c in INPAINTERS.values() for f in c.__dataclass_fields__})
    if unknown:
        raise InputError(f"unknown inpainter option(s) {', '.join(unknown)}", "options")
    fields = set(cls.__dataclass_fields__)
    return cls(**{k: v for k, v in options.items() if k in fields})


def inpaint_rgb(image, mask, method: str = DEFAULT_RGB, **options) -> np.ndarray:
    """Fill the masked pixels of an (H, W, 3) float image in [0, 1] with ``method``; the rest is returned unchanged."""
    return make_inpainter(method, **options).rgb(image, mask)


def inpaint_depth(depth, mask, method: str = DEFAULT_DEPTH, **options) -> np.ndarray:
    """Fill the masked pixels of an (H, W) depth map (metres, > 0 where known) with ``method``; the rest is returned unchanged."""
    return make_inpainter(method, **options).depth(depth, mask)
