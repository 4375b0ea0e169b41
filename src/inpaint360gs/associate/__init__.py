"""Key Object Management association (paper Sec. 3.2, Eq. 2, Alg. 1): per-view 2D segments linked into
view-consistent object ids through the Gaussians they cover.

* :mod:`.config` — :class:`AssociationConfig`; :mod:`.kom` — the algorithm; :mod:`.tracker` — the 2D
  tracker of ablation a); :mod:`.stage` — :func:`associate` (arrays) and :func:`associate_stage` (folders).
"""

from inpaint360gs.associate.config import MAX_OBJECTS, AssociationConfig
from inpaint360gs.associate.stage import Association, associate, associate_stage, write_association

__all__ = ["MAX_OBJECTS", "Association", "AssociationConfig", "associate", "associate_stage", "write_association"]
