"""``inpaint360gs view SCENE [RUN] [--model PLY] [--preset cpu|gpu|paper] [--port N] [--host H]``: the
browser viewer (README "Viewer"; thin shell over :func:`inpaint360gs.viewer.api.view`). Click on a
photo to select the object to remove, Run to remove and inpaint it into RUN (the run of
``inpaint360gs run SCENE RUN --click ...``), compare before and after. Serves on 127.0.0.1 unless
``--host`` says otherwise (with a warning: the page has no login)."""

from __future__ import annotations

import argparse
import warnings

from inpaint360gs.cli.common import add_backend_argument, add_scene_arguments, add_threads_argument, existing_dir, existing_file, nonneg_int, output_dir, set_threads


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """Add ``inpaint360gs view``'s arguments to ``parser``."""
    from inpaint360gs.pipeline.presets import DEFAULT_PRESET, PRESETS
    from inpaint360gs.viewer.server import DEFAULT_PORT, DEFAULT_SPLATS

    parser.add_argument("scene", type=existing_dir, help="scene folder (images/, sparse/0, scene.json, ...)")
    parser.add_argument("out", type=output_dir, nargs="?", default=None, help="the run's folder, as inpaint360gs run's OUT (default: runs/<scene name>)")
    parser.add_argument("--model", type=existing_file, default=None, help="a trained 3DGS PLY of this scene (as run --model)")
    parser.add_argument("--preset", default=DEFAULT_PRESET, choices=list(PRESETS), help=f"the run's settings (default {DEFAULT_PRESET}, as inpaint360gs run)")
    parser.add_argument("--port", type=nonneg_int, default=DEFAULT_PORT, help=f"port to serve on (default {DEFAULT_PORT}; 0: a free one)")
    parser.add_argument("--host", default="127.0.0.1", help="address to serve on (default 127.0.0.1, this machine only; another is warned about)")
    parser.add_argument("--splats", dest="max_splats", type=nonneg_int, default=DEFAULT_SPLATS, help=f"the most opaque splats drawn at first (default {DEFAULT_SPLATS}: "
                        "what a browser without a GPU draws in seconds; 0: all; the page's 'splats' switches to all)")  # fmt: skip
    parser.add_argument("--accept", action="store_true", help="keep a run's result that fails its check (as run --accept)")
    add_scene_arguments(parser, llffhold=False, resize_note="else images/ shrunk on read; clicks stay in the coordinates of images/")
    add_backend_argument(parser, default=None)
    add_threads_argument(parser)


def _send_model(server, args: argparse.Namespace):
    """The trained model's splats sent to ``server`` at once (:func:`inpaint360gs.viewer.splats.send_splats`),
    or None when there is none yet or its file does not read so (the page sends them later)."""
    from pathlib import Path

    from inpaint360gs.core.layout import RunLayout
    from inpaint360gs.viewer.splats import send_splats

    path = args.model if args.model is not None else RunLayout(Path(args.out)).model if args.out is not None else None
    if path is None or not Path(path).is_file():
        return None
    try:
        return send_splats(server, path, args.max_splats)
    except (OSError, ValueError, KeyError, IndexError):
        return None


def run(args: argparse.Namespace) -> int:
    """Run ``inpaint360gs view`` with parsed ``args`` (serves until Ctrl-C); returns the exit status."""
    from dataclasses import replace

    from inpaint360gs.viewer.server import exposure_warning, start_server

    server = start_server(args.host, args.port)  # before torch is imported: the browser loads the page meanwhile
    try:
        warning = exposure_warning(args.host)
        if warning:
            print(f"warning: {warning}", flush=True)
        print(f"inpaint360gs view: http://{args.host}:{server.get_port()} (Ctrl-C to stop)", flush=True)
        sent = _send_model(server, args)  # still before torch: the browser draws them while the rest loads

        from inpaint360gs.io.scene import load_scene
        from inpaint360gs.pipeline.presets import get_preset
        from inpaint360gs.viewer.api import view

        set_threads(args.threads)
        scene = load_scene(args.scene, resize=args.resize, load_masks=False)
        cfg = get_preset(args.preset)
        if args.backend is not None:
            cfg = replace(cfg, backend=args.backend)
        with warnings.catch_warnings():  # said above, as one line
            warnings.simplefilter("ignore")
            app = view(scene, args.out, cfg=cfg, model=args.model, accept=args.accept, block=False, max_splats=args.max_splats, server=server, sent=sent)
    except BaseException:
        server.stop()
        raise
    print(f"inpaint360gs view: run folder {app.session.layout.root}; the scene is loaded", flush=True)
    app.serve_forever()
    return 0
