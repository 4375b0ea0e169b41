"""Key Object Management association (paper Sec. 3.2, Eq. 2, Alg. 1): per-view 2D segments linked into
view-consistent object ids through the Gaussians they cover.

* :mod:`.config` — :class:`AssociationConfig`; :mod:`.kom` — the algorithm; :mod:`.tracker` — the 2D
  tracker of ablation a); :mod:`.stage` — :func:`associate` (arrays) and :func:`associate_stage` (folders).
"""

from inpaint360gs.core.exports import lazy_exports

# name -> module: imported on first use, so that the settings (``associate.config``) load without the stage
_EXPORTS = {"MAX_OBJECTS": "config", "AssociationConfig": "config", "Association": "stage", "associate": "stage", "associate_stage": "stage",
            "write_association": "stage"}  # fmt: skip
__all__ = sorted(_EXPORTS)

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
