"""Object-ID distillation (paper Sec. 3.3): identity features of the frozen Gaussian field, trained
on the associated per-view object masks, and the classifier Phi that maps them to object ids."""

from inpaint360gs.distill.config import DistillConfig
from inpaint360gs.distill.field import IdentityField, read_classifier, write_classifier
from inpaint360gs.distill.labels import read_objects
from inpaint360gs.distill.stage import DistillResult, distill_stage

__all__ = ["DistillConfig", "DistillResult", "IdentityField", "distill_stage", "read_classifier", "read_objects", "write_classifier"]
