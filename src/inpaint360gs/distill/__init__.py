"""Object-ID distillation (paper Sec. 3.3): identity features of the frozen Gaussian field, trained
on the associated per-view object masks, and the classifier Phi that maps them to object ids."""

from inpaint360gs.core.exports import lazy_exports

# name -> module: imported on first use, so that the settings (``distill.config``) load without the stage
_EXPORTS = {"DistillConfig": "config", "IdentityField": "field", "read_classifier": "field", "write_classifier": "field",
            "read_objects": "labels", "DistillResult": "stage", "distill_stage": "stage"}  # fmt: skip
__all__ = sorted(_EXPORTS)

__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals())
