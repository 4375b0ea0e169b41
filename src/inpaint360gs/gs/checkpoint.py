"""Atomic training checkpoints: everything needed to continue a run bit-for-bit.

A checkpoint holds the parameters, every Adam state, the densification state, the next step, the
random generators' states, the camera-order state, the log rows so far and the config it was made
with. It is written to a temporary file and renamed, so the previous one survives any crash.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import torch

from inpaint360gs.core.errors import InputError
from inpaint360gs.io.atomic import atomic_path

CHECKPOINT_NAME = "checkpoint.pt"
FORMAT_VERSION = 2  # 2: the optimisation state lives under "loop"


def save_checkpoint(path: str | Path, payload: dict[str, Any]) -> None:
    """Write ``payload`` (tensors, dicts, lists, numbers, strings) atomically."""
    with atomic_path(path) as tmp:
        torch.save({"format_version": FORMAT_VERSION, **payload}, tmp)


def load_checkpoint(path: str | Path) -> dict[str, Any]:
    """Read a checkpoint written by :func:`save_checkpoint` (tensors only: ``weights_only``)."""
    path = Path(path)
    if not path.is_file():
        raise InputError("no checkpoint to resume from", path)
    try:
        data = torch.load(path, map_location="cpu", weights_only=True)
    except Exception as e:  # truncated/corrupt file: zip or unpickling errors of several kinds
        raise InputError(f"cannot read checkpoint ({e.__class__.__name__})", path) from None
    if not isinstance(data, dict) or data.get("format_version") != FORMAT_VERSION:
        raise InputError("not a checkpoint of this version of inpaint360gs", path)
    return data
