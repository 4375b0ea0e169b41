"""The viewer's web server, started before anything heavy is imported (``inpaint360gs view`` prints
its address at once, so that the browser loads the page while the scene loads; README "Viewer"),
and the viewer's defaults. Imports viser only, when the server starts."""

from __future__ import annotations

from inpaint360gs.core.errors import InputError

DEFAULT_PORT = 8080
DEFAULT_SPLATS = 5000  # splats drawn at first (the most opaque): what a browser without a GPU draws in seconds
LOCAL_HOSTS = ("127.0.0.1", "localhost", "::1")


def exposure_warning(host: str) -> str | None:
    """The warning printed when the viewer serves beyond this machine, or None for a local host."""
    if host in LOCAL_HOSTS:
        return None
    return (f"serving on {host}: anyone who can reach this machine can see the scene, run stages that write into the run folder "
            "and overwrite scene.json's clicks; the page has no login")  # fmt: skip


def start_server(host: str = "127.0.0.1", port: int = DEFAULT_PORT):
    """A viser server serving the (still empty) page on ``host``:``port`` (0: a free port).
    Raises: :class:`InputError` for a bad host or port or a missing viser (``pip install -e .[viewer]``)."""
    if not isinstance(host, str) or not host:
        raise InputError(f"expected a host name or address, got {host!r:.40}", setting="host")
    if isinstance(port, bool) or not isinstance(port, int) or not 0 <= port <= 65535:
        raise InputError(f"a port is a whole number in 0..65535, got {port!r:.40}", setting="port")
    try:
        import viser
    except ImportError:
        raise InputError("the viewer needs viser: pip install -e '.[viewer]'", setting="viewer") from None
    try:
        return viser.ViserServer(host=host, port=port, verbose=False)
    except OSError as e:
        raise InputError(f"cannot serve on {host}:{port}: {e.strerror or e}", setting="port") from None
