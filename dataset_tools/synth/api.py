"""Rendering extra cameras of a synthetic scene (later stages: virtual views, evaluation, tests)."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import replace
from pathlib import Path

from dataset_tools.synth.cameras import View
from dataset_tools.synth.raycast import World
from dataset_tools.synth.render import SUPERSAMPLE, Rendering, render
from dataset_tools.synth.scene import SynthScene, as_scene


def render_view(
    scene: SynthScene | str | Path,
    camera,
    *,
    with_objects: bool = True,
    hidden: Iterable[int] | None = None,
    supersample: int = SUPERSAMPLE,
) -> Rendering:
    """Render any camera of a scene: RGB (supersampled), centre-ray z-depth, instance ids and hit points.

    ``scene``: a :class:`SynthScene` or a generated scene folder. ``camera``: an
    :class:`inpaint360gs.core.camera.Camera` (any dtype or device) or a :class:`View`.
    ``with_objects=False`` removes the removal targets (the object-free capture); ``hidden`` instead
    names exactly which object ids to remove.
    """
    sc = as_scene(scene)
    view = camera if isinstance(camera, View) else View(camera if camera.name else replace(camera, name="view"))
    if hidden is not None:
        world = World(sc.spec, frozenset(int(i) for i in hidden), sc.seed)
    else:
        world = sc.world(object_free=not with_objects)
    return render(world, view, supersample)
