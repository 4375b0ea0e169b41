"""The viewer's page (src/inpaint360gs/viewer/app.py) served in-process with viser: a click on the
chosen camera's photo (a ray through its frustum, as the page sends it) selects what
``inpaint360gs run --click`` at that pixel selects, the Run button's job writes the removal that
``run`` writes, and headless Chromium shows the splats in the scene's colours."""

from __future__ import annotations

import os
import shutil
import time

import numpy as np
import pytest
from object_fields import click_on, labelled_field, write_field

pytest.importorskip("viser", reason="the viewer extra is not installed (pip install -e .[viewer])")

from inpaint360gs.cli import main  # noqa: E402
from inpaint360gs.io.images import write_image  # noqa: E402
from inpaint360gs.io.scene import load_scene  # noqa: E402
from inpaint360gs.pipeline.presets import get_preset  # noqa: E402
from inpaint360gs.remove.select import Click  # noqa: E402
from inpaint360gs.viewer.browser import Browser, chromium  # noqa: E402
from inpaint360gs.viewer.app import SELECTED_TINT, ViewerApp, exposure_warning  # noqa: E402
from inpaint360gs.viewer.session import ViewerSession, frustum_depth, frustum_shape, ray_through_pixel, splat_arrays  # noqa: E402

BLOB_1 = (0.45, 0.0, 0.25)  # scene_builder.blobs_model's first blob (label 1)
BLOB_2 = (-0.45, 0.0, 0.25)


def click_in_page(app: ViewerApp, c: Click) -> str | None:
    """What the page does for a click on the chosen camera's photo at ``c``: a ray from a point in
    front of the scene through that pixel of the photo on the frustum."""
    view = app.scene.view(c.view)
    app.show_view(view)
    fov, aspect = frustum_shape(view.camera)
    origin = view.camera.center.double().numpy() * 1.7
    return app.on_frustum_click(view.name, origin, ray_through_pixel(view, c.x, c.y, origin, frustum_depth(fov, aspect, app.scale)))


def test_only_a_host_beyond_this_machine_is_warned_about():
    assert exposure_warning("127.0.0.1") is None and exposure_warning("localhost") is None
    assert "no login" in exposure_warning("0.0.0.0")


@pytest.mark.slow
def test_the_page_click_and_run_button_give_what_run_click_gives(tiny_scene, tmp_path):
    """segment, associate and distill once (run --until distill); a copy of that run folder for the
    viewer; the page's click, then its Run button, against ``run --click`` at that pixel."""
    from inpaint360gs.cli.run import add_arguments, run_config

    root, model = tiny_scene
    scene = load_scene(root)
    out_cli, out_view = tmp_path / "cli", tmp_path / "view"
    common = [str(root), str(out_cli), "--model", str(model), "--distill-iterations", "20", "--no-progress", "--accept"]
    assert main(["run", *common, "--until", "distill", "--id", "1"]) == 0
    shutil.copytree(out_cli, out_view)

    import argparse

    parser = argparse.ArgumentParser()
    add_arguments(parser)
    cfg = run_config(parser.parse_args(common))  # the settings `run` ran with
    session = ViewerSession(scene, out_view, cfg, model=model, accept=True, until="remove")
    app = ViewerApp(session, port=0)
    try:
        v = scene.train_views[0]
        c = click_on(v, BLOB_1)
        line = click_in_page(app, c)
        assert session.clicks == [c], line
        assert session.plan is not None and session.plan.targets == [1]
        job = app.run()
        assert job is not None and app.wait_for_job(600) and job.error is None, job.error
        assert [job.stages[s].what for s in ("segment", "associate", "distill", "remove")] == ["up to date"] * 3 + ["ran"]
        assert "remove: ran in" in app.g_stages.content and "removed" in session.available()
        assert app.g_within.content == "stage: -" and app.g_within_bar.value == 0.0  # the job is done: no stage running
    finally:
        app.stop()
    assert main(["run", *common, "--until", "remove", "--click", str(c)]) == 0
    for name in ("point_cloud.ply", "removed.ply", "removed_index.npy"):
        assert (out_view / "removed" / name).read_bytes() == (out_cli / "removed" / name).read_bytes(), name
    assert (out_view / "check.json").is_file()
    # the run folder is run's: run with the same click finds everything up to date
    assert main(["run", *common[:1], str(out_view), *common[2:], "--until", "remove", "--click", str(c)]) == 0


def blobs_session(make_blobs_scene, tmp_path, name: str, n_views: int):
    """(scene, model, labels, session) on a blobs scene whose run folder holds a labelled field."""
    from inpaint360gs.io.ply import write_ply

    root, model, labels = make_blobs_scene(name, n_views=n_views)
    scene = load_scene(root)
    write_ply(tmp_path / "model.ply", model)
    out = tmp_path / "run"
    write_field(out / "distill", labelled_field(model, labels, [0, 3, 7]), scene)
    return scene, model, labels, ViewerSession(scene, out, get_preset("cpu"), model=tmp_path / "model.ply")


def share_near(img: np.ndarray, rgb: np.ndarray, tol: float = 0.15) -> float:
    return float((np.abs(img - rgb).max(axis=-1) < tol).mean())


@pytest.mark.skipif(chromium() is None, reason="no chromium (Debian's chromium package; .ci/run installs it)")
def test_the_browser_shows_the_splats_in_the_scenes_colours_and_the_selection(make_blobs_scene, tmp_path):
    scene, model, labels, session = blobs_session(make_blobs_scene, tmp_path, "shot", 10)
    app = ViewerApp(session, port=0)
    try:
        app.click(click_on(scene.train_views[0], BLOB_2))
        assert session.plan.targets == [7]
        rgbs, lab = splat_arrays(model)["rgbs"], labels.numpy()
        blob1 = rgbs[lab == 1].mean(axis=0)
        blob2_tinted = (0.5 * rgbs[lab == 2] + 0.5 * SELECTED_TINT).mean(axis=0)
        browser = Browser()
        try:
            browser.call("Page.navigate", url=f"http://127.0.0.1:{app.port}")
            # the splats fade in as their data arrives: screenshots until both blobs are there (each some
            # 0.2 % of the 1280x800 page; the floor's colours are far from both), or the last after 2 min
            browser.wait_for(lambda im: share_near(im / 255.0, blob1) > 0.0008 and share_near(im / 255.0, blob2_tinted) > 0.0008)
            time.sleep(2.0)  # the fade-in's end, and the panel's pictures
            raw = browser.screenshot()
        finally:
            browser.close()
    finally:
        app.stop()
    img = raw / 255.0
    shot = tmp_path / "viewer.png"
    write_image(shot, raw.astype(np.uint8))
    assert img.std() > 0.05  # not blank
    assert share_near(img, blob1) > 0.0008, "the unselected blob's colour is not on the page"
    assert share_near(img, blob2_tinted) > 0.0008, "the selected blob is not drawn tinted"
    assert share_near(img, rgbs[lab == 2].mean(axis=0)) < 0.2 * share_near(img, blob2_tinted)  # drawn tinted, not in its own colour
    keep = os.environ.get("INPAINT360GS_VIEWER_SCREENSHOT")  # README's picture: INPAINT360GS_VIEWER_SCREENSHOT=docs/images/viewer.png
    if keep:
        shutil.copyfile(shot, keep)


@pytest.mark.skipif(chromium() is None, reason="no chromium (Debian's chromium package; .ci/run installs it)")
def test_a_shift_click_on_the_splats_in_the_browser_selects_the_blob_under_it(make_blobs_scene, tmp_path):
    """A shift-click in the page on the pixels where a blob is drawn: the page sends its ray, the
    viewer selects that blob (its object id, as a click on a photo of it) and draws it tinted; the
    other blob stays unselected."""
    scene, model, labels, session = blobs_session(make_blobs_scene, tmp_path, "splatclick", 10)
    app = ViewerApp(session, port=0)
    rgbs, lab = splat_arrays(model)["rgbs"], labels.numpy()
    blob1, blob2 = rgbs[lab == 1].mean(axis=0), rgbs[lab == 2].mean(axis=0)
    blob2_tinted = (0.5 * rgbs[lab == 2] + 0.5 * SELECTED_TINT).mean(axis=0)
    try:
        browser = Browser()
        try:
            browser.call("Page.navigate", url=f"http://127.0.0.1:{app.port}")
            browser.wait_for(lambda im: share_near(im / 255.0, blob1) > 0.0008 and share_near(im / 255.0, blob2) > 0.0008)
            time.sleep(2.0)  # the fade-in's end
            img = browser.screenshot() / 255.0
            view = img[:, : int(img.shape[1] * 0.72)]  # left of the panel (its photo shows the blobs too)
            ys, xs = np.nonzero(np.abs(view - blob2).max(axis=-1) < 0.15)
            assert len(ys) > 50, "blob 2 is not drawn in the 3D view"
            y, x = float(np.median(ys)), float(np.median(xs))
            browser.call("Input.dispatchMouseEvent", type="mouseMoved", x=x, y=y, modifiers=8)
            for kind in ("mousePressed", "mouseReleased"):
                browser.call("Input.dispatchMouseEvent", type=kind, x=x, y=y, button="left", clickCount=1, modifiers=8)
            t0 = time.perf_counter()
            while session.selected() is None and time.perf_counter() - t0 < 60:
                time.sleep(0.1)
            assert session.selected() is not None, "the shift-click reached no selection"
            assert session.plan.targets == [7]  # blob 2's object id in the field
            assert len(session.clicks) == 1 and session.clicks[0].view is not None
            shot = browser.wait_for(lambda im: share_near(im / 255.0, blob2_tinted) > 0.0008, timeout=60)
        finally:
            browser.close()
    finally:
        app.stop()
    assert shot is not None, "the selected blob is not drawn tinted"
    assert share_near(shot / 255.0, blob1) > 0.0008  # the other blob is drawn untinted


def test_the_page_draws_the_most_opaque_splats_and_the_selected_ones_among_them_tinted(make_blobs_scene, tmp_path):
    """In-process (no browser): with ``max_splats`` the 'before' node holds the most opaque splats;
    a click tints the selected ones among them in that node (half the tint, the rest untouched), a
    second click on them gives the colours back, and "all" sends every splat (the whole selection
    tinted)."""
    scene, model, labels, session = blobs_session(make_blobs_scene, tmp_path, "few", 6)
    k = len(model) // 3
    app = ViewerApp(session, port=0, max_splats=k, background=False)

    def colours(node) -> np.ndarray:
        return node.buffer[:, 7:8].view(np.uint8).reshape(-1, 4)[:, :3].astype(np.float64) / 255.0

    try:
        _, _, keep, node = app.splats["before"]
        opacity = model.opacities.detach().numpy()
        assert len(keep) == k and node.buffer.shape[0] == k and opacity[keep].min() >= np.delete(opacity, keep).max()
        centres = node.buffer[:, :3].view(np.float32)
        assert np.allclose(centres, model.means.detach().numpy()[keep])
        rgbs = splat_arrays(model)["rgbs"].astype(np.float64)
        assert np.allclose(colours(node), rgbs[keep], atol=1 / 255)
        click = click_on(scene.train_views[0], BLOB_2)
        app.click(click)
        sel = session.selected()
        shown = sel[keep]
        assert shown.sum() > 0 and (~shown).sum() > 0
        assert np.allclose(colours(node)[shown], 0.5 * rgbs[keep][shown] + 0.5 * SELECTED_TINT, atol=1.5 / 255)
        assert np.allclose(colours(node)[~shown], rgbs[keep][~shown], atol=1 / 255)
        assert np.allclose(node.buffer[:, :7].view(np.float32)[:, :3], centres)  # only the colours change
        app.click(click)  # drops it: the colours as sent
        assert session.selected() is None and np.allclose(colours(node), rgbs[keep], atol=1 / 255)
        app.click(click)
        app.set_max_splats(0)
        node = app.splats["before"][3]
        assert app.splats["before"][2] is None and node.buffer.shape[0] == len(model)
        assert np.allclose(colours(node)[sel], 0.5 * rgbs[sel] + 0.5 * SELECTED_TINT, atol=1.5 / 255)
        assert np.allclose(colours(node)[~sel], rgbs[~sel], atol=1 / 255)
    finally:
        app.stop()


def test_the_page_shows_the_running_stage_s_own_progress(make_blobs_scene, tmp_path):
    """The panel's second bar and its line are the job's :meth:`RunJob.within` (what the stage's bar
    last counted), the first bar the share of stages done."""
    from inpaint360gs.viewer.session import RunJob

    scene, model, labels, session = blobs_session(make_blobs_scene, tmp_path, "within", 6)
    app = ViewerApp(session, port=0, background=False)
    try:
        assert app.g_within.content == "stage: -"
        job = session.job = RunJob(runner=None, until="distill")  # a job as its thread leaves it mid-stage (never started)
        job._on_stage("train", "ran", 1.0)
        job._on_stage("segment", "running", None)
        job._on_bar("segment (gt)", 3, 10)
        app._show_progress(job)
        assert app.g_within.content == "stage: segment (gt) 3/10" and app.g_within_bar.value == pytest.approx(30.0)
        assert app.g_bar.value == pytest.approx(25.0)  # 1 of the 4 stages up to distill
        job._on_stage("segment", "ran", 1.0)
        job._on_stage("associate", "running", None)  # a stage without a bar: the last stage's is not shown
        app._show_progress(job)
        assert app.g_within.content == "stage: -" and app.g_within_bar.value == 0.0
        job._on_bar("open-ended", 4, None)
        app._show_progress(job)
        assert app.g_within.content == "stage: open-ended 4"
    finally:
        app.stop()
