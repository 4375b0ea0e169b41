"""Render a model at a list of a scene's views into a folder: ``color/<stem>.png``, ``depth/<stem>.npy``
(float32, paper Eq. 5) and ``depth/<stem>.png`` (16 bit, scales in ``render.json``)."""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path

import torch

from inpaint360gs.core import layout
from inpaint360gs.core.errors import InputError
from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.core.progress import track
from inpaint360gs.io.arguments import check_stage_call
from inpaint360gs.io.atomic import atomic_dir
from inpaint360gs.io.images import write_depth, write_image
from inpaint360gs.io.scene import Scene, View
from inpaint360gs.render.api import render


@torch.no_grad()
def render_stage(
    scene: Scene,
    model: Gaussians,
    views: Sequence[View],
    out: str | Path,
    *,
    sh_degree: int | None = None,
    background: torch.Tensor | None = None,
    backend: str = "auto",
    overwrite: bool = False,
    progress: bool = True,
    meta: dict | None = None,
) -> dict:
    """Render ``views`` into ``out`` (atomically); returns what ``render.json`` holds plus ``empty_views``,
    the number of views where no pixel is covered (alpha < 1/255 everywhere). ``meta`` goes into render.json.

    ``sh_degree``, ``background`` and ``backend`` are passed to :func:`render` (the stage has no
    settings object: these three are its settings).
    Raises: :class:`InputError` for a non-empty ``out`` without ``overwrite``, and what :func:`render` raises."""
    check_stage_call("render_stage", scene, out, None, object, overwrite=overwrite, progress=progress, models={"model": model})
    if not isinstance(model, Gaussians):
        raise InputError(f"expected Gaussians (io.ply.read_ply), got {type(model).__name__}", setting="render_stage.model")
    if not isinstance(views, (list, tuple)) or not all(isinstance(v, View) for v in views):
        raise InputError("expected a list of the scene's views", setting="render_stage.views")
    scales, empty = {}, 0
    with atomic_dir(out, overwrite=overwrite) as tmp:
        for v in track(views, "render", bool(views and progress)):
            o = render(model, v.camera, sh_degree=sh_degree, background=background, backend=backend)
            write_image(tmp / layout.RENDER_COLOR_DIR / f"{v.stem}.png", o.color)
            scales[v.name] = write_depth(tmp / "depth" / v.stem, o.depth)
            empty += int(bool((o.alpha < 1.0 / 255).all()))
        info = {**(meta or {}), "scene": str(scene.root), "views": [v.name for v in views], "resize": scene.resize, "depth_png_scale": scales}
        (tmp / "render.json").write_text(json.dumps(info, indent=2) + "\n")
    return {**info, "empty_views": empty}
