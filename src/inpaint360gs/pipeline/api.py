"""The Python API that ``import inpaint360gs`` exports: :func:`load_scene`, :func:`remove_object` and
the :class:`RemovalResult` it returns. The same run as ``inpaint360gs run`` (:class:`.run.Runner`), so
a folder written by one is picked up by the other, stage by stage."""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Iterable, Union

from inpaint360gs.core.errors import InputError
from inpaint360gs.core.layout import LLFFHOLD, RunLayout
from inpaint360gs.core.settings import check_value
from inpaint360gs.io.arguments import path_argument
from inpaint360gs.io.scene import Scene
from inpaint360gs.io.scene import load_scene as read_scene
from inpaint360gs.pipeline.presets import DEFAULT_PRESET, PRESETS, get_preset
from inpaint360gs.pipeline.run import SECONDS_KEY, STAGES, RunConfig, Runner, check_run_arguments
from inpaint360gs.remove.select import Click

ClickLike = Union[Click, str, tuple]


def load_scene(path: str | Path, *, resize: int = 1, llffhold: int = LLFFHOLD) -> Scene:
    """Read a scene folder (``images/``, ``sparse/0``, optional ``scene.json``; docs/architecture.md,
    "Scene format"); pixels are read when a stage needs them.

    Args: ``path`` the folder; ``resize`` work on the images downscaled by this factor
    (``images_<R>/`` when present); ``llffhold`` every Nth non-test view is held out of training (0: none).
    Returns: a :class:`inpaint360gs.io.scene.Scene`.
    Raises: :class:`inpaint360gs.core.errors.InputError` naming the file when the folder is missing or inconsistent."""
    return read_scene(path, resize=resize, llffhold=llffhold, load_masks=False)


@dataclass
class RemovalResult:
    """What :func:`remove_object` did: the run's folder, each stage's folder and main file, what each
    stage did (``"ran"``, ``"up to date"`` or ``"given"``) and its wall seconds when it last ran."""

    out: Path
    stages: dict[str, str]
    seconds: dict[str, float]
    config: RunConfig = field(repr=False)
    check: dict | None = None  # the run's check of its result (``check.json``: passed, failed checks, each value and limit)

    @property
    def layout(self) -> RunLayout:
        """The run folder's layout (where each stage writes)."""
        return RunLayout(self.out)

    @property
    def model(self) -> Path:
        """The 3DGS model the later stages read (trained here unless one was given)."""
        return self.layout.model

    @property
    def removed(self) -> Path:
        """The scene with the object removed (``point_cloud.ply``, ``removal.json``)."""
        return self.layout.removed

    @property
    def inpainted(self) -> Path:
        """The final, inpainted scene (``point_cloud.ply``, ``grid.png``, ``trajectory.gif``, renders)."""
        return self.layout.inpainted


def _click(c: ClickLike) -> Click:
    if isinstance(c, Click):
        return c
    if isinstance(c, str):
        return Click.parse(c)
    if not isinstance(c, (tuple, list)) or len(c) != 3:
        raise InputError(f"click {c!r:.60} is not (view, x, y) nor 'VIEW:X,Y'", setting="clicks")
    return Click.make(*c)


def _listed(value: object, name: str) -> list:
    """The items of a list-like argument (a list, tuple or other iterable; not a string, a mapping or one number)."""
    if value is None:
        return []
    if isinstance(value, (str, bytes, dict)) or not isinstance(value, Iterable):
        raise InputError(f"expected a list, got {type(value).__name__} {value!r:.40}", setting=name)
    return list(value)


def remove_object(
    scene: Scene | str | Path,
    out: str | Path,
    *,
    clicks: Iterable[ClickLike] | None = None,
    ids: Iterable[int] | None = None,
    preset: str | RunConfig = DEFAULT_PRESET,
    model: str | Path | None = None,
    until: str = STAGES[-1],
    seed: int | None = None,
    progress: bool = False,
    accept: bool = False,
) -> RemovalResult:
    """Remove the clicked objects from ``scene`` and inpaint what they hid (paper Alg. 1), into ``out``
    (one sub-folder per stage; stages already done with the same inputs and settings are skipped).

    Args: ``scene`` a :class:`Scene` or its folder; ``out`` the run's folder (absent, empty, or an
    earlier run's); ``clicks`` on the object, each ``(view, x, y)``, ``"VIEW:X,Y"`` or a
    :class:`Click`, in the pixels of ``images/`` (default: ``scene.json``'s clicks); ``ids`` object ids
    to remove besides; ``preset`` ``"cpu"``, ``"gpu"`` or ``"paper"`` (:mod:`.presets`), or a whole
    :class:`RunConfig` (a preset changed with ``dataclasses.replace``); ``model`` a trained 3DGS PLY of
    the scene (skips training); ``until`` the last stage to run (one of :data:`STAGES`); ``seed`` the
    seed of every stage (None: the preset's, 0); ``progress`` show progress bars; ``accept`` keep a
    result that fails the run's own check.
    Returns: a :class:`RemovalResult`.
    Raises: :class:`InputError` for a bad scene, click, preset, model, stage or output folder, and when
    a click selects nothing (the stages before the failing one are kept);
    :class:`inpaint360gs.core.errors.CheckFailedError` when the result fails the run's own check
    (``OUT/check.json``, ``OUT/check.png``; the outputs are kept) and ``accept`` is false."""
    # the front door: every argument checked before any work (docs/architecture.md, "Reliability")
    path_argument(out, "out")
    if not isinstance(preset, (str, RunConfig)):
        raise InputError(f"expected a preset's name ({', '.join(PRESETS)}) or a RunConfig, got {type(preset).__name__}", setting="preset")
    cfg = preset if isinstance(preset, RunConfig) else get_preset(preset)
    if seed is not None:
        check_value(seed, int, "seed")
        cfg = replace(cfg, seed=seed)
    if not isinstance(until, str) or until not in STAGES:
        raise InputError(f"unknown stage {until!r:.40} (one of {', '.join(STAGES)})", setting="until")
    clicks, ids = [_click(c) for c in _listed(clicks, "clicks")], _listed(ids, "ids")
    check_run_arguments(out, cfg, model=model, clicks=clicks, ids=ids, progress=progress, accept=accept)
    if not isinstance(scene, Scene):
        scene = load_scene(path_argument(scene, "scene"))
    runner = Runner(scene, out, cfg, model=model, clicks=clicks, ids=ids, progress=progress, accept=accept)
    done = dict(runner.run(until))
    seconds = {s: t for s, t in runner.record.get(SECONDS_KEY, {}).items() if s in done}
    check = runner.check.to_json() if runner.check is not None else None
    return RemovalResult(out=runner.layout.root, stages=done, seconds=seconds, config=cfg, check=check)

