"""``inpaint360gs.view(...)``: the viewer from Python (README "Viewer"); viser is imported here only
when the viewer starts, so that it stays an optional extra."""

from __future__ import annotations

from pathlib import Path

from inpaint360gs.core.errors import InputError
from inpaint360gs.io.arguments import bool_argument, path_argument, scene_argument
from inpaint360gs.io.scene import Scene
from inpaint360gs.pipeline.config import RunConfig
from inpaint360gs.pipeline.presets import DEFAULT_PRESET, get_preset
from inpaint360gs.viewer.server import DEFAULT_PORT, DEFAULT_SPLATS, start_server

__all__ = ["DEFAULT_PORT", "DEFAULT_SPLATS", "default_run_folder", "view"]


def default_run_folder(scene: Scene) -> Path:
    """Where the viewer's run goes when none is given: ``runs/<scene name>`` in the working folder
    (the README's layout), so that ``inpaint360gs run SCENE runs/<name>`` resumes it."""
    return Path("runs") / scene.name


def view(scene: Scene, out: str | Path | None = None, *, cfg: RunConfig | None = None, model: str | Path | None = None, host: str = "127.0.0.1",
         port: int = DEFAULT_PORT, accept: bool = False, block: bool = True, on_ready=None,
         max_splats: int = DEFAULT_SPLATS, server=None, sent: tuple | None = None):  # fmt: skip
    """Serve the viewer of ``scene`` and the run folder ``out`` (default :func:`default_run_folder`).

    Args: ``cfg`` the run's settings (default: the default preset's, as ``inpaint360gs run``);
    ``model`` a trained 3DGS PLY (as ``run --model``); ``host`` / ``port`` where to serve (port 0:
    a free one; a host other than this machine's loopback is warned about); ``accept`` keep a result
    that fails the run's check; ``block`` serve until Ctrl-C, else return at once; ``on_ready(port)``
    called as soon as the page can be opened, before the scene's content is loaded (it fills in as
    it comes); ``max_splats`` the most opaque splats drawn at first (:data:`DEFAULT_SPLATS`; 0: all;
    the page's "splats" switches to all); ``server`` one :func:`.server.start_server` started
    (``host``, ``port`` and ``on_ready`` are then its caller's; ``inpaint360gs view`` starts it first);
    ``sent`` the trained model's splats already on ``server`` (:func:`.splats.send_splats`).
    Returns: the running :class:`inpaint360gs.viewer.app.ViewerApp` (``.port``, ``.stop()``).
    Raises: :class:`InputError` for a bad argument or a missing viser (``pip install -e .[viewer]``)."""
    from inpaint360gs.viewer.session import ViewerSession

    scene_argument(scene)
    if out is not None:
        path_argument(out, "out")
    if model is not None:
        path_argument(model, "model")
    bool_argument(accept, "accept")
    bool_argument(block, "block")
    if cfg is None:
        cfg = get_preset(DEFAULT_PRESET)
    elif not isinstance(cfg, RunConfig):
        raise InputError(f"expected a RunConfig (a preset, inpaint360gs.get_preset), got {type(cfg).__name__}", setting="cfg")
    if isinstance(max_splats, bool) or not isinstance(max_splats, int) or max_splats < 0:
        raise InputError(f"the splats drawn are a whole number >= 0 (0: all), got {max_splats!r:.40}", setting="max_splats")
    if on_ready is not None and not callable(on_ready):
        raise InputError(f"expected a function of the port, got {type(on_ready).__name__}", setting="on_ready")
    if server is None:
        server = start_server(host, port)  # first: the browser loads the page while the rest loads
    elif on_ready is not None:
        raise InputError("on_ready is for a server view starts; one given is ready already", setting="on_ready")
    try:
        from inpaint360gs.viewer.app import serve

        if on_ready is not None:
            on_ready(server.get_port())
        session = ViewerSession(scene, default_run_folder(scene) if out is None else out, cfg, model=model, accept=accept)
        return serve(session, host=host, port=port, block=block, server=server, max_splats=max_splats, sent=sent)
    except BaseException:
        server.stop()
        raise
