"""The viewer's page (README "Viewer"), built on viser (an optional extra, ``pip install -e
.[viewer]``; :mod:`.server` starts its server). What it shows and does is :class:`.session.ViewerSession`'s;
this module puts it in the page and turns the page's events into the session's calls.

* The splats of the chosen stage (before / removed / inpainted) with viser's Gaussian splats, each
  stage's sent once and shown or hidden. Only the ``max_splats`` most opaque are drawn unless the
  panel's "splats" says all (a browser without a GPU draws a few thousand splats in seconds, the
  tens of thousands of a trained scene in tens of seconds). The selected ones among them are drawn
  tinted red: the 'before' node's colours changed in place (a node added or removed would make the
  page rebuild all its splats). Shift-clicking on
  the splats selects the object the ray hits first (:meth:`.session.ViewerSession.click_ray`: the
  photo click at the pixel it projects to).
* Each training camera as a frustum with its photo. Clicking a frustum chooses that camera (the
  page's camera moves to it; the panel shows the photo with the selection beside the render at that
  camera); clicking on the chosen camera's photo selects the object under that pixel, or drops it.
* Run (the session's :class:`.session.RunJob`: the share of stages done, and the running stage's
  own bar, e.g. "3DGS 1200/3000", as the command's progress bars count), Clear, Save clicks to
  scene.json, and downloads of the shown PLY and the inpainting's turntable GIF."""

from __future__ import annotations

import threading
import time
import warnings
from pathlib import Path

import numpy as np

from inpaint360gs.core.errors import InputError
from inpaint360gs.pipeline.run import STAGES
from inpaint360gs.remove.select import Click
from inpaint360gs.viewer.server import exposure_warning
from inpaint360gs.viewer.splats import most_opaque
from inpaint360gs.viewer.session import MODES, ViewerSession, camera_pose, frustum_depth, frustum_shape, pixel_from_ray, scene_up, splat_arrays

SELECTED_TINT = np.array([1.0, 0.1, 0.1], np.float32)  # colour the selected Gaussians are drawn in (half-blended)
THUMB_WIDTH = 320  # the photos on the frustums are sent at most this wide


def _thumb(img: np.ndarray) -> np.ndarray:
    import cv2

    h, w = img.shape[:2]
    if w <= THUMB_WIDTH:
        return img
    return cv2.resize(img, (THUMB_WIDTH, round(h * THUMB_WIDTH / w)), interpolation=cv2.INTER_AREA)


class ViewerApp:
    """The page of ``session``, served on ``host``:``port`` (0: a free port) until :meth:`stop`."""

    def __init__(self, session: ViewerSession, *, host: str = "127.0.0.1", port: int = 8080, server=None, max_splats: int = 0,
                 background: bool = True, sent: tuple | None = None):  # fmt: skip
        """``server``: a viser server already serving (:func:`inpaint360gs.viewer.api.view` starts it
        first, so that the browser loads the page while the scene loads), else one on ``host``:``port``.
        ``max_splats``: the most opaque splats drawn (0: all; the panel can switch to all; the
        viewer's command draws :data:`inpaint360gs.viewer.server.DEFAULT_SPLATS`). The splats
        are sent before this returns; the cameras with their photos and the panel's render follow in
        a thread (``background``; else before returning): :meth:`wait_loaded` waits for them.
        ``sent``: the 'before' splats ``server`` holds already (:func:`.splats.send_splats`; kept
        when they are the shown PLY's at ``max_splats``)."""
        import viser

        self.session = session
        self.scene = session.scene
        self.server = viser.ViserServer(host=host, port=port, verbose=False) if server is None else server
        self.lock = threading.RLock()  # page events come from viser's thread pool
        self.views = self.scene.train_views
        self.current = self.views[0]
        self.mode = next(iter(session.available()), MODES[0])
        self.scale = 0.03 * max(self.scene.extent, 1e-6)  # frustum size: a fraction of the camera orbit
        self.frustums = {}
        self._colors = {}  # frustum -> the colour it was last given
        self.max_splats = self.few_splats = max_splats
        self.splats = {}  # mode -> (the PLY's mtime, max_splats it was sent with, indices sent or None for all, the node)
        self._untinted = None  # (the 'before' node, its colours as sent: buffer column 7)
        if sent is not None and session.ply("before").is_file() and sent[:2] == (session.ply("before").stat().st_mtime, max_splats):
            self.splats["before"] = sent
        self._poller = None
        self._warmer = None  # the thread of session.warm, started once the page is loaded
        self._stopped = False
        self.server.scene.set_up_direction(tuple(scene_up(self.scene)))
        self._build_gui()
        # viser's splat nodes report no clicks: a shift-click anywhere in the scene gives the ray (a plain
        # click stays the frustums' and the camera's)
        self.server.scene.on_click(modifier="shift")(lambda e: self.on_splat_click(e.ray_origin, e.ray_direction))
        session.on_checked = self._on_checked
        self.show_splats()
        self._loader = threading.Thread(target=self._load_rest, name="inpaint360gs-viewer-load", daemon=True)
        if background:
            self._loader.start()
        else:
            self._load_rest()

    def _load_rest(self) -> None:
        with self.lock:
            self.show_view(self.current, move=False)
        self._add_cameras()
        with self.lock:
            self.show_view(self.current, move=False)  # the chosen camera's frustum coloured
        # what every click's selection re-uses, before the first click (a click meanwhile does what is missing)
        self._warmer = threading.Thread(target=self.session.warm, args=(self.current,), name="inpaint360gs-viewer-warm", daemon=True)
        self._warmer.start()

    def _on_checked(self) -> None:
        """The selection's check is done (a background thread): its line in the panel."""
        with self.lock:
            if not self._stopped:
                self._refresh_text()

    def wait_warm(self, timeout: float | None = None) -> bool:
        """Wait until the page is loaded and what clicks re-use is ready (:meth:`.session.ViewerSession.warm`;
        benchmarks); True when it is."""
        if not self.wait_loaded(timeout):
            return False
        if self._warmer is not None:
            self._warmer.join(timeout)
        return self._warmer is None or not self._warmer.is_alive()

    def wait_loaded(self, timeout: float | None = None) -> bool:
        """Wait until the page's content is all sent (tests); True when it is."""
        if self._loader.is_alive():
            self._loader.join(timeout)
        return not self._loader.is_alive()

    # --- the page ------------------------------------------------------------------------------------
    def _build_gui(self) -> None:
        gui = self.server.gui
        gui.set_panel_label("inpaint360gs")
        self.g_status = gui.add_markdown(self._status())
        self.g_view = gui.add_dropdown("camera", [v.name for v in self.views], initial_value=self.current.name)
        self.g_view.on_update(lambda _: self.show_view(self.scene.view(self.g_view.value)))
        self.g_mode = gui.add_dropdown("show", list(MODES), initial_value=self.mode)
        self.g_mode.on_update(lambda _: self.set_mode(self.g_mode.value))
        few = f"{self.max_splats} most opaque"
        self.g_splats = gui.add_dropdown("splats", [few, "all"] if self.max_splats > 0 else ["all"], initial_value=few if self.max_splats > 0 else "all")
        self.g_splats.on_update(lambda _: self.set_max_splats(0 if self.g_splats.value == "all" else self.few_splats))
        self.g_image = gui.add_image(np.zeros((8, 16, 3), np.uint8), label="photo | render")
        self.g_check = gui.add_markdown("")
        self.g_clear = gui.add_button("Clear selection")
        self.g_clear.on_click(lambda _: self._clear())
        self.g_save = gui.add_button("Save clicks to scene.json")
        self.g_save.on_click(lambda _: self._save())
        self.g_run = gui.add_button("Run removal and inpainting")
        self.g_run.on_click(lambda _: self.run())
        with gui.add_folder("progress"):
            self.g_bar = gui.add_progress_bar(0.0)
            self.g_within_bar = gui.add_progress_bar(0.0)
            self.g_within = gui.add_markdown(self._within()[0])
            self.g_stages = gui.add_markdown(self._stages())
        with gui.add_folder("export"):
            self.g_ply = gui.add_button("Download the shown PLY")
            self.g_ply.on_click(lambda e: self._download(e.client, self.session.ply(self.mode)))
            self.g_gif = gui.add_button("Download the turntable GIF", disabled=not self._gif().is_file())
            self.g_gif.on_click(lambda e: self._download(e.client, self._gif()))

    def _gif(self) -> Path:
        """The turntable GIF the inpainting stage writes (``inpaint_stage``: its trajectory renders)."""
        return self.session.layout.inpainted / "trajectory.gif"

    def _status(self) -> str:
        s = self.session
        field = "object field: loaded" if s.field is not None else "object field: not yet (Run distils it)"
        sel = ", ".join(str(c) for c in s.clicks) or "none"
        return f"**{self.scene.name}** · run folder `{s.layout.root}` · {field}  \nselection: {sel}  \n{s.message}"

    def _stages(self) -> str:
        job = self.session.job
        if job is None:
            return "no run started here"
        now = time.monotonic()
        lines = [f"- {st}: {job.stages[st].line(now)}" for st in STAGES]
        if job.error:
            lines.append(f"\n**failed**: {job.error}")
        elif job.done:
            lines.append("\n**done**")
        return "\n".join(lines)

    def _within(self) -> tuple[str, float]:
        """The running stage's own progress: its line (e.g. "stage: 3DGS garden 1200/3000"; "stage: -"
        when no stage's bar is counting) and its bar's value (0..100)."""
        job = self.session.job
        w = job.within() if job is not None else None  # read once: the run's thread keeps updating it
        if w is None:
            return "stage: -", 0.0
        desc, done, total = w
        if not total:
            return f"stage: {desc} {done}", 0.0
        return f"stage: {desc} {done}/{total}", 100.0 * min(done / total, 1.0)

    def _show_progress(self, job) -> None:
        """Both bars and the stage table; only what changed is sent (each update is a message and a
        redraw in the page)."""
        line, value = self._within()
        for gui, attr, new in ((self.g_bar, "value", 100.0 * job.fraction()), (self.g_within_bar, "value", value),
                               (self.g_within, "content", line), (self.g_stages, "content", self._stages())):  # fmt: skip
            if getattr(gui, attr) != new:
                setattr(gui, attr, new)

    def _refresh_text(self) -> None:
        self.g_status.content = self._status()
        self.g_check.content = f"selection check: **{self.session.verdict()}**"

    def _add_cameras(self) -> None:
        for v in self.views:
            fov, aspect = frustum_shape(v.camera)
            wxyz, pos = camera_pose(v.camera)
            photo = _thumb(self.scene.load_image_raw(v))
            with self.lock:
                fr = self.server.scene.add_camera_frustum(f"/cameras/{v.stem}", fov=fov, aspect=aspect, scale=self.scale, image=photo, wxyz=wxyz, position=pos,
                                                      color=(120, 120, 120))  # fmt: skip
                fr.on_click(lambda e, v=v: self.on_frustum_click(v.name, e.ray_origin, e.ray_direction))
                self.frustums[v.name] = fr
                self._colors[v.name] = (120, 120, 120)

    # --- what events do ------------------------------------------------------------------------------
    def show_splats(self) -> None:
        """Show the splats of the shown mode, sending them when the page does not have that file's
        (at ``max_splats``) yet, the other modes' hidden; then the selection (:meth:`show_selection`)."""
        with self.lock:
            g = self.session.gaussians(self.mode)
            if g is not None:
                stamp = self.session.ply(self.mode).stat().st_mtime
                have = self.splats.get(self.mode)
                if have is None or have[:2] != (stamp, self.max_splats):
                    arr, keep = most_opaque(splat_arrays(g), self.max_splats)
                    node = self.server.scene.add_gaussian_splats(f"/splats/{self.mode}", **arr)
                    self.splats[self.mode] = (stamp, self.max_splats, keep, node)
            for mode, (*_, node) in self.splats.items():
                node.visible = mode == self.mode and g is not None
            self.show_selection()

    def set_max_splats(self, n: int) -> None:
        """Draw the ``n`` most opaque splats (0: all)."""
        with self.lock:
            self.max_splats = n
            self.show_splats()

    def show_selection(self) -> None:
        """Draw the selected Gaussians tinted (:data:`SELECTED_TINT` half-blended) in the 'before'
        splats themselves, untinted in the other modes and without a selection.

        The tint is a change of the 'before' node's colours in place: the page then updates its
        splat texture and re-sorts, where a node added or removed makes it rebuild every splat node's
        buffers and meshes, seconds under software WebGL (README "Viewer")."""
        with self.lock:
            have = self.splats.get("before")
            if have is None:
                return
            _, _, keep, node = have
            if self._untinted is None or self._untinted[0] is not node:  # a node sent anew: its own colours
                self._untinted = (node, node.buffer[:, 7].copy())
            base = self._untinted[1]
            sel = self.session.selected() if self.mode == "before" else None
            g = self.session.gaussians("before") if sel is not None else None
            idx = np.zeros(0, np.int64)
            if g is not None and len(sel) == len(g):  # the field's Gaussians are the drawn model's
                idx = np.flatnonzero(sel if keep is None else sel[keep])  # positions in the node of the selected ones drawn
            rgba = base.copy()
            rgb = rgba.view(np.uint8).reshape(-1, 4)[:, :3]  # a view: writing it writes rgba
            rgb[idx] = np.round(0.5 * rgb[idx] + 127.5 * SELECTED_TINT).astype(np.uint8)
            if not np.array_equal(rgba, node.buffer[:, 7]):  # each update is a message and a re-sort in the page
                buf = node.buffer.copy()
                buf[:, 7] = rgba
                node.buffer = buf

    def set_mode(self, mode: str) -> None:
        with self.lock:
            self.mode = mode
            self.show_splats()
            self.show_view(self.current, move=False)

    def show_view(self, view, *, move: bool = True) -> None:
        """Choose the camera ``view``: the panel's photo | render, and (``move``) the page's camera at it."""
        with self.lock:
            if view.name != self.current.name and self.session.field is not None:  # the id map a click on this photo reads, while it is looked at
                threading.Thread(target=self.session.id_map, args=(view,), name="inpaint360gs-viewer-id-map", daemon=True).start()
            self.current = view
            if self.g_view.value != view.name:
                self.g_view.value = view.name
            for name, fr in self.frustums.items():
                color = (255, 200, 0) if name == view.name else (120, 120, 120)
                if self._colors.get(name) != color:  # each update is a message and a redraw in the page: only the changed ones
                    fr.color = self._colors[name] = color
            self.g_image.image = self.session.side_by_side(view, self.mode)
            self._refresh_text()
            if move:
                wxyz, pos = camera_pose(view.camera)
                fov, _ = frustum_shape(view.camera)
                for client in self.server.get_clients().values():
                    with client.atomic():
                        client.camera.fov = fov
                        client.camera.wxyz = wxyz
                        client.camera.position = pos

    def on_frustum_click(self, name: str, origin, direction) -> str | None:
        """A click on a frustum: on another camera's, choose it; on the chosen camera's photo, the
        click at the pixel the ray hits. Returns the session's line for a selection click."""
        view = self.scene.view(name)
        if view.name != self.current.name:
            self.show_view(view)
            return None
        fov, aspect = frustum_shape(view.camera)
        px = pixel_from_ray(view, origin, direction, frustum_depth(fov, aspect, self.scale))
        if px is None:
            return None
        return self.click(Click(view.name, *px))

    def on_splat_click(self, origin, direction) -> str:
        """A click on the splats: the session's selection of the object the ray hits first (the
        photo click at the pixel it projects to), drawn. Returns the session's line."""
        with self.lock:
            c, line = self.session.click_ray(origin, direction, wait=False)
            self._show_clicked(self.current if c is None else self.scene.view(c.view))
            return line

    def click(self, click: Click) -> str:
        """Select (or drop) the object under ``click`` and draw the selection; its check follows
        (:meth:`.session.ViewerSession.click` without waiting: the panel's line when it is done)."""
        with self.lock:
            line = self.session.click(click, wait=False)
            self._show_clicked(self.scene.view(click.view))
            return line

    def _show_clicked(self, view) -> None:
        """After a change of the selection: the panel's photo with its mask, then the 3D selection."""
        self.show_view(view, move=False)
        # sent now, alone: the page applies a batch of panel-only messages at once, but one that also
        # changes the 3D scene waits for the next 3D frame (slow under software WebGL)
        self.server.flush()
        self.show_selection()

    def _clear(self) -> None:
        with self.lock:
            self.session.clear()
            self._show_clicked(self.current)

    def _save(self) -> None:
        with self.lock:
            try:
                self.session.message = f"saved the clicks to {self.session.save_clicks()}"
            except InputError as e:
                self.session.message = str(e)
            self._refresh_text()

    def _download(self, client, path: Path) -> None:
        if client is None:
            return
        if not path.is_file():
            self.session.message = f"{path.name} does not exist yet: run first"
            self._refresh_text()
            return
        client.send_file_download(path.name, path.read_bytes())

    def run(self):
        """The Run button: start the job and follow it (its progress in the panel); returns the job or None."""
        with self.lock:
            try:
                job = self.session.start_run()
            except InputError as e:
                self.session.message = f"cannot run: {e}"
                self._refresh_text()
                return None
            self.session.message = "running ..."
            self._refresh_text()
        self._poller = threading.Thread(target=self._follow, args=(job,), name="inpaint360gs-progress", daemon=True)
        self._poller.start()
        return job

    def _follow(self, job) -> None:
        while not job.done:
            self._show_progress(job)  # the job's counts are read, not waited for: the page stays responsive
            time.sleep(0.5)
        with self.lock:
            self.session.after_run()
            self._show_progress(job)
            report, picture = self.session.check_report()
            if report is not None:
                state = "passed" if report["passed"] else "FAILED (" + ", ".join(report["failed"]) + ")" + (", accepted" if report["accepted"] else "")
                self.session.message = f"run's check after {report['stage']}: {state}"
                if picture is not None:
                    from inpaint360gs.io.images import read_image

                    self.g_check_picture = getattr(self, "g_check_picture", None) or self.server.gui.add_image(np.zeros((8, 8, 3), np.uint8), label="check.png")
                    self.g_check_picture.image = _thumb(read_image(picture)[..., :3])
            if job.error:
                self.session.message = f"run failed: {job.error}"
            if self.session.available():
                self.mode = "inpainted" if "inpainted" in self.session.available() else self.session.available()[-1]
                self.g_mode.value = self.mode
            self.g_gif.disabled = not self._gif().is_file()
            self.show_splats()
            self.show_view(self.current, move=False)

    def wait_for_job(self, timeout: float | None = None) -> bool:
        """Wait until the page has shown the finished job (tests); True when it has."""
        if self._poller is not None:
            self._poller.join(timeout)
        return self._poller is None or not self._poller.is_alive()

    @property
    def port(self) -> int:
        return self.server.get_port()

    def stop(self) -> None:
        with self.lock:
            self._stopped = True
        self.server.stop()

    def serve_forever(self) -> None:
        """Serve until interrupted (Ctrl-C), then stop. A running job stops with the process;
        ``inpaint360gs run`` (or the viewer again) resumes it from its last finished stage."""
        try:
            while True:
                time.sleep(1.0)
        except KeyboardInterrupt:
            pass
        finally:
            self.stop()


def serve(session: ViewerSession, *, host: str = "127.0.0.1", port: int = 8080, block: bool = True, server=None,
          max_splats: int = 0, sent: tuple | None = None) -> ViewerApp:  # fmt: skip
    """Serve ``session``'s page (on ``server`` when given, see :class:`ViewerApp`); with ``block``
    until interrupted (Ctrl-C). Warns when ``host`` is not local."""
    warning = exposure_warning(host)
    if warning:
        warnings.warn(warning, stacklevel=3)
    app = ViewerApp(session, host=host, port=port, server=server, max_splats=max_splats, sent=sent)
    if block:
        app.serve_forever()
    return app
