"""Hand-made identity fields for the removal tests (paper Sec. 3.3-3.4): Gaussians whose identity
feature is a scaled one-hot vector of a known class and a classifier Phi that reads it back, so
that which object each Gaussian (and each rendered pixel) belongs to is known without training.

* :func:`labelled_field`: an :class:`IdentityField` from Gaussians and their class indices.
* :func:`write_field`: that field as a distillation output folder (``point_cloud.ply``,
  ``classifier.json`` and a ``distill.json`` recording the scene, as ``inpaint360gs distill`` writes).
* :func:`ball`: centres uniform in a ball.
* :func:`click_on`: the click at the pixel a world point projects to in a view.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path

import numpy as np
import torch

from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.distill.field import IdentityField, write_classifier
from inpaint360gs.io.ply import write_ply

STRENGTH = 8.0  # feature of a Gaussian of class c: STRENGTH * e_c -> probability of c ~ 0.999


def one_hot_features(classes: torch.Tensor, dim: int, strength: float = STRENGTH) -> torch.Tensor:
    """(N, dim) features: ``strength`` on the Gaussian's class channel; class -1: all zero (no opinion)."""
    f = torch.zeros(len(classes), dim)
    on = classes >= 0
    f[on.nonzero()[:, 0], classes[on]] = strength
    return f


def labelled_field(model: Gaussians, classes: torch.Tensor, object_ids: Sequence[int] = (0, 3, 7), dim: int = 4) -> IdentityField:
    """The field whose Gaussian i has the class ``classes[i]`` (index into ``object_ids``; -1: none).
    Phi is the identity on the first ``len(object_ids)`` channels, so a pixel's rendered id is the
    class with the largest composited weight (background 0 where nothing is rendered: ties go to class 0)."""
    q = len(object_ids)
    lin = torch.nn.Linear(dim, q)
    with torch.no_grad():
        lin.weight.copy_(torch.eye(q, dim))
        lin.bias.zero_()
    g = Gaussians(**{**model.tensors(), "features": one_hot_features(classes, dim)})
    return IdentityField(g, lin, list(object_ids))


def write_field(folder: Path, field: IdentityField, scene=None) -> Path:
    """``folder`` as ``inpaint360gs distill`` leaves it (``distill.json`` names ``scene`` when given)."""
    folder.mkdir(parents=True, exist_ok=True)
    write_ply(folder / "point_cloud.ply", field.gaussians)
    write_classifier(folder / "classifier.json", field.classifier, field.object_ids)
    inputs = {} if scene is None else {"scene": str(scene.root), "scene_content_sha256": scene.fingerprint(), "resize": scene.resize}
    report = {"stage": "distill", "inputs": inputs, "object_ids": field.object_ids, "num_gaussians": len(field.gaussians)}
    (folder / "distill.json").write_text(json.dumps(report, indent=2) + "\n")
    return folder


def ball(rng: np.random.Generator, n: int, radius: float, centre=(0.0, 0.0, 0.0)) -> np.ndarray:
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    return np.asarray(centre) + d * radius * rng.uniform(0, 1, (n, 1)) ** (1 / 3)


def points_model(points: np.ndarray, scale: float = 0.03, opacity: float = 0.9) -> Gaussians:
    """Small grey isotropic Gaussians at ``points``."""
    p = torch.tensor(points, dtype=torch.float32)
    return Gaussians.from_points(p, torch.full_like(p, 0.5), sh_degree=0, init_opacity=opacity, scales=torch.full((len(p),), scale))


def click_on(view, point):
    """The :class:`Click` at the pixel where the world ``point`` projects in ``view`` (a camera at full size)."""
    from inpaint360gs.remove.select import Click

    cam = view.camera
    R, t = cam.R.double().numpy(), cam.t.double().numpy()
    xc = R @ np.asarray(point, float) + t
    return Click(view.name, int(cam.fx * xc[0] / xc[2] + cam.cx), int(cam.fy * xc[1] / xc[2] + cam.cy))
