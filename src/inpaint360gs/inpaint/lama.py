"""LaMa (Fourier-convolution inpainting, the paper's 2D inpainter, Sec. 3.5 and supp. B) from a
user-supplied ONNX checkpoint, run with onnxruntime on the CPU.

No weights ship with the package and nothing is downloaded (docs/architecture.md, "Decisions the
paper leaves open": no learned weights by default). The checkpoint comes from an argument or from
the environment variable ``INPAINT360GS_LAMA_ONNX``.

The model contract is the common LaMa export: inputs ``image`` (1, 3, H, W) float in [0, 1] and
``mask`` (1, 1, H, W) float, 1 = hole; one output (1, 3, H, W). Handled here:

- **value range of the output**: some exports return [0, 1], others 0..255. ``output_range="auto"``
  compares the output with the input on the known pixels (a LaMa export reproduces them, up to its
  own compositing): a least-squares gain above 16 (the geometric middle of 1 and 255) means 0..255.
  ``"unit"`` / ``"byte"`` force one or the other.
- **size**: LaMa's downsampling wants sides that are multiples of 8. A model with dynamic height and
  width gets the image and the mask padded (reflect) to the next multiple of 8 and the output
  cropped back. A model exported with a fixed size gets both resized to it (image: area/linear,
  mask: any hole coverage makes a hole pixel, so no hole pixel is lost) and the output resized back.
- **the hole** is zeroed in the image fed to the model (LaMa's training input is ``img * (1 - mask)``).

:class:`LamaOnnx` returns the model's full prediction; :mod:`inpaint360gs.inpaint.inpainters` writes
back only the masked pixels.
"""

from __future__ import annotations

import functools
import os
from pathlib import Path
from typing import Literal

import cv2
import numpy as np

from inpaint360gs.core.errors import InputError

ENV_VAR = "INPAINT360GS_LAMA_ONNX"
PAD_MULTIPLE = 8
OutputRange = Literal["auto", "unit", "byte"]


def resolve_lama_path(path: str | Path | None) -> Path:
    """The checkpoint path from ``path`` or ``$INPAINT360GS_LAMA_ONNX``; InputError when neither names a file."""
    if path is None or str(path) == "":
        env = os.environ.get(ENV_VAR, "")
        if not env:
            raise InputError(f"LaMa needs an ONNX checkpoint: pass its path or set {ENV_VAR}", "lama")
        path = env
    path = Path(path).expanduser()
    if not path.is_file():
        raise InputError("LaMa ONNX checkpoint not found", path)
    return path


@functools.lru_cache(maxsize=4)
def _session(path: str, mtime_ns: int, size: int):  # noqa: ARG001  (mtime/size key the cache)
    try:
        import onnxruntime as ort
    except ImportError:
        raise InputError("the lama inpainter needs onnxruntime (pip install 'inpaint360gs[lama]')", "lama") from None
    opts = ort.SessionOptions()
    opts.log_severity_level = 3  # errors only
    try:
        sess = ort.InferenceSession(path, sess_options=opts, providers=["CPUExecutionProvider"])
    except Exception as e:  # onnxruntime raises its own pybind classes (InvalidProtobuf, Fail, ...)
        first = str(e).strip().splitlines()[0] if str(e).strip() else ""
        raise InputError(f"not a loadable ONNX model ({type(e).__name__}: {first[:200]})", path) from None
    _check_signature(sess, Path(path))
    return sess


def _fmt(arg) -> str:
    return f"{arg.name} {tuple(arg.shape)} {arg.type}"


def _check_signature(sess, path: Path) -> None:
    inputs = {a.name: a for a in sess.get_inputs()}
    outputs = sess.get_outputs()
    want = "inputs image (1,3,H,W) and mask (1,1,H,W) float, one output (1,3,H,W)"
    found = "; has inputs " + ", ".join(_fmt(a) for a in sess.get_inputs()) + " and outputs " + ", ".join(_fmt(a) for a in outputs)
    ok = set(inputs) == {"image", "mask"} and len(outputs) >= 1
    if ok:
        for name, ch in (("image", 3), ("mask", 1)):
            a = inputs[name]
            shape = a.shape
            ok &= a.type == "tensor(float)" and len(shape) == 4
            ok &= ok and (not isinstance(shape[1], int) or shape[1] == ch)
            ok &= ok and (not isinstance(shape[0], int) or shape[0] == 1)
        o = outputs[0].shape
        ok &= len(o) == 4 and (not isinstance(o[1], int) or o[1] == 3)
    if not ok:
        raise InputError(f"not a LaMa model: expected {want}{found}", path)


def _static_size(sess) -> tuple[int, int] | None:
    """(height, width) the model was exported with, or None when they are dynamic."""
    shape = next(a.shape for a in sess.get_inputs() if a.name == "image")
    h, w = shape[2], shape[3]
    if isinstance(h, int) and isinstance(w, int) and h > 0 and w > 0:
        return h, w
    return None


class LamaOnnx:
    """A LaMa ONNX checkpoint ready to run: ``LamaOnnx(path)(image, mask) -> (H, W, 3) float32``.

    ``path`` None reads ``$INPAINT360GS_LAMA_ONNX``. The session is loaded (and its inputs checked)
    here, so a bad file fails before any work; sessions are cached per file.
    """

    def __init__(self, path: str | Path | None = None, *, output_range: OutputRange = "auto"):
        if output_range not in ("auto", "unit", "byte"):
            raise InputError(f"output_range must be auto, unit or byte, got {output_range!r}", "output_range")
        self.path = resolve_lama_path(path)
        st = self.path.stat()
        self.session = _session(str(self.path), st.st_mtime_ns, st.st_size)
        self.output_range = output_range
        self.static_size = _static_size(self.session)
        self.output_name = self.session.get_outputs()[0].name

    def _run(self, image: np.ndarray, mask: np.ndarray) -> np.ndarray:
        """image (h, w, 3) float32 with the hole zeroed, mask (h, w) float32 -> raw output (h, w, 3)."""
        feed = {
            "image": np.ascontiguousarray(image.transpose(2, 0, 1)[None], dtype=np.float32),
            "mask": np.ascontiguousarray(mask[None, None], dtype=np.float32),
        }
        try:
            out = self.session.run([self.output_name], feed)[0]
        except Exception as e:
            first = str(e).strip().splitlines()[0] if str(e).strip() else ""
            raise InputError(f"LaMa model failed on a {image.shape[1]}x{image.shape[0]} input ({type(e).__name__}: {first[:200]})", self.path) from None
        out = np.asarray(out)
        if out.ndim != 4 or out.shape[0] != 1 or out.shape[1] != 3 or out.shape[2:] != image.shape[:2]:
            raise InputError(f"LaMa model returned shape {out.shape}, expected (1, 3, {image.shape[0]}, {image.shape[1]})", self.path)
        return out[0].transpose(1, 2, 0).astype(np.float32)

    def _scale(self, out: np.ndarray, image: np.ndarray, known: np.ndarray) -> float:
        if self.output_range == "unit":
            return 1.0
        if self.output_range == "byte":
            return 1.0 / 255.0
        x, y = image[known].astype(np.float64).ravel(), out[known].astype(np.float64).ravel()
        xx = float(x @ x)
        gain = float(x @ y) / xx if xx > 1e-12 else float(np.abs(out).max())
        return 1.0 / 255.0 if gain > 16.0 else 1.0

    def __call__(self, image: np.ndarray, mask: np.ndarray) -> np.ndarray:
        """LaMa's prediction for the whole frame, (H, W, 3) float32 in [0, 1].

        ``image`` (H, W, 3) float in [0, 1] (clipped), ``mask`` (H, W) bool with True = hole.
        """
        h, w = mask.shape
        img = np.clip(np.asarray(image, dtype=np.float32), 0.0, 1.0)
        img = np.where(mask[..., None], np.float32(0.0), img)
        m = mask.astype(np.float32)
        if self.static_size is not None:
            sh, sw = self.static_size
            interp = cv2.INTER_AREA if (sh <= h and sw <= w) else cv2.INTER_LINEAR
            img_s = cv2.resize(img, (sw, sh), interpolation=interp)
            m_s = (cv2.resize(m, (sw, sh), interpolation=cv2.INTER_AREA if interp == cv2.INTER_AREA else cv2.INTER_LINEAR) > 0).astype(np.float32)
            img_s = np.where(m_s[..., None] > 0, np.float32(0.0), img_s)
            out_s = self._run(img_s, m_s)
            out_s *= self._scale(out_s, img_s, m_s == 0)
            out = cv2.resize(out_s, (w, h), interpolation=cv2.INTER_LINEAR)
        else:
            ph, pw = (-h) % PAD_MULTIPLE, (-w) % PAD_MULTIPLE
            img_p = np.pad(img, ((0, ph), (0, pw), (0, 0)), mode="reflect")
            m_p = np.pad(m, ((0, ph), (0, pw)), mode="reflect")
            out_p = self._run(img_p, m_p)
            out_p *= self._scale(out_p, img_p, m_p == 0)
            out = out_p[:h, :w]
        return np.clip(out, 0.0, 1.0).astype(np.float32)
