"""The front door of the library (docs/architecture.md, "Reliability"): the argument checks every
stage function, :class:`inpaint360gs.pipeline.run.Runner` and :func:`inpaint360gs.remove_object`
run before any work. A wrong type (a number for a folder, ``"1"`` for a seed, a list for a scene) is
an :class:`~inpaint360gs.core.errors.InputError` naming the argument (its ``setting``), never a
``TypeError`` from deep inside a stage after minutes of work."""

from __future__ import annotations

import dataclasses
import os
from pathlib import Path

from inpaint360gs.core.errors import InputError
from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.core.settings import check_fields
from inpaint360gs.io.scene import Scene


def _kind(value: object) -> str:
    return "None" if value is None else f"{type(value).__name__} {value!r:.40}"


def path_argument(value: object, name: str) -> Path:
    """``value`` as a :class:`Path`: a ``str`` or path-like, not empty, without NUL bytes;
    :class:`InputError` naming ``name`` otherwise."""
    if isinstance(value, os.PathLike):
        value = os.fspath(value)
    if not isinstance(value, str) or not value.strip() or "\0" in value:
        raise InputError(f"expected a path (str or pathlib.Path), got {_kind(value)}", setting=name)
    return Path(value)


def bool_argument(value: object, name: str) -> bool:
    """``value`` when it is a bool; :class:`InputError` naming ``name`` otherwise (``"false"`` is not false)."""
    if not isinstance(value, bool):
        raise InputError(f"expected True or False, got {_kind(value)}", setting=name)
    return value


def scene_argument(value: object, name: str = "scene") -> Scene:
    """``value`` when it is a loaded :class:`Scene`; :class:`InputError` naming ``name`` otherwise."""
    if not isinstance(value, Scene):
        raise InputError(f"expected a Scene (inpaint360gs.load_scene), got {_kind(value)}", setting=name)
    return value


def check_stage_call(stage: str, scene: object, out: object, cfg: object, cfg_type: type | tuple[type, ...], *, overwrite: object, progress: object,
                     out_optional: bool = False, models: dict[str, object] | None = None, folders: dict[str, object] | None = None) -> None:  # fmt: skip
    """The checks of a stage function's common call shape ``(scene, inputs…, out, cfg=None, *,
    overwrite, progress)``: ``scene`` a :class:`Scene`; each of ``models`` (name -> value) a
    :class:`Gaussians` or a path; each of ``folders`` a path; ``out`` a path (or None with
    ``out_optional``); ``cfg`` None or a ``cfg_type`` whose fields have their types
    (:func:`~inpaint360gs.core.settings.check_fields`); ``overwrite`` and ``progress`` bools.
    Raises :class:`InputError` naming ``<stage>.<argument>``."""
    scene_argument(scene, f"{stage}.scene")
    for name, value in (models or {}).items():
        if not isinstance(value, Gaussians):
            path_argument(value, f"{stage}.{name}")
    for name, value in (folders or {}).items():
        path_argument(value, f"{stage}.{name}")
    if not (out_optional and out is None):
        path_argument(out, f"{stage}.out")
    if cfg is not None:
        if not isinstance(cfg, cfg_type):
            names = " or ".join(t.__name__ for t in (cfg_type if isinstance(cfg_type, tuple) else (cfg_type,)))
            raise InputError(f"expected a {names} (or None: the defaults), got {_kind(cfg)}", setting=f"{stage}.cfg")
        if dataclasses.is_dataclass(cfg):
            check_fields(cfg)
    bool_argument(overwrite, f"{stage}.overwrite")
    bool_argument(progress, f"{stage}.progress")
