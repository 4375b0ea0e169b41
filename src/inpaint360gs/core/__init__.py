"""The ground floor: types and names every other layer shares; imports nothing else of the package.

:class:`Camera`, :class:`Gaussians` (with the SH constant and quaternion maths), the errors the CLI
maps to exit codes, and the scene-folder / output names (:mod:`.layout`). The exports load on first
use, so that a light module (``core.errors``, ``core.layout``) imports without torch: the workflow
reads the library's defaults at parse time and pays no torch import for it.
"""

from inpaint360gs.core.exports import lazy_exports

# name -> module of this package
_EXPORTS = {"Camera": "camera", "InputError": "errors", "TestPixelAccessError": "errors", "TrainingDivergedError": "errors",
            "SH_C0": "gaussians", "Gaussians": "gaussians", "num_sh_bases": "gaussians", "quat_to_rotmat": "gaussians"}  # fmt: skip
__all__ = sorted(_EXPORTS)

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
