"""Never-before-seen (NBS) regions in any view, derived geometrically from the Gaussian field, and
the occluders of the removed objects (paper Sec. 3.4; supp. B "Virtual Camera Views").

The paper tracks the NBS mask through the virtual views with SAM-Tracking and its authors
hand-pick masks in a GUI; here there is no tracker and no GUI. A pixel of a view needs inpainting
when it lies in the removed objects' footprint (the removed Gaussians gave it at least half of its
colour in the original model) and the surface the removal reveals there was never observed:

* nothing is revealed (the edited scene renders alpha < 0.5 there: a hole), or
* the revealed point (back-projected with the edited scene's depth, Eq. 5 normalised by alpha)
  is seen by no training view: in every training view it is off-image, behind the camera,
  hidden — the original scene's depth there (the object present) is nearer by more than
  ``depth_tol`` of the distance — or shown by the removed objects themselves (their Gaussians give
  that training pixel at least ``seen_object_share`` of its colour). The last case is where an object
  meets its support: at the contact the object's base lies within ``depth_tol`` of the floor point
  behind it, so the depth test alone counts the floor under the base as observed, although what
  the training views recorded there is the object's base (its colour stays in the Gaussians the
  removal reveals: a dark print of the base that the inpainting must replace).

The mask is then cleaned of specks (components smaller than ``min_component`` pixels) and dilated by
``dilate`` pixels (the authors dilate their inpainting masks before LaMa too).

Occluders of the target in a view are other objects in front of it: pixels of the target's own
silhouette (the removed Gaussians rendered alone) where the original scene's id map shows another
object nearer than the target. They are found by object id in 3D and removed for inpainting, then
put back (the paper finds them with a detector; Sec. 3.4).
"""

from __future__ import annotations

from collections.abc import Sequence

import cv2
import numpy as np
import torch

from inpaint360gs.core.camera import Camera
from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.render.api import RenderOutput, render
from inpaint360gs.views.config import UnseenConfig  # noqa: F401  (defined with the other settings, importable here)


def normalised_depth(out: RenderOutput, min_alpha: float = 1e-3) -> torch.Tensor:
    """Depth of the surface a pixel shows: Eq. 5's ``Σ z α T`` divided by alpha (0 where alpha is ~0)."""
    a = out.alpha
    return torch.where(a > min_alpha, out.depth / a.clamp_min(min_alpha), torch.zeros_like(a))


def backproject(camera: Camera, depth: np.ndarray, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """World points of pixel centres (rows, cols) at camera-space z ``depth``."""
    R = camera.R.detach().cpu().double().numpy()
    t = camera.t.detach().cpu().double().numpy()
    x = (cols + 0.5 - camera.cx) / camera.fx * depth
    y = (rows + 0.5 - camera.cy) / camera.fy * depth
    xc = np.stack([x, y, depth], axis=-1)
    return (xc - t) @ R  # R^T (x_cam - t)


def project(camera: Camera, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pixel column, row (floats) and camera z of world points."""
    R = camera.R.detach().cpu().double().numpy()
    t = camera.t.detach().cpu().double().numpy()
    xc = points @ R.T + t
    z = xc[:, 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        u = camera.fx * xc[:, 0] / z + camera.cx
        v = camera.fy * xc[:, 1] / z + camera.cy
    return u, v, z


class TrainingVisibility:
    """The training views' depth with the objects present, for "was this point ever seen?" tests.

    With ``removed`` (N,) flags of ``model``'s removed Gaussians, a training pixel that the removed
    objects colour (share ``object_share`` or more) observes no point behind or under them, even
    when the depths agree within the tolerance (see the module docstring)."""

    def __init__(
        self,
        model: Gaussians,
        cameras: Sequence[Camera],
        backend: str = "auto",
        min_alpha: float = 0.5,
        removed: torch.Tensor | None = None,
        object_share: float = 0.1,
    ):
        self.cameras = list(cameras)
        self.depths = []
        self.object_pixels: list[np.ndarray | None] = []
        if removed is not None:  # one render per view gives the depth and the removed objects' colour share
            model = model.map(lambda t: t)
            model.features = removed.to(model.means.dtype)[:, None]
        with torch.no_grad():
            for c in self.cameras:
                o = render(model, c, with_features=removed is not None, backend=backend)
                d = normalised_depth(o).numpy()
                d[o.alpha.numpy() < min_alpha] = 0.0  # no surface: nothing occludes there
                self.depths.append(d)
                self.object_pixels.append(None if removed is None else (o.features[..., 0] >= object_share).numpy())

    def seen(self, points: np.ndarray, depth_tol: float) -> np.ndarray:
        """Which world points some training view observed (in its image, in front, not occluded)."""
        seen = np.zeros(len(points), dtype=bool)
        for cam, d, obj in zip(self.cameras, self.depths, self.object_pixels):
            todo = ~seen
            if not todo.any():
                break
            u, v, z = project(cam, points[todo])
            ok = (z > 1e-6) & (u >= 0) & (u < cam.width) & (v >= 0) & (v < cam.height)
            idx = np.flatnonzero(todo)[ok]
            vi, ui = v[ok].astype(np.int64), u[ok].astype(np.int64)
            surf = d[vi, ui]
            visible = (surf <= 0) | (surf >= z[ok] * (1.0 - depth_tol))  # nothing nearer in front of it
            if obj is not None:
                visible &= ~obj[vi, ui]  # the pixel recorded the removed objects, not this point
            seen[idx[visible]] = True
        return seen


def rendered_share(model: Gaussians, flags: torch.Tensor | np.ndarray, camera: Camera, backend: str = "auto") -> np.ndarray:
    """(H, W) share of each pixel's colour that the Gaussians flagged in ``flags`` (N,) give (Eq. 1)."""
    g = model.map(lambda t: t)
    g.features = torch.as_tensor(flags).to(device=model.means.device, dtype=model.means.dtype)[:, None]
    with torch.no_grad():
        return render(g, camera, with_features=True, backend=backend).features[..., 0].cpu().numpy()


def footprint(model: Gaussians, removed: torch.Tensor, camera: Camera, share: float = 0.5, backend: str = "auto",
              near: float | None = None) -> np.ndarray:  # fmt: skip
    """Pixels at least ``share`` of whose colour the Gaussians flagged in ``removed`` gave (full model).

    ``near``: leave out the Gaussians nearer to ``camera`` than this x the median camera depth of the
    removed ones in front of it (None: none left out). A haze of floaters hanging in front of a
    camera (3DGS leaves them near views it was not trained on) gives every pixel of such a view a
    share of its colour, so that the object behind it gives less than ``share`` anywhere and its
    footprint is empty; what lies between the camera and half the object's distance is not the
    object's surroundings either way."""
    if near is None:
        return rendered_share(model, removed, camera, backend) >= share
    flags = torch.as_tensor(removed, dtype=torch.bool).cpu()
    z = project(camera, model.means.detach().cpu().double().numpy())[2]
    zr = z[flags.numpy() & (z > 1e-6)]
    if not len(zr):
        return np.zeros((camera.height, camera.width), dtype=bool)
    keep = torch.from_numpy(z >= near * float(np.median(zr))).to(flags.device)
    return rendered_share(model.subset(keep), flags[keep], camera, backend) >= share


def share_in_front(model: Gaussians, camera: Camera, planes: Sequence[tuple[np.ndarray, float]], margin: float = 0.03, backend: str = "auto") -> np.ndarray:
    """(H, W) share of each pixel's colour given by the Gaussians in front of the ``planes``
    ((unit normal, offset) pairs, n.x = offset): those nearer to the camera than (1 - ``margin``) x
    the distance at which the ray through their centre meets each plane (or whose ray meets it
    nowhere ahead). Alpha compositing (Eq. 1) makes an opaque surface in front give nearly all of
    the colour and a faint haze little, where the alpha-normalised depth of Eq. 5 puts the haze's
    depth in front either way."""
    p = model.means.detach().cpu().double().numpy()
    c = camera.center.detach().cpu().double().numpy()
    front = project(camera, p)[2] > 1e-6
    for normal, offset in planes:
        n = np.asarray(normal, dtype=np.float64)
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (offset - n @ c) / ((p - c) @ n)  # the plane meets the ray at c + t (p - c)
        front &= ~np.isfinite(t) | (t <= 0) | (t > 1.0 / (1.0 - margin))
    return rendered_share(model, front, camera, backend)


def clean_mask(mask: np.ndarray, min_component: int, dilate: int) -> np.ndarray:
    """Drop connected components smaller than ``min_component`` pixels, then dilate by ``dilate``."""
    m = mask.astype(np.uint8)
    if min_component > 1 and m.any():
        n, lab, stats, _ = cv2.connectedComponentsWithStats(m, connectivity=8)
        small = np.flatnonzero(stats[:, cv2.CC_STAT_AREA] < min_component)
        m[np.isin(lab, small[small > 0])] = 0
    if dilate > 0 and m.any():
        k = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * dilate + 1, 2 * dilate + 1))
        m = cv2.dilate(m, k)
    return m.astype(bool)


def unseen_mask(
    original: Gaussians,
    removed: torch.Tensor,
    edited: Gaussians,
    camera: Camera,
    visibility: TrainingVisibility,
    cfg: UnseenConfig | None = None,
    backend: str = "auto",
) -> tuple[np.ndarray, np.ndarray]:
    """(cleaned unseen mask, raw unseen mask before cleaning) of ``camera`` (see the module docstring).

    ``original`` is the scene with the objects, ``removed`` (N,) flags its removed Gaussians,
    ``edited`` is the scene after removal (and with any occluders taken out)."""
    cfg = cfg or UnseenConfig()
    fp = footprint(original, removed, camera, cfg.footprint_share, backend)
    with torch.no_grad():
        o = render(edited, camera, backend=backend)
    alpha = o.alpha.numpy()
    depth = normalised_depth(o).numpy()
    rows, cols = np.nonzero(fp & (alpha >= cfg.min_alpha))
    raw = fp & (alpha < cfg.min_alpha)
    if len(rows):
        pts = backproject(camera, depth[rows, cols].astype(np.float64), rows, cols)
        unseen = ~visibility.seen(pts, cfg.depth_tol)
        raw[rows[unseen], cols[unseen]] = True
    return clean_mask(raw, cfg.min_component, cfg.dilate), raw


def occluders(
    original: Gaussians,
    removed: torch.Tensor,
    object_ids: np.ndarray,
    cameras: Sequence[Camera],
    exclude: set[int],
    min_pixels: int = 10,
    depth_tol: float = 0.03,
    backend: str = "auto",
) -> dict[int, int]:
    """Objects in front of the removed ones in any of ``cameras``: id -> largest number of occluding
    pixels in one view (at least ``min_pixels``). ``object_ids`` (N,) is each Gaussian's object id in
    ``original`` (0 = background); ids in ``exclude`` (the removed objects) never count.

    A pixel of the removed objects' own silhouette is occluded by object o when the original scene
    shows o there (the majority id among the Gaussians that colour it) nearer than the removed
    objects' surface."""
    target = original.subset(removed)
    n_ids = int(object_ids.max()) + 1 if len(object_ids) else 1
    g = original.map(lambda t: t)
    g.features = torch.nn.functional.one_hot(torch.as_tensor(object_ids, dtype=torch.long), n_ids).to(original.means.dtype)
    found: dict[int, int] = {}
    with torch.no_grad():
        for cam in cameras:
            t_out = render(target, cam, backend=backend)
            sil = t_out.alpha.numpy() >= 0.5
            if not sil.any():
                continue
            t_depth = normalised_depth(t_out).numpy()
            o = render(g, cam, with_features=True, backend=backend)
            ids = o.features.argmax(-1).numpy()
            o_depth = normalised_depth(o).numpy()
            front = sil & (o_depth < t_depth * (1.0 - depth_tol)) & (o.alpha.numpy() >= 0.5)
            oids, counts = np.unique(ids[front], return_counts=True)
            for oid, c in zip(oids, counts):
                if oid != 0 and int(oid) not in exclude and c >= min_pixels:
                    found[int(oid)] = max(found.get(int(oid), 0), int(c))
    return found
