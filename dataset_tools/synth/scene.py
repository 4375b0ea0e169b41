"""A synthetic scene instance: catalogue spec + seed + image size + capture views, with its two worlds.

Built from the catalogue (:func:`build_scene`) or read back from a generated folder
(:func:`load_scene`: ``scene.json`` gives name and seed, ``gt/cameras.json`` the exact poses).
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path

from dataset_tools.synth.cameras import View, capture_views
from dataset_tools.synth.catalogue import scene_spec
from dataset_tools.synth.raycast import World
from dataset_tools.synth.spec import SceneSpec
from inpaint360gs.core.errors import InputError

FULL_SIZE = (256, 192)  # benchmark resolution (width, height)
REDUCED_SIZE = (128, 96)
REDUCED_VIEWS = (32, 8)  # object-inclusive, object-free captures with --reduced (fewer: SfM fails at 128x96)
REDUCED_POINTS = 3000


@dataclass
class SynthScene:
    """Everything needed to render or check a generated scene."""

    spec: SceneSpec
    seed: int
    width: int
    height: int
    reduced: bool
    views: list[View] = field(repr=False)
    n_points: int = 8000

    @property
    def name(self) -> str:
        return self.spec.name

    @property
    def inclusive_views(self) -> list[View]:
        """Object-inclusive captures (training + held-out), in orbit order."""
        return [v for v in self.views if not v.object_free]

    @property
    def test_views(self) -> list[View]:
        return [v for v in self.views if v.object_free]

    @cached_property
    def world_full(self) -> World:
        """The scene with every object (what the object-inclusive captures see)."""
        return World(self.spec, frozenset(), self.seed)

    @cached_property
    def world_free(self) -> World:
        """The scene with the removal targets taken away (what the test captures see)."""
        return World(self.spec, frozenset(self.spec.removal_targets), self.seed)

    def world(self, object_free: bool) -> World:
        return self.world_free if object_free else self.world_full


def build_scene(name: str, *, reduced: bool = False, width: int | None = None, height: int | None = None, seed: int = 0) -> SynthScene:
    """The catalogue scene ``name`` at the benchmark size (or ``--reduced`` CI size, or an explicit size)."""
    spec = scene_spec(name)
    if (width is None) != (height is None):
        raise InputError("give both --width and --height, or neither")
    if width is None:
        width, height = REDUCED_SIZE if reduced else FULL_SIZE
    if width < 16 or height < 16 or width > 8192 or height > 8192:
        raise InputError(f"image size {width}x{height} out of range (16..8192)")
    n_views, n_test = REDUCED_VIEWS if reduced else (spec.n_views, spec.n_test)
    views = capture_views(spec, n_views, n_test, int(width), int(height), int(seed))
    n_points = REDUCED_POINTS if reduced else spec.n_points
    return SynthScene(spec, int(seed), int(width), int(height), bool(reduced), views, n_points)


def load_scene(scene_dir: str | Path) -> SynthScene:
    """Rebuild the :class:`SynthScene` of a generated folder from its ``scene.json`` and ``gt/cameras.json``."""
    scene_dir = Path(scene_dir)
    sj, cj = scene_dir / "scene.json", scene_dir / "gt" / "cameras.json"
    for p in (sj, cj):
        if not p.is_file():
            raise InputError("missing (not a synthetic scene folder?)", p)
    bad = (KeyError, TypeError, ValueError, AttributeError, UnicodeDecodeError)  # JSONDecodeError is a ValueError
    try:
        meta = json.loads(sj.read_text())
        prov = meta["provenance"]
        seed, reduced = int(prov["seed"]), bool(prov["reduced"])
        name = meta["name"]
        if not isinstance(name, str):
            raise TypeError(f"name is a {type(name).__name__}, not a string")
    except bad as e:
        raise InputError(f"malformed synthetic scene metadata ({type(e).__name__}: {e})", sj) from None
    try:
        spec = scene_spec(name)
    except InputError as e:
        raise InputError(e.message, sj) from None
    try:
        cams = json.loads(cj.read_text())
        K = (float(cams["fx"]), float(cams["fy"]), float(cams["cx"]), float(cams["cy"]))
        views = [View.at(c["name"], c["R"], c["t"], K, int(cams["width"]), int(cams["height"]), bool(c["object_free"]))
                 for c in cams["images"]]
    except bad as e:
        raise InputError(f"malformed synthetic camera metadata ({type(e).__name__}: {e})", cj) from None
    n_points = REDUCED_POINTS if reduced else spec.n_points
    return SynthScene(spec, seed, int(cams["width"]), int(cams["height"]), reduced, views, n_points)


def as_scene(scene) -> SynthScene:
    """Accept a :class:`SynthScene`, or a path to a generated scene folder."""
    if isinstance(scene, SynthScene):
        return scene
    if isinstance(scene, (str, Path)):
        return load_scene(scene)
    raise TypeError(f"expected a SynthScene or a scene folder path, got {type(scene).__name__}")
