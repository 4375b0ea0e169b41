"""The distilled identity field: Gaussians with identity features f_i and the linear map Phi to classes
(paper Sec. 3.3, Eq. 3: F = sum_i f_i alpha_i T_i, O^ = softmax(Phi(F))).

Stored as ``point_cloud.ply`` (features as ``obj_0..F-1``, :mod:`inpaint360gs.io.ply`) and
``classifier.json``: ``weight`` (Q x F), ``bias`` (Q), ``object_ids`` (the object id of each class,
class 0 = background = id 0), ``feature_dim``, ``num_classes``. Float32 values round-trip exactly
through JSON (Python writes the shortest decimal that reads back as the same double).
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import torch

from inpaint360gs.core.camera import Camera
from inpaint360gs.core.errors import InputError
from inpaint360gs.core.files import parse_json
from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.io import provenance
from inpaint360gs.io.atomic import write_text
from inpaint360gs.io.ply import read_ply

CLASSIFIER_JSON = "classifier.json"
MODEL_PLY = "point_cloud.ply"
DISTILL_JSON = "distill.json"  # the distillation's report (distill/stage.py writes it)


def make_classifier(feature_dim: int, num_classes: int, generator: torch.Generator) -> torch.nn.Linear:
    """Phi = ``torch.nn.Linear(F, Q)`` with torch's default initialisation, U(-1/sqrt(F), 1/sqrt(F)) for
    weight and bias, drawn from ``generator`` (not torch's global RNG)."""
    lin = torch.nn.Linear(feature_dim, num_classes)
    bound = 1.0 / feature_dim**0.5
    with torch.no_grad():
        lin.weight.uniform_(-bound, bound, generator=generator)
        lin.bias.uniform_(-bound, bound, generator=generator)
    return lin


@dataclass
class IdentityField:
    """Gaussians with identity ``features`` (N, F) and the classifier Phi (F -> Q)."""

    gaussians: Gaussians
    classifier: torch.nn.Linear
    object_ids: list[int]  # class -> object id (class 0 = background, id 0)
    record: provenance.Record | None = None  # what it was distilled from (when loaded from a folder)

    def __post_init__(self):
        f = self.gaussians.features
        if f is None or f.ndim != 2:
            raise InputError("the model has no identity features (obj_* properties); run distill first", "gaussians.features")
        if f.shape[1] != self.classifier.in_features:
            raise InputError(f"features have {f.shape[1]} channels but the classifier expects {self.classifier.in_features}", "classifier")
        if len(self.object_ids) != self.classifier.out_features:
            raise InputError(f"{len(self.object_ids)} object ids for {self.classifier.out_features} classes", "classifier")

    @property
    def num_classes(self) -> int:
        """Number of classifier classes (the distilled object ids)."""
        return len(self.object_ids)

    def _id_lut(self, device) -> torch.Tensor:
        return torch.tensor(self.object_ids, dtype=torch.long, device=device)

    @torch.no_grad()
    def classify(self, features: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        """Rendered features (..., F) -> (object ids (...) long, class probabilities (..., Q))."""
        w, b = (t.detach().to(features) for t in (self.classifier.weight, self.classifier.bias))
        probs = torch.softmax(torch.nn.functional.linear(features, w, b), dim=-1)
        return self._id_lut(features.device)[probs.argmax(-1)], probs

    @torch.no_grad()
    def render_ids(self, camera: Camera, *, backend: str = "auto", min_alpha: float = 0.0) -> tuple[torch.Tensor, torch.Tensor]:
        """(object id map (H, W) long, class probabilities (H, W, Q)) for any camera, through the ordinary
        rasterizer. Pixels whose rendered alpha is below ``min_alpha`` get id 0 (nothing is there: the
        classifier's answer to a zero feature is its bias alone)."""
        from inpaint360gs.render.api import render

        out = render(self.gaussians, camera, sh_degree=0, with_features=True, backend=backend)
        ids, probs = self.classify(out.features)
        if min_alpha > 0:
            ids = torch.where(out.alpha.reshape(ids.shape) < min_alpha, torch.zeros_like(ids), ids)
        return ids, probs

    @torch.no_grad()
    def gaussian_probs(self) -> torch.Tensor:
        """(N, Q) softmax of Phi applied to each Gaussian's own feature (what removal thresholds)."""
        return self.classify(self.gaussians.features)[1]

    def class_of(self, object_id: int) -> int:
        """Classifier class index of ``object_id``; :class:`InputError` when it was not distilled."""
        if object_id not in self.object_ids:
            raise InputError(f"object id {object_id} is not one of the distilled ids {self.object_ids}", "object id")
        return self.object_ids.index(object_id)

    @staticmethod
    def load(folder: str | Path, *, device: torch.device | str = "cpu") -> "IdentityField":
        """Read a distillation output folder (``point_cloud.ply`` + ``classifier.json``, and the
        provenance record of its ``distill.json`` when there is one)."""
        folder = Path(folder)
        record = provenance.of_stage(folder, "distill")
        classifier, ids = read_classifier(folder / CLASSIFIER_JSON)
        g = read_ply(folder / MODEL_PLY, device=device)
        if g.features is None:
            raise InputError("the model has no identity features (obj_* properties): not a distillation output", folder / MODEL_PLY)
        if g.features.shape[1] != classifier.in_features:
            raise InputError(
                f"{MODEL_PLY} has {g.features.shape[1]} identity feature channels but the classifier expects {classifier.in_features}: files of two runs?",
                folder / CLASSIFIER_JSON,
            )
        return IdentityField(g, classifier.to(device), ids, record)


def classifier_dict(classifier: torch.nn.Linear, object_ids: Sequence[int]) -> dict:
    """JSON-ready dict of the linear classifier (sizes, float32 weight and bias, the object id of each class)."""
    w = classifier.weight.detach().cpu().to(torch.float32)
    b = classifier.bias.detach().cpu().to(torch.float32)
    return {
        "feature_dim": int(w.shape[1]),
        "num_classes": int(w.shape[0]),
        "object_ids": [int(i) for i in object_ids],
        "weight": w.tolist(),
        "bias": b.tolist(),
    }


def write_classifier(path: str | Path, classifier: torch.nn.Linear, object_ids: Sequence[int]) -> None:
    """Write :func:`classifier_dict` to ``path`` as JSON, atomically."""
    write_text(path, json.dumps(classifier_dict(classifier, object_ids), indent=1) + "\n")


def read_classifier(path: str | Path) -> tuple[torch.nn.Linear, list[int]]:
    """(Phi, class -> object id) from ``classifier.json``; InputError naming the file on any inconsistency."""
    path = Path(path)
    if not path.is_file():
        raise InputError("classifier.json not found", path)
    d = parse_json(path)
    try:
        w = torch.tensor(d["weight"], dtype=torch.float32)
        b = torch.tensor(d["bias"], dtype=torch.float32)
        ids = [int(i) for i in d["object_ids"]]
    except (KeyError, TypeError, ValueError) as e:
        raise InputError(f"not a classifier file ({type(e).__name__}: {e})", path) from None
    if w.ndim != 2 or b.shape != (w.shape[0],) or len(ids) != w.shape[0] or not torch.isfinite(w).all() or not torch.isfinite(b).all():
        raise InputError(f"inconsistent classifier: weight {tuple(w.shape)}, bias {tuple(b.shape)}, {len(ids)} object ids (or non-finite values)", path)
    lin = torch.nn.Linear(w.shape[1], w.shape[0])
    with torch.no_grad():
        lin.weight.copy_(w)
        lin.bias.copy_(b)
    return lin, ids
