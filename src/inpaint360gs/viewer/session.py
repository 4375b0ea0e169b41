"""What the viewer shows and does, without a web library (README "Viewer"): one scene, one run folder.

* The splats of each stage of the run (:data:`MODES`: the trained 3DGS, after removal, after
  inpainting) as the arrays a Gaussian-splat renderer takes (:func:`splat_arrays`).
* The training cameras: their pose and frustum (:func:`camera_pose`, :func:`frustum_shape`), and the
  pixel of the photo a ray through the frustum's image hits (:func:`pixel_from_ray`).
* The selection (:class:`ViewerSession`): a click selects the object under it with the selection of
  ``inpaint360gs run --click`` (:func:`inpaint360gs.remove.stage.plan_removal`, the same clicks, the
  same settings), a click on a selected object drops it; its selection check (object / too small /
  support / backdrop / off the click) and fill mask are shown. It can be saved as ``scene.json``'s
  clicks.
* The run (:class:`RunJob`): :class:`inpaint360gs.pipeline.run.Runner` in a background thread on the
  same run folder, so OUT is what ``inpaint360gs run`` with those clicks writes (and resumes)."""

from __future__ import annotations

import json
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import torch

from inpaint360gs.core.camera import Camera
from inpaint360gs.core.errors import InputError
from inpaint360gs.core.gaussians import Gaussians, quat_to_rotmat
from inpaint360gs.core.layout import SCENE_JSON, RunLayout
from inpaint360gs.core.progress import progress_listener
from inpaint360gs.io.atomic import write_text
from inpaint360gs.io.ply import read_ply
from inpaint360gs.io.scene import Scene, View
from inpaint360gs.pipeline.check import CHECK_JSON, CHECK_PICTURE, selection_overlay
from inpaint360gs.pipeline.config import RunConfig
from inpaint360gs.pipeline.run import STAGES, Runner
from inpaint360gs.remove.select import Click
from inpaint360gs.remove.objects import fill_masks
from inpaint360gs.remove.select import check_clicks, click_id_map, select
from inpaint360gs.remove.stage import RemovalPlan, Selected, complete_plan, load_field, plan_removal, select_removal, support_plane
from inpaint360gs.render.feature_cache import FeatureRenders
from inpaint360gs.viewer.splats import splat_arrays_np

MODES = ("before", "removed", "inpainted")  # the splats the page can show: 3DGS, after removal, after inpainting


def splat_arrays(g: Gaussians) -> dict[str, np.ndarray]:
    """The Gaussians as a splat renderer takes them (:func:`.splats.splat_arrays_np`): ``centers``
    (N, 3), ``covariances`` (N, 3, 3) ``R S S^T R^T`` (Eq. 1's Sigma), ``rgbs`` (N, 3) the
    view-independent colour (degree-0 SH, as the renderer's ``SH_C0 * dc + 0.5``, in [0, 1]) and
    ``opacities`` (N, 1); float32."""
    def a(t):
        return t.detach().cpu().double().numpy()

    return splat_arrays_np(a(g.means), a(g.log_scales), a(g.quats), a(g.opacity_logits), a(g.sh0[:, 0, :]))


def _wxyz(rot: np.ndarray) -> np.ndarray:
    from scipy.spatial.transform import Rotation

    x, y, z, w = Rotation.from_matrix(rot).as_quat()
    return np.array([w, x, y, z])


def camera_pose(cam: Camera) -> tuple[np.ndarray, np.ndarray]:
    """(wxyz, position) of the camera-to-world transform (OpenCV axes: +z forward, +y down)."""
    R = cam.R.double().numpy()
    return _wxyz(R.T), cam.center.double().numpy()


def frustum_shape(cam: Camera) -> tuple[float, float]:
    """(vertical field of view in radians, width / height) of ``cam``."""
    return 2.0 * float(np.arctan(cam.height / (2.0 * cam.fy))), cam.width / cam.height


def frustum_depth(fov: float, aspect: float, scale: float) -> float:
    """Depth, in the camera's frame, of the image a frustum of ``scale`` shows (viser's frustum: the
    pyramid of half-extents ``tan(fov/2) * aspect``, ``tan(fov/2)``, 1 normalised to volume 1/3 of
    its box, times ``scale``)."""
    y = np.tan(fov / 2.0)
    return float(scale / np.cbrt(y * aspect * y / 3.0))


def pixel_from_ray(view: View, origin, direction, depth: float) -> tuple[int, int] | None:
    """The pixel (in ``images/`` coordinates, as a :class:`Click` takes it) of ``view``'s photo shown
    on its frustum at ``depth`` that the world ray ``origin + s direction`` hits, or None when it
    misses the photo. The photo spans the frustum's far rectangle, its top row at -y."""
    cam = view.camera
    R, t = cam.R.double().numpy(), cam.t.double().numpy()
    o = R @ np.asarray(origin, float) + t
    d = R @ np.asarray(direction, float)
    if abs(d[2]) < 1e-12:
        return None
    s = (depth - o[2]) / d[2]
    if s < 0:
        return None
    p = o + s * d
    fov, aspect = frustum_shape(cam)
    half_y = depth * np.tan(fov / 2.0)
    u, v = (p[0] / (half_y * aspect) + 1.0) / 2.0, (p[1] / half_y + 1.0) / 2.0
    if not (0.0 <= u < 1.0 and 0.0 <= v < 1.0):
        return None
    w, h = view.full_size or (cam.width, cam.height)
    return min(int(u * w), w - 1), min(int(v * h), h - 1)


def ray_through_pixel(view: View, x: int, y: int, origin, depth: float) -> np.ndarray:
    """The world direction from ``origin`` through the centre of pixel (x, y) (``images/``
    coordinates) of ``view``'s photo on its frustum at ``depth``: the inverse of :func:`pixel_from_ray`."""
    cam = view.camera
    w, h = view.full_size or (cam.width, cam.height)
    fov, aspect = frustum_shape(cam)
    half_y = depth * np.tan(fov / 2.0)
    p = np.array([((x + 0.5) / w * 2.0 - 1.0) * half_y * aspect, ((y + 0.5) / h * 2.0 - 1.0) * half_y, depth])
    R, t = cam.R.double().numpy(), cam.t.double().numpy()
    world = R.T @ (p - t)
    return world - np.asarray(origin, float)


def ray_hit(g: Gaussians, origin, direction) -> np.ndarray | None:
    """The world point where the ray ``origin + s direction`` (s > 0) meets the splats of ``g``, or
    None when it passes them by. Each Gaussian's alpha is its opacity times its density at the ray's
    closest approach (Mahalanobis distance under Eq. 1's Sigma); composited front to back as Eq. 1
    composites a pixel, the hit is the closest approach of the Gaussian with the largest weight
    ``alpha_i T_i``, so an opaque front surface wins over what lies behind it. A ray whose
    accumulated opacity stays under 0.5 hits nothing (as a click on a pixel less than half covered)."""
    o = np.asarray(origin, np.float64)
    d = np.asarray(direction, np.float64)
    d = d / max(np.linalg.norm(d), 1e-12)
    with torch.no_grad():
        R = quat_to_rotmat(g.quats.detach().double()).numpy()
        inv_s2 = 1.0 / np.maximum(g.scales.detach().double().numpy(), 1e-12) ** 2
        mu = g.means.detach().double().numpy()
        opacity = g.opacities.detach().double().numpy()
    # in each Gaussian's frame: x = R^T (mu - o), e = R^T d; Sigma^-1 = R diag(1/s^2) R^T
    x = np.einsum("nji,nj->ni", R, mu - o)
    e = np.einsum("nji,j->ni", R, d)
    dd = (e * e * inv_s2).sum(1)
    dx = (e * x * inv_s2).sum(1)
    xx = (x * x * inv_s2).sum(1)
    s = dx / np.maximum(dd, 1e-30)
    alpha = np.where(s > 0, np.minimum(0.99, opacity * np.exp(-0.5 * np.maximum(xx - dx * s, 0.0))), 0.0)
    hit = np.flatnonzero(alpha > 1.0 / 255.0)  # the rasterizer's cut-off for a Gaussian's share of a pixel
    if len(hit) == 0:
        return None
    hit = hit[np.argsort(s[hit], kind="stable")]
    a = alpha[hit]
    T = np.concatenate([[1.0], np.cumprod(1.0 - a)[:-1]])
    if 1.0 - T[-1] * (1.0 - a[-1]) < 0.5:
        return None
    best = hit[int(np.argmax(a * T))]
    return o + s[best] * d


def click_at_point(scene: Scene, point, direction) -> Click | None:
    """The :class:`Click` (``images/`` coordinates) at the world ``point`` in the training view that
    looks at it most nearly along ``direction`` (the page's viewing ray), among those in whose frame
    it lies; None when none holds it."""
    p = np.asarray(point, np.float64)
    d = np.asarray(direction, np.float64)
    d = d / max(np.linalg.norm(d), 1e-12)
    best, best_cos = None, -2.0
    for v in scene.train_views:
        cam = v.camera
        xc = cam.R.double().numpy() @ p + cam.t.double().numpy()
        if xc[2] <= 1e-9:
            continue
        u, w = cam.fx * xc[0] / xc[2] + cam.cx, cam.fy * xc[1] / xc[2] + cam.cy
        if not (0.0 <= u < cam.width and 0.0 <= w < cam.height):
            continue
        look = p - cam.center.double().numpy()
        cos = float(look @ d / max(np.linalg.norm(look), 1e-12))
        if cos > best_cos:
            fw, fh = v.full_size or (cam.width, cam.height)
            best, best_cos = Click(v.name, min(int(u * fw / cam.width), fw - 1), min(int(w * fh / cam.height), fh - 1)), cos
    return best


def scene_up(scene: Scene) -> np.ndarray:
    """The scene's up direction: the training cameras' mean up (-y of the OpenCV camera), unit length."""
    up = -np.mean([v.camera.R.double().numpy()[1] for v in scene.train_views], axis=0)
    n = np.linalg.norm(up)
    return up / n if n > 0 else np.array([0.0, 0.0, 1.0])


@dataclass
class StageState:
    """One stage of a job as the page shows it: ``what`` waiting / running / ran / up to date / given."""

    what: str = "waiting"
    seconds: float | None = None
    started: float | None = None  # time.monotonic() when it started running

    def line(self, now: float) -> str:
        if self.what == "running" and self.started is not None:
            return f"running ({now - self.started:.0f} s)"
        if self.what == "ran" and self.seconds is not None:
            return f"ran in {self.seconds:.1f} s"
        return self.what


@dataclass
class RunJob:
    """A run of :class:`Runner` in a background thread (the page stays responsive; closing it does
    not stop the job). ``stages``: each stage's state; ``error``: the one-line failure, if any;
    ``bars``: the last count of each progress bar the run's stages made (desc -> (done, total), in
    the order they were made; :mod:`inpaint360gs.core.progress`), :meth:`within` the running one's."""

    runner: Runner
    until: str = STAGES[-1]
    stages: dict[str, StageState] = field(default_factory=lambda: {s: StageState() for s in STAGES})
    error: str | None = None
    done: bool = False
    thread: threading.Thread | None = None
    bars: dict[str, tuple[int, int | None]] = field(default_factory=dict)
    _within: tuple[str, int, int | None] | None = None

    def _on_stage(self, stage: str, what: str, seconds: float | None) -> None:
        if what == "running":
            self._within = None  # the previous stage's last bar is not this one's
        self.stages[stage] = StageState(what, seconds, time.monotonic() if what == "running" else None)

    def _on_bar(self, desc: str, done: int, total: int | None) -> None:
        """The run thread's progress listener: one assignment each (a stage's step is not slowed)."""
        self._within = (desc, done, total)
        self.bars[desc] = (done, total)

    def start(self) -> "RunJob":
        self.runner.on_stage = self._on_stage
        self.thread = threading.Thread(target=self._run, name="inpaint360gs-run", daemon=True)
        self.thread.start()
        return self

    def _run(self) -> None:
        try:
            with progress_listener(self._on_bar):
                self.runner.run(self.until)
        except Exception as e:  # shown in the page as one line; the run's folder keeps what it wrote (run resumes it)
            self.error = f"{type(e).__name__}: {e}"
        finally:
            self.done = True

    def wait(self, timeout: float | None = None) -> bool:
        """Wait for the job; True when it is done."""
        if self.thread is not None:
            self.thread.join(timeout)
        return self.done

    def within(self) -> tuple[str, int, int | None] | None:
        """Progress within the running stage: its latest bar's (desc, done, total) (``total`` None
        when unknown), e.g. ``("3DGS garden", 1200, 3000)``; None when the job is done or the running
        stage has made no bar yet (the association and the removal make none)."""
        return None if self.done else self._within

    def fraction(self) -> float:
        """Share of the stages finished (0..1)."""
        stages = STAGES[: STAGES.index(self.until) + 1]
        return sum(self.stages[s].what not in ("waiting", "running") for s in stages) / len(stages)


class ViewerSession:
    """The viewer's state on ``scene`` and the run folder ``out`` (absent, empty, or a run's).

    Args: ``cfg`` the run's settings (the preset ``inpaint360gs run`` would use); ``model`` a trained
    3DGS PLY (as ``run --model``); ``accept`` keep a result that fails the run's check (as ``run --accept``);
    ``until`` the last stage the Run button runs (as ``run --until``).
    Raises: :class:`InputError` when ``out`` holds something no run writes."""

    def __init__(self, scene: Scene, out: str | Path, cfg: RunConfig, *, model: str | Path | None = None, accept: bool = False,
                 until: str = STAGES[-1]):
        from inpaint360gs.pipeline.run import check_run_folder

        self.scene = scene
        self.layout = RunLayout(Path(out))
        check_run_folder(self.layout.root)
        self.cfg = cfg.validate()
        self.model_path = Path(model) if model is not None else None
        if self.model_path is not None and not self.model_path.is_file():
            raise InputError("model file not found", self.model_path)
        self.accept = accept
        if until not in STAGES:
            raise InputError(f"unknown stage {until!r} (one of {', '.join(STAGES)})", setting="until")
        self.until = until
        self.clicks: list[Click] = []
        self.selection: Selected | None = None  # what the clicks select, drawn at once; its check follows (plan)
        self._plan: RemovalPlan | None = None
        self._checked = threading.Event()  # set when _plan is the selection's whole plan (or there is none)
        self._checked.set()
        self._generation = 0  # bumped by each new selection: a check of an older one is dropped
        self._masks: dict[str, np.ndarray] = {}  # fill masks of the current selection drawn so far
        self.on_checked = None  # called (no arguments, from a background thread) when a selection's check is done
        self.job: RunJob | None = None
        self.message = ""
        self._gaussians: dict[str, tuple[float, Gaussians]] = {}
        self._renders: dict[tuple, np.ndarray] = {}  # (view, mode, PLY mtime) -> the panel's render
        self._photos: dict[str, np.ndarray] = {}  # view -> its photo, as read
        self.field = None
        self.renders: FeatureRenders | None = None
        self._support = None
        self._id_maps: dict = {}  # view name -> the field's id map a click there reads (select's): id_map()
        self._id_locks: dict[str, threading.Lock] = {}  # view name -> held while its id map is rendered
        self._id_guard = threading.Lock()
        self._warm = threading.Lock()
        self.reload_field()

    # --- what the run folder holds -----------------------------------------------------------------
    def reload_field(self) -> None:
        """Load the run's object field (``distill/``) when it exists; clicks are resolved with it."""
        self.field, self.renders, self._support, self._id_maps, self._id_locks = None, None, None, {}, {}
        if (self.layout.distill / "classifier.json").is_file():
            try:
                self.field = load_field(self.layout.distill, self.scene)
            except InputError as e:
                self.message = f"the run's object field cannot be used: {e}"
        if self.field is not None:
            self.renders = FeatureRenders(self.field.gaussians, self.cfg.backend)

    def support(self):
        """The field's support plane (:func:`support_plane`), found once per field."""
        with self._warm:
            if self._support is None and self.field is not None:
                self._support = support_plane(self.field, self.scene, self.cfg.removal)
            return self._support

    def id_map(self, view: View) -> np.ndarray | None:
        """The object field's id map of ``view`` that a click there reads (:func:`click_id_map`),
        rendered once per view and field (thread-safe: a click waits for a render of it under way
        rather than rendering it again); None without a field."""
        field_ = self.field
        if field_ is None:
            return None
        with self._id_guard:
            lock = self._id_locks.setdefault(view.name, threading.Lock())
        with lock:
            ids = self._id_maps.get(view.name)
            if ids is None:
                ids = click_id_map(field_, view)
                if self.field is field_:  # not reloaded meanwhile
                    self._id_maps[view.name] = ids
        return ids

    def warm(self, view: View | None = None) -> None:
        """Do before any click what every click's selection re-uses (README "Viewer"): the id map of
        ``view`` (the camera the page shows: where the next click lands), the support plane and each
        training view's projection of the field's Gaussians (:class:`FeatureRenders`). The viewer
        runs it in a background thread once the page is drawn (and the id map of each camera it is
        switched to); a click meanwhile does what is missing itself. The selections are the same
        with or without it."""
        renders = self.renders
        if renders is None:
            return
        if view is not None:
            self.id_map(view)
        self.support()
        for v in self.scene.train_views:
            if self.renders is not renders:  # the field was reloaded
                return
            renders.prepare(v.name, v.camera)

    def ply(self, mode: str) -> Path:
        """The PLY shown for ``mode`` (one of :data:`MODES`)."""
        if mode not in MODES:
            raise InputError(f"unknown mode {mode!r} (one of {', '.join(MODES)})", setting="mode")
        if mode == "before":
            return self.model_path if self.model_path is not None else self.layout.model
        return (self.layout.removed if mode == "removed" else self.layout.inpainted) / "point_cloud.ply"

    def available(self) -> list[str]:
        """The modes whose PLY exists."""
        return [m for m in MODES if self.ply(m).is_file()]

    def gaussians(self, mode: str) -> Gaussians | None:
        """The Gaussians of ``mode`` (read once per file version), or None when the stage has not run."""
        path = self.ply(mode)
        if not path.is_file():
            return None
        stamp = path.stat().st_mtime
        cached = self._gaussians.get(mode)
        if cached is None or cached[0] != stamp:
            cached = (stamp, read_ply(path))
            self._gaussians[mode] = cached
        return cached[1]

    # --- the selection -------------------------------------------------------------------------------
    @property
    def plan(self) -> RemovalPlan | None:
        """The selection's whole plan (:func:`plan_removal`'s: fill masks of every training view and
        the selection check), waiting for its check when that is still running."""
        self._checked.wait()
        return self._plan

    @plan.setter
    def plan(self, plan: RemovalPlan | None) -> None:
        self._generation += 1
        self._plan, self.selection, self._masks = plan, None, {}
        self._checked.set()

    def checking(self) -> bool:
        """Whether the current selection's check is still running."""
        return not self._checked.is_set()

    def selected(self) -> np.ndarray | None:
        """(N,) bool over the field's Gaussians (the model's): what the removal takes, or None."""
        sel = self.selection if self.selection is not None else self._plan
        return None if sel is None else sel.removal.removed_mask.numpy()

    def _plan_args(self) -> dict:
        return {"cfg": self.cfg.removal, "backend": self.cfg.backend, "renders": self.renders}

    def click(self, click: Click, *, wait: bool = True) -> str:
        """A click on a photo: select the object under it, or drop it when it is selected already.
        Returns the line the page shows; an :class:`InputError` (a click on empty space, on the
        support) leaves the selection as it was and is returned as that line.

        The selection is :func:`plan_removal`'s with the clicks (what ``run --click`` with them
        removes). Without ``wait``, this returns once the selected Gaussians and the clicked photo's
        fill mask are known (what the page draws); the other views' fill masks and the selection
        check follow in a background thread (:attr:`plan` waits for them, :attr:`on_checked` is
        called when they are done)."""
        try:
            if self.field is None:  # no object field yet: kept as given, resolved once the run distilled it
                self.clicks = [c for c in self.clicks if c != click] if click in self.clicks else [*self.clicks, click]
                self.message = f"{len(self.clicks)} click(s); the object field does not exist yet: Run distils it and removes what they select"
                return self.message
            # what each click picks (independent of the other clicks); a click on a selected object drops it
            for view in self._click_views([*self.clicks, click]):  # each view's id map rendered once (a click re-selects the earlier clicks too)
                self.id_map(view)
            picked_all = select(self.field, self.scene, [*self.clicks, click], backend=self.cfg.backend, id_maps=self._id_maps)
            picked = picked_all[-1]
            same = []
            for c, p in zip(self.clicks, picked_all[:-1]):
                if picked.object_id is not None and p.object_id == picked.object_id:
                    same.append(c)
                elif picked.gaussians is not None and p.gaussians is not None and (p.gaussians & picked.gaussians).sum() > 0.5 * picked.gaussians.sum():
                    same.append(c)
            clicks, chosen = [*self.clicks, click], picked_all
            if same:
                keep = [i for i, c in enumerate(self.clicks) if c not in same]
                clicks, chosen = [self.clicks[i] for i in keep], [picked_all[i] for i in keep]
            sel = select_removal(self.field, self.scene, clicks=clicks, picked=chosen, support=self.support(), **self._plan_args()) if clicks else None
            masks = {}
            if sel is not None and click.view is not None:
                view = self.scene.view(click.view)
                masks = fill_masks(self.field.gaussians, sel.removal.removed_mask, [view], self.cfg.removal.mask_share, self.cfg.backend, self.renders)
        except InputError as e:
            self.message = f"not selected: {e.args[0] if e.args else e}"
            return self.message
        self.clicks = clicks
        self.plan = None  # a new generation: an older selection's check is dropped
        self.selection, self._masks = sel, masks
        what = f"dropped object {picked.object_id}" if same and picked.object_id is not None else "dropped" if same else f"selected ({picked.how})"
        if sel is not None:
            self._checked.clear()
        self.message = f"{what}; {self.verdict()}"  # before the check's thread can write its own
        line = self.message
        if sel is not None:
            worker = threading.Thread(target=self._check, args=(self._generation, sel, dict(masks), what), name="inpaint360gs-check", daemon=True)
            worker.start()
            if wait:
                self._checked.wait()
                return self.message
        return line

    def _click_views(self, clicks: list[Click]) -> list[View]:
        """The views of ``clicks`` that select can read (a bad click is left to select to say so)."""
        try:
            return check_clicks(self.scene, clicks)
        except InputError:
            return []

    def _check(self, gen: int, sel: Selected, masks: dict, what: str) -> None:
        """The rest of the plan of ``sel`` (fill masks of the other views, the check), in the background,
        on one rasterizer thread: the other cores draw the selection meanwhile (the server's page and,
        where it runs on the same computer, the browser)."""
        from inpaint360gs.render.numba_arrays import numba_threads_at_most

        try:
            with numba_threads_at_most(1):
                plan = complete_plan(self.field, self.scene, sel, masks=masks, **self._plan_args())
            error = None
        except Exception as e:  # shown as the page's line; the selection stays drawn
            plan, error = None, f"{type(e).__name__}: {e}"
        if gen != self._generation:
            return
        self._plan, self.selection = plan, None if plan is not None else sel
        self.message = f"{what}; {self._verdict(plan)}" if error is None else f"{what}; the selection check failed: {error}"
        self._checked.set()
        if self.on_checked is not None:
            self.on_checked()

    def click_ray(self, origin, direction, *, wait: bool = True) -> tuple[Click | None, str]:
        """A click on the splats, given as the page's ray: the pixel of the front surface the ray hits
        (:func:`ray_hit` on the object field's Gaussians, else the trained model's) in the training
        view looking along the ray (:func:`click_at_point`), then :meth:`click` with it, the photo
        click's path. Returns (that click or None, the page's line)."""
        g = self.field.gaussians if self.field is not None else self.gaussians("before")
        point = None if g is None else ray_hit(g, origin, direction)
        c = None if point is None else click_at_point(self.scene, point, direction)
        if c is None:
            self.message = "not selected: the click hits no splat seen by a training camera"
            return None, self.message
        return c, self.click(c, wait=wait)

    def clear(self) -> None:
        """Select nothing."""
        self.clicks, self.plan, self.message = [], None, "nothing selected"

    def verdict(self) -> str:
        """The selection check of the current selection in one line (does not wait for it)."""
        if self.checking():
            return "checking the selection ..."
        return self._verdict(self._plan)

    def _verdict(self, plan: RemovalPlan | None) -> str:
        if plan is None:
            return "nothing selected" if not self.clicks else "not checked yet (no object field)"
        c = plan.check
        return f"{'passed' if c.passed else 'refused'} ({c.verdict}): {c.reason}"

    def save_clicks(self) -> Path:
        """Write the selection's clicks as ``scene.json``'s ``clicks`` (atomically; its other keys
        kept), so that ``inpaint360gs run`` without ``--click`` and the workflow reproduce it."""
        if not self.clicks:
            raise InputError("nothing selected: click on an object first", setting="clicks")
        path = self.scene.root / SCENE_JSON
        info = json.loads(path.read_text()) if path.is_file() else {}
        if not isinstance(info, dict):
            raise InputError("is not a JSON object", path)
        info["clicks"] = [{"view": c.view, "x": c.x, "y": c.y} for c in self.clicks]
        write_text(path, json.dumps(info, indent=1) + "\n")
        self.scene.info = info
        return path

    # --- pictures ------------------------------------------------------------------------------------
    def photo(self, view: View) -> np.ndarray:
        """(H, W, 3) float photo of a training view with the selection's fill mask tinted and the
        clicks on it crossed (at the scene's resolution)."""
        if view.name not in self._photos:
            self._photos[view.name] = self.scene.load_image(view).numpy()
        img = self._photos[view.name]
        mask = self.mask(view)
        mask = np.zeros(img.shape[:2], bool) if mask is None else mask
        return selection_overlay(img, mask, [c.pixel(view) for c in self.clicks if self.scene.view(c.view).name == view.name])

    def mask(self, view: View) -> np.ndarray | None:
        """The current selection's fill mask in ``view`` (drawn now when its check has not yet), or None."""
        plan = self._plan if not self.checking() else None
        if plan is not None:
            return plan.masks.get(view.name)
        sel, masks = self.selection, self._masks
        if sel is None or self.field is None:
            return None
        if view.name not in masks:
            masks[view.name] = fill_masks(self.field.gaussians, sel.removal.removed_mask, [view], self.cfg.removal.mask_share, self.cfg.backend,
                                          self.renders)[view.name]  # fmt: skip
        return masks[view.name]

    def render(self, view: View, mode: str) -> np.ndarray | None:
        """(H, W, 3) float render of ``mode``'s Gaussians at ``view``'s camera, or None (kept per PLY version)."""
        from inpaint360gs.render.api import render

        g = self.gaussians(mode)
        if g is None:
            return None
        key = (view.name, mode, self._gaussians[mode][0])
        if key not in self._renders:
            with torch.no_grad():
                out = render(g, view.camera, backend=self.cfg.backend)
            self._renders = {k: v for k, v in self._renders.items() if k[1] != mode or k[2] == key[2]}  # drop renders of older files
            self._renders[key] = out.color.clamp(0, 1).numpy()
        return self._renders[key]

    def side_by_side(self, view: View, mode: str) -> np.ndarray:
        """uint8 photo (with the selection) | render of ``mode`` at that camera (black when not there yet)."""
        photo = self.photo(view)
        rendered = self.render(view, mode)
        rendered = np.zeros_like(photo) if rendered is None else rendered
        return (np.concatenate([photo, rendered], axis=1) * 255).round().astype(np.uint8)

    def check_report(self) -> tuple[dict | None, Path | None]:
        """The run's check (``check.json``) and its picture, when the run has been checked."""
        path = self.layout.root / CHECK_JSON
        if not path.is_file():
            return None, None
        picture = self.layout.root / CHECK_PICTURE
        return json.loads(path.read_text()), picture if picture.is_file() else None

    # --- the run -------------------------------------------------------------------------------------
    def start_run(self) -> RunJob:
        """Start the run of the selection's clicks on the run folder in a background thread (the
        stages missing run first); :class:`InputError` before any work when nothing is selected, a
        job is running, or the run's arguments are wrong (as ``inpaint360gs run`` says them)."""
        if self.job is not None and not self.job.done:
            raise InputError("a run is going on: wait for it to finish", setting="run")
        if not self.clicks:
            raise InputError("nothing selected: click on an object first", setting="clicks")
        runner = Runner(self.scene, self.layout.root, self.cfg, model=self.model_path, clicks=list(self.clicks), progress=False, accept=self.accept)
        self.job = RunJob(runner, until=self.until).start()
        return self.job

    def after_run(self) -> None:
        """Pick up what the finished run wrote: the object field, and the selection resolved with it."""
        had_field = self.field is not None
        self.reload_field()
        if self.field is not None and not had_field and self.clicks:
            try:
                self.plan = plan_removal(self.field, self.scene, clicks=self.clicks, support=self.support(), **self._plan_args())
            except InputError as e:
                self.message = f"the clicks select nothing in the field: {e}"


def view_by_name(scene: Scene, name: str) -> View:
    """The training view named ``name`` (file name or stem)."""
    v = scene.view(name)
    if v.is_test:
        raise InputError(f"{v.name} is an evaluation (test_) view; the viewer shows the training views", setting="view")
    return v
