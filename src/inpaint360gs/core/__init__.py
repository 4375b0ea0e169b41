"""The ground floor: types and names every other layer shares; imports nothing else of the package.

:class:`Camera`, :class:`Gaussians` (with the SH constant and quaternion maths), the errors the CLI
maps to exit codes, and the scene-folder / output names (:mod:`.layout`).
"""

from inpaint360gs.core.camera import Camera
from inpaint360gs.core.errors import InputError, TestPixelAccessError, TrainingDivergedError
from inpaint360gs.core.gaussians import SH_C0, Gaussians, num_sh_bases, quat_to_rotmat

__all__ = ["SH_C0", "Camera", "Gaussians", "InputError", "TestPixelAccessError", "TrainingDivergedError", "num_sh_bases", "quat_to_rotmat"]
