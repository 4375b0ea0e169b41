"""Selecting what to remove: a click is a prompt (paper Sec. 3.4 first paragraph: the object under a
click, read off the rendered id map).

A click (a view and a pixel, in the coordinates of the image in ``images/``) selects, in order:

1. the object the distilled field's id map shows there (argmax of the classifier on the rendered
   identity features, where the rendered alpha is at least 0.5: the paper's click);
2. else the object that owns most of the pixel's colour among the Gaussians it is composited from
   (the weights ``alpha T`` of Eq. 1): thin or faint parts (a leg, a handle) whose pixels are less
   than half covered, or whose rendered feature is mixed with what lies behind them;
3. else, when those Gaussians belong to no object (the segmenter missed it), the object grown in 3D
   from them: the connected set of Gaussians standing on the support plane (higher than the
   geometric segmenter's tau) linked to them, as :func:`.removal.object_body` links centres.

A click where nothing is rendered, on the support surface itself, or on something that cannot be
told from the rest of the scene is refused with the reason.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from inpaint360gs.core.errors import InputError
from inpaint360gs.distill.field import IdentityField
from inpaint360gs.io.scene import Scene, View


@dataclass(frozen=True)
class Click:
    """A user's selection: a pixel (column x, row y) in a named view, in the coordinates of the image
    as it lies in the scene's ``images/`` (at full size, whatever ``--resize`` the run uses)."""

    view: str
    x: int
    y: int

    def __post_init__(self) -> None:
        if not isinstance(self.view, str) or not self.view.strip():
            raise InputError(f"a click's view is a view's name, got {self.view!r:.40}", setting="clicks")
        for v in (self.x, self.y):
            if isinstance(v, bool) or not isinstance(v, int):
                raise InputError(f"a click's pixel is two whole numbers, got {v!r:.40}", setting="clicks")

    @staticmethod
    def make(view: object, x: object, y: object, where: str | Path | None = None) -> "Click":
        """A click from loose values (a JSON file's, a tuple's): ``x`` and ``y`` whole finite numbers
        (``3.0`` is taken, ``3.5``, ``inf``, ``"3"`` and ``True`` are not); :class:`InputError` naming
        ``where`` (or the setting ``clicks``) otherwise."""
        ok = isinstance(view, str) and view.strip() and all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and v == int(v) for v in (x, y))
        if not ok:
            raise InputError(f"click ({view!r:.40}, {x!r:.20}, {y!r:.20}) is not a view's name and a pixel of two whole numbers", where, setting=None if where else "clicks")
        return Click(view, int(x), int(y))

    @staticmethod
    def parse(text: str) -> "Click":
        """``VIEW:X,Y`` (e.g. ``IMG_0003.png:120,88``)."""
        try:
            view, xy = text.rsplit(":", 1)
            x, y = (int(round(float(s))) for s in xy.split(","))
            if not view.strip():
                raise ValueError("no view")
        except (ValueError, OverflowError):  # OverflowError: an infinite coordinate
            raise InputError(f"click {text!r} is not VIEW:X,Y (e.g. IMG_0003.png:120,88)", setting="clicks") from None
        return Click(view, x, y)

    def __str__(self) -> str:
        return f"{self.view}:{self.x},{self.y}"

    def pixel(self, view: View) -> tuple[int, int]:
        """(column, row) of the click in ``view``'s camera (the scene's resolution): the full-size
        pixel's centre scaled by the camera's size over the image's."""
        cam = view.camera
        w, h = view.full_size or (cam.width, cam.height)
        return min(int((self.x + 0.5) * cam.width / w), cam.width - 1), min(int((self.y + 0.5) * cam.height / h), cam.height - 1)


@dataclass
class ClickSelection:
    """What a click selected: a field object (``object_id``) or a set of Gaussians grown from the click
    (``gaussians``, (N,) bool), and how (``"id map"``, ``"contributions"``, ``"grown"``)."""

    click: Click
    how: str
    object_id: int | None = None
    gaussians: np.ndarray | None = None


def check_selection(clicks: object, ids: object) -> None:
    """The types of a selection, before any work: ``clicks`` None or a list of :class:`Click`,
    ``ids`` None or a list of whole numbers in 1..255 (``associate.config.MAX_OBJECTS``; 0 is the
    background). :class:`InputError` naming ``clicks`` or ``ids``."""
    from inpaint360gs.associate.config import MAX_OBJECTS

    if clicks is not None and not (isinstance(clicks, (list, tuple)) and all(isinstance(c, Click) for c in clicks)):
        raise InputError(f"expected a list of clicks, got {clicks!r:.60}", setting="clicks")
    if ids is not None:
        if not isinstance(ids, (list, tuple)):
            raise InputError(f"expected a list of object ids, got {ids!r:.60}", setting="ids")
        for i in ids:
            if isinstance(i, bool) or not isinstance(i, int) or not 1 <= i <= MAX_OBJECTS:
                raise InputError(f"an object id is a whole number in 1..{MAX_OBJECTS}, got {i!r:.40}", setting="ids")


def clicks_from_json(entries: object, where: str | Path) -> list[Click]:
    """The clicks a ``scene.json`` names (``clicks``: a list of ``{view, x, y}``), as a user would give
    them: ``view`` a name, ``x`` and ``y`` whole numbers. :class:`InputError` naming ``where`` for
    anything else (a coordinate that is not finite, a fraction, a string); ``inpaint360gs run`` and
    ``validate`` read them here, so they agree on what is a click."""
    if not isinstance(entries, list) or not all(isinstance(c, dict) for c in entries):
        raise InputError("clicks must be a list of {view, x, y}", where)
    return [Click.make(c.get("view"), c.get("x"), c.get("y"), where) for c in entries]


def click_problem(c: Click, views: Mapping[str, tuple[int, int, bool]]) -> str | None:
    """Why the click ``c`` cannot select anything before the field exists, or None: ``views`` maps
    each registered view's name to (width, height, is a test_ view) of its image in ``images/``.
    The rule of :func:`check_clicks` and ``validate``."""
    name = c.view if c.view in views else next((n for n in views if Path(n).stem == c.view), None)
    if name is None:
        return f"click {c}: the scene has no view {c.view!r}"
    w, h, test = views[name]
    if test:
        return f"click {c}: {name} is an evaluation (test_) view; click on a training view"
    if not (0 <= c.x < w and 0 <= c.y < h):
        return f"click {c} is outside the {w}x{h} image (clicks are in the coordinates of images/)"
    return None


def check_clicks(scene: Scene, clicks: list[Click], where: str | Path | None = None) -> list[View]:
    """The view of each click; :class:`InputError` for an unknown view, an evaluation (``test_``) view
    or a pixel outside the image (what can be checked before the field exists, :func:`click_problem`).
    ``where``: where the clicks came from, named in the error."""
    sizes = {v.name: (*(v.full_size or (v.camera.width, v.camera.height)), v.is_test) for v in scene.views}
    for c in clicks:
        problem = click_problem(c, sizes)
        if problem is not None:
            raise InputError(problem, where, setting=None if where else "clicks")
    return [scene.view(c.view) for c in clicks]


def resolve_clicks(field_: IdentityField, scene: Scene, clicks: list[Click], *, backend: str = "auto") -> list[int]:
    """The object id each click selects; a click that selects no field object (step 3 of the module
    docstring) is an :class:`InputError` here: use :func:`select` for those."""
    ids = []
    for sel in select(field_, scene, clicks, grow=False, backend=backend):
        ids.append(sel.object_id)
    return ids


def select(field_: IdentityField, scene: Scene, clicks: list[Click], *, grow: bool = True, backend: str = "auto",
           pixel_share: float = 0.5, max_share: float = 0.5, id_maps: dict | None = None) -> list[ClickSelection]:  # fmt: skip
    """What each click selects (the module docstring's three steps). ``pixel_share``: the share of the
    pixel's colour an object must own in step 2; ``max_share``: a grown set holding more than this
    share of the Gaussians standing on the support is not one object (step 3 refuses it).
    ``id_maps``: view name -> :func:`id_map` of that view, when already rendered (the viewer's)."""
    out = []
    frame = None
    for c, view in zip(clicks, check_clicks(scene, clicks)):
        x, y = c.pixel(view)
        id_map = id_maps[view.name] if id_maps is not None and view.name in id_maps else click_id_map(field_, view)
        oid = int(id_map[y, x])
        if oid != 0:
            out.append(ClickSelection(c, "id map", object_id=oid))
            continue
        weights, idx = _pixel_weights(field_, view, x, y, backend)
        if weights.sum() < 1e-3:
            raise InputError(f"click {c} is on empty space: the scene renders nothing there", setting="clicks")
        owners = np.asarray(field_.object_ids)[field_.gaussian_probs()[torch.from_numpy(idx)].argmax(dim=1).numpy()]
        share = {int(o): float(weights[owners == o].sum() / weights.sum()) for o in np.unique(owners)}
        best = max((o for o in share if o != 0), key=lambda o: share[o], default=None)
        if best is not None and share[best] >= pixel_share:
            out.append(ClickSelection(c, "contributions", object_id=best))
            continue
        if not grow:
            raise InputError(f"click {c} is on the background (no object there in the rendered id map)", setting="clicks")
        if frame is None:
            frame = _frame(field_, scene)
        out.append(ClickSelection(c, "grown", gaussians=_grow(field_, frame, idx, weights, c, max_share)))
    return out


def click_id_map(field_: IdentityField, view: View):
    """(H, W) the object id map a click reads (:meth:`IdentityField.render_ids`; id 0 where the
    pixel is less than half covered: nothing there)."""
    return field_.render_ids(view.camera, min_alpha=0.5)[0]


def _pixel_weights(field_: IdentityField, view: View, x: int, y: int, backend: str) -> tuple[np.ndarray, np.ndarray]:
    """(weights alpha T, Gaussian indices) of the Gaussians composited into pixel (x, y) (Eq. 1)."""
    from inpaint360gs.render.contributions import contributions

    w = contributions(field_.gaussians.map(lambda t: t.detach()), view.camera, backend=backend if backend != "auto" else "numba", min_weight=1e-4)
    p = y * view.camera.width + x
    lo, hi = int(w.indptr[p]), int(w.indptr[p + 1])
    return w.vals[lo:hi].double().numpy(), w.cols[lo:hi].long().numpy()


def _frame(field_: IdentityField, scene: Scene):
    from inpaint360gs.segment.cluster3d import ClusterConfig
    from inpaint360gs.segment.frame import scene_frame

    g = field_.gaussians
    cc = ClusterConfig()
    return scene_frame([v.camera for v in scene.train_views], g.means.detach().cpu().double().numpy(), g.opacities.detach().cpu().numpy(),
                       min_opacity=cc.plane_min_opacity, tol_frac=cc.plane_tol, tries=cc.plane_tries, max_tilt_deg=cc.plane_max_tilt_deg)  # fmt: skip


def _grow(field_: IdentityField, frame, idx: np.ndarray, weights: np.ndarray, click: Click, max_share: float) -> np.ndarray:
    """Step 3: the Gaussians standing on the support (higher than tau, opacity above the geometric
    segmenter's growing threshold) linked to the front contributors of the clicked pixel."""
    from scipy.sparse.csgraph import connected_components
    from scipy.spatial import cKDTree

    from inpaint360gs.segment.cluster3d import ClusterConfig

    cc = ClusterConfig()
    g = field_.gaussians
    means = g.means.detach().cpu().double().numpy()
    heights = frame.heights(means)
    tau = cc.tau * frame.radius
    k = int(np.searchsorted(np.cumsum(weights), 0.5 * weights.sum())) + 1
    front = idx[:k]  # the front-most Gaussians giving half the pixel's colour (contributions come front to back)
    if np.median(heights[front]) <= tau:
        raise InputError(f"click {click} is on the support surface the objects stand on, not on an object standing there: click on the object", setting="clicks")
    standing = (heights > tau) & (g.opacities.detach().cpu().numpy() > cc.grow_min_opacity)
    cand = np.flatnonzero(standing)
    seeds = np.intersect1d(front, cand)
    tree = cKDTree(means[cand])
    d, _ = tree.query(means[cand], k=2)
    graph = tree.sparse_distance_matrix(tree, 4.0 * float(np.median(d[:, 1])), output_type="coo_matrix")
    _, labels = connected_components(graph, directed=False)
    pos = np.searchsorted(cand, seeds)
    comp = np.isin(labels, np.unique(labels[pos]))
    if comp.sum() > max_share * len(cand):
        raise InputError(f"click {click}: what stands there is joined to most of the scene ({comp.sum()} of {len(cand)} Gaussians standing "
                         "on the support); no single object can be told apart there", setting="clicks")  # fmt: skip
    out = np.zeros(len(means), dtype=bool)
    out[cand[comp]] = True
    return out


def support_heights(field_: IdentityField, scene: Scene) -> tuple[np.ndarray | None, float, str, np.ndarray | None]:
    """(height of every Gaussian above the support plane, orbit radius R, note, the plane's unit
    normal) from the training cameras and the opaque centres, as the geometric segmenter finds them;
    (None, 0, why, None) without a plane."""
    from inpaint360gs.segment.cluster3d import ClusterConfig
    from inpaint360gs.segment.frame import scene_frame

    g = field_.gaussians
    means = g.means.detach().cpu().double().numpy()
    cc = ClusterConfig()
    try:
        frame = scene_frame([v.camera for v in scene.train_views], means, g.opacities.detach().cpu().numpy(),
                            min_opacity=cc.plane_min_opacity, tol_frac=cc.plane_tol, tries=cc.plane_tries, max_tilt_deg=cc.plane_max_tilt_deg)  # fmt: skip
    except InputError as e:
        return None, 0.0, f"support guard skipped: {e}", None
    return frame.heights(means), frame.radius, "support plane found", frame.up


