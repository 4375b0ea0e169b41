"""Inpaint360GS: object-aware 3D inpainting with Gaussian Splatting in 360° scenes (WACV 2026).

The API: :func:`load_scene` reads a scene folder, :func:`remove_object` runs the method on it (the
same run as ``inpaint360gs run``) and returns a :class:`RemovalResult` (folders, what each stage did,
stage seconds); :data:`PRESETS` are the settings it runs with (``cpu``, ``gpu``, ``paper``), each a whole
:class:`RunConfig` to change with ``dataclasses.replace``.
:func:`view` serves the browser viewer on a scene and a run folder (click to select, run, compare).
Importing the package is cheap: the API's modules load on first use.

>>> import inpaint360gs
>>> sorted(inpaint360gs.PRESETS)
['cpu', 'gpu', 'paper']
>>> scene = inpaint360gs.load_scene("data/kitchen")  # doctest: +SKIP
>>> result = inpaint360gs.remove_object(scene, "out/kitchen", clicks=[("IMG_0003.png", 120, 88)])  # doctest: +SKIP
>>> result.inpainted / "grid.png", result.seconds["train"]  # doctest: +SKIP
"""

import os as _os

# torch and the numba rasterizer each bring an OpenMP runtime; with libgomp's default spin-waiting
# their idle threads steal the cores from each other, and torch ops right after a numba kernel crawl
# (results/README.md, "The CPU"). Threads that sleep when idle avoid it. Effective when this package is imported
# before torch (the CLI does); an explicit user setting wins.
_os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")
# MKL (torch's CPU BLAS) picks its code path and splits work between threads at run time; on CPUs
# with AVX-512 that made two identical backward passes of the LPIPS term of the inpainting loss
# (Eq. 6; a 1x1 feature map's convolution goes through MKL) differ in the last bits, so a seeded
# run did not repeat. Conditional Numerical Reproducibility ("AUTO": the best path for this CPU,
# chosen once) makes them repeat bit for bit. MKL reads the variable at its
# first call: effective when this package is imported before torch computes anything.
_os.environ.setdefault("MKL_CBWR", "AUTO")

__version__ = "0.1.0"

__all__ = ["PRESETS", "RemovalResult", "RunConfig", "get_preset", "load_scene", "remove_object", "view", "__version__"]


def __getattr__(name: str):
    """The API's names, imported on first use (``import inpaint360gs`` loads neither torch nor numba)."""
    if name in ("load_scene", "remove_object", "RemovalResult"):
        from inpaint360gs.pipeline import api

        return getattr(api, name)
    if name in ("PRESETS", "get_preset"):
        from inpaint360gs.pipeline import presets

        return getattr(presets, name)
    if name == "view":  # the browser viewer (viser, an optional extra, loads when it starts)
        from inpaint360gs.viewer.api import view

        return view
    if name == "RunConfig":
        from inpaint360gs.pipeline.config import RunConfig

        return RunConfig
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
