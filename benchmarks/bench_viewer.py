"""How fast the viewer answers (README "Viewer"; targets: the first frame within 10 s of
``inpaint360gs view`` on a trained kitchen, a click's selection drawn within 2 s once the object
field exists). Headless Chromium (software WebGL) is driven over its DevTools protocol and its page
is screenshotted every 0.1 s, so that "drawn" is what the browser shows, not what the server sent.

1. ``inpaint360gs view SCENE RUN`` in a fresh process: seconds to its URL line (the page can be
   opened; the browser is sent there at once), to its line saying the scene is loaded, and to the
   first screenshot whose splat region holds the scene (pixels neither the page's white nor the
   frustums' grey), counted from the command's start.
2. In this process, the viewer on the same folders with a browser connected, the page loaded and
   what clicks re-use ready (seconds from the page's opening to that, ``ViewerApp.wait_warm``): a
   click on the photo at ``--click`` (the selection through the object field, as ``run --click``),
   seconds to the selection computed and sent, and to the first screenshot that differs from the one
   before the click; then the same click again (drops it); then a click on the splats along the ray
   from the clicked view's camera through that pixel (the same selection).
3. When the object field must be distilled first: the run folder's ``run.json`` seconds of segment,
   associate and distill (what the Run button takes before a click can be resolved).

    python benchmarks/bench_viewer.py data/kitchen runs/kitchen --click IMG_12.png:856,360 --resize 4
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np

from inpaint360gs.viewer.api import DEFAULT_SPLATS
from inpaint360gs.viewer.browser import Browser, free_port


def scene_drawn(img: np.ndarray) -> bool:
    """Whether the page's 3D view (left of the panel) shows the splats: at least 2 % of its pixels are
    coloured (not the white page, not a grey frustum line, not the notice boxes' white)."""
    view = img[:, : int(img.shape[1] * 0.72)]
    spread = view.max(axis=-1) - view.min(axis=-1)
    return float(((spread > 20) & (view.max(axis=-1) < 250)).mean()) > 0.02


def changed(img: np.ndarray, before: np.ndarray) -> float:
    """The share of pixels that changed visibly (any channel by more than 30 of 255)."""
    return float((np.abs(img - before).max(axis=-1) > 30).mean())


def wait_for(browser: Browser, test, t0: float, timeout: float = 120.0) -> float:
    while time.perf_counter() - t0 < timeout:
        if test(browser.screenshot()):
            return time.perf_counter() - t0
        time.sleep(0.1)
    return float("nan")


def first_frame(args, browser: Browser) -> dict:
    port = free_port()
    cmd = [str(Path(sys.executable).with_name("inpaint360gs")), "view", args.scene, args.run, "--port", str(port), "--resize", str(args.resize)]
    t0 = time.perf_counter()
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True)
    try:
        for line in proc.stdout:
            if line.startswith("inpaint360gs view: http://"):
                break
        else:
            sys.exit(f"bench_viewer: {' '.join(cmd)} ended without serving")
        ready = time.perf_counter() - t0
        browser.call("Page.navigate", url=f"http://127.0.0.1:{port}")
        loaded = threading.Thread(target=lambda: [line for line in proc.stdout if "the scene is loaded" in line and not times.append(time.perf_counter() - t0)])
        times: list[float] = []
        loaded.start()
        frame = wait_for(browser, scene_drawn, t0)
    finally:
        proc.terminate()
        proc.wait()
    return {"view: URL printed (s)": ready, "view: scene loaded (s)": times[0] if times else float("nan"), "view: first frame with the splats (s)": frame}


def look_from_behind(app, view) -> None:
    """The page's camera at the clicked camera's pose, moved back along its axis by five depths of its
    frustum's photo: the selection lies in the 3D view, the frustum's photo covers a small part of it."""
    from inpaint360gs.viewer.session import camera_pose, frustum_depth, frustum_shape

    wxyz, pos = camera_pose(view.camera)
    fov, aspect = frustum_shape(view.camera)
    back = pos - 5.0 * frustum_depth(fov, aspect, app.scale) * view.camera.R.double().numpy()[2]
    for client in app.server.get_clients().values():
        with client.atomic():
            client.camera.fov = fov
            client.camera.wxyz = wxyz
            client.camera.position = back


def click_times(args, browser: Browser) -> dict:
    from inpaint360gs.io.scene import load_scene
    from inpaint360gs.pipeline.presets import get_preset
    from inpaint360gs.remove.select import Click
    from inpaint360gs.viewer.app import ViewerApp
    from inpaint360gs.viewer.session import ViewerSession, frustum_depth, frustum_shape, ray_through_pixel

    scene = load_scene(args.scene, resize=args.resize, load_masks=False)
    session = ViewerSession(scene, args.run, get_preset("cpu"))
    if session.field is None:
        sys.exit(f"bench_viewer: {args.run} has no object field (distill/): run it up to distill first")
    app = ViewerApp(session, port=free_port(), max_splats=DEFAULT_SPLATS)  # as inpaint360gs view draws them
    out = {}
    try:
        t0 = time.perf_counter()
        browser.call("Page.navigate", url=f"http://127.0.0.1:{app.port}")
        app.wait_warm()
        wait_for(browser, scene_drawn, time.perf_counter())
        click = Click.parse(args.click)
        view = scene.view(click.view)
        app.show_view(view, move=False)
        look_from_behind(app, view)
        session.id_map(view)  # the shown photo's id map, which the page renders when a camera is chosen
        out["viewer warm: support plane, projections, the shown photo's id map (s)"] = time.perf_counter() - t0
        time.sleep(1.0)
        origin = view.camera.center.double().numpy()
        fov, aspect = frustum_shape(view.camera)
        ray = ray_through_pixel(view, click.x, click.y, origin, frustum_depth(fov, aspect, app.scale))
        for what, do in (("select", lambda: app.click(click)), ("drop", lambda: app.click(click)), ("on the splats", lambda: app.on_splat_click(origin, ray))):
            time.sleep(1.0)
            t0 = time.perf_counter()
            before = browser.screenshot()
            # a capture draws a frame of the page: its time is the floor of every "drawn" below
            out[f"click ({what}): one screenshot of the page, nothing changed (s)"] = time.perf_counter() - t0
            t0 = time.perf_counter()
            do()
            t_sent = time.perf_counter() - t0
            drawn = wait_for(browser, lambda img: changed(img, before) > 0.002, t0)
            in_3d = wait_for(browser, lambda img: changed(img[:, : int(img.shape[1] * 0.72)], before[:, : int(img.shape[1] * 0.72)]) > 0.002, t0)
            out |= {f"click ({what}): computed and sent (s)": t_sent, f"click ({what}): drawn, first change (s)": drawn,
                    f"click ({what}): drawn in the 3D view (s)": in_3d}  # fmt: skip
        out["selection check"] = session.verdict() if session.plan else "(dropped)"
    finally:
        app.stop()
    seconds = json.loads((Path(args.run) / "run.json").read_text()).get("seconds", {}) if (Path(args.run) / "run.json").is_file() else {}
    if all(k in seconds for k in ("segment", "associate", "distill")):
        out["object field first (segment + associate + distill, run.json) (s)"] = float(seconds["segment"] + seconds["associate"] + seconds["distill"])
    return out


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("scene")
    p.add_argument("run", help="a run folder with 3dgs/ and distill/ (inpaint360gs run --until distill)")
    p.add_argument("--click", required=True, help="VIEW:X,Y on the object (images/ coordinates)")
    p.add_argument("--resize", type=int, default=1)
    args = p.parse_args()
    browser = Browser()
    if browser.proc is None:
        sys.exit("bench_viewer: needs chromium (Debian's chromium package)")
    try:
        rows = first_frame(args, browser)
        print(rows, flush=True)
        rows |= click_times(args, browser)
    finally:
        browser.close()
    print("| measure | value |\n|---|---|")
    for k, v in rows.items():
        print(f"| {k} | {v:.2f} |" if isinstance(v, float) else f"| {k} | {v} |")


if __name__ == "__main__":
    main()
