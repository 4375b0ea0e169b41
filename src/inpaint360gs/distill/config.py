"""Settings of object-ID distillation (paper Sec. 3.3, supp. B "Object Feature Distillation")."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

from inpaint360gs.core.errors import InputError


@dataclass
class DistillConfig:
    """Everything that determines a distillation run (with ``seed``: same inputs, same bytes)."""

    iterations: int = 2000  # optimiser steps, >= 1 (the paper's)
    feature_dim: int = 16  # identity feature per Gaussian (the paper's 16)
    lambda_space: float = 0.0005  # weight of the 3D spatial loss, Eq. 4 (the paper's lambda)
    knn: int = 5  # neighbours per Gaussian in the spatial loss (the paper's k)
    # Gaussians the spatial loss is evaluated on per step, drawn with replacement from the loop's
    # generator (0: all of them every step). An unbiased estimate of the full mean; see distill.loss.
    knn_sample: int = 16384  # count, >= 0
    features_lr: float = 2.5e-3  # Adam lr of the features (Gaussian Grouping's obj_dc lr)
    classifier_lr: float = 5e-4  # Adam lr of the linear map Phi (Gaussian Grouping's classifier lr)
    min_weight: float = 0.0  # drop cached weights alpha*T below this (0: the exact rasterizer weights)
    backend: str = "auto"  # rasterizer whose weights are cached (render.contributions) and that renders ids
    seed: int = 0  # seeds the feature and classifier initialisation and the optimisation loop
    log_every: int = 100  # steps per row of the loss curve in distill.json

    def validate(self) -> None:
        """Raise :class:`InputError` (naming the field) for a setting out of range."""
        def bad(name: str, why: str) -> InputError:
            return InputError(f"{name} {why}, got {getattr(self, name)}", setting=f"DistillConfig.{name}")

        for name in ("iterations", "feature_dim", "knn", "log_every"):
            if int(getattr(self, name)) != getattr(self, name) or getattr(self, name) < 1:
                raise bad(name, "must be an integer >= 1")
        if int(self.knn_sample) != self.knn_sample or self.knn_sample < 0:
            raise bad("knn_sample", "must be an integer >= 0")
        for name in ("lambda_space", "min_weight"):
            if not (math.isfinite(getattr(self, name)) and getattr(self, name) >= 0):
                raise bad(name, "must be finite and >= 0")
        for name in ("features_lr", "classifier_lr"):
            if not (math.isfinite(getattr(self, name)) and getattr(self, name) > 0):
                raise bad(name, "must be finite and > 0")

    def to_dict(self) -> dict:
        """Every field, JSON-ready."""
        return dataclasses.asdict(self)
