"""From rendered radiance to the 8-bit photo a camera writes: exposure, white balance, sensor noise, JPEG.

The effects and their parameters are :class:`~dataset_tools.synth.spec.Photo`'s (all off in the
classic scenes, whose images stay ``round(255 * rgb)``). Every random draw comes from the
generator's seed and the image's name, so an image does not depend on which others are rendered.
JPEG goes through OpenCV (libjpeg): the stored PNG holds the decoded JPEG, pixel for pixel.
"""

from __future__ import annotations

import zlib
from dataclasses import dataclass

import cv2
import numpy as np

from dataset_tools.synth.spec import Photo


@dataclass(frozen=True)
class Development:
    """What :func:`develop` applied to one image (written to ``gt/photometric.json``)."""

    gain: float  # exposure gain (linear)
    white_balance: tuple[float, float, float]  # per-channel gains, green = 1
    noise: float
    shot_noise: float
    jpeg_quality: int

    def to_json(self) -> dict:
        return {"gain": round(self.gain, 6), "white_balance": [round(float(x), 6) for x in self.white_balance],
                "noise": self.noise, "shot_noise": self.shot_noise, "jpeg_quality": self.jpeg_quality}


def _rng(seed: int, name: str, stream: int) -> np.random.Generator:
    return np.random.default_rng([int(seed), zlib.crc32(name.encode()), 0x9407, stream])


def draw(photo: Photo, seed: int, name: str) -> Development:
    """The per-image gains of image ``name`` (its noise is drawn in :func:`develop`)."""
    rng = _rng(seed, name, 0)
    gain = float(2.0 ** rng.normal(0.0, photo.exposure)) if photo.exposure > 0 else 1.0
    wb = np.exp(rng.normal(0.0, photo.white_balance, 2)) if photo.white_balance > 0 else np.ones(2)
    return Development(gain, (float(wb[0]), 1.0, float(wb[1])), photo.noise, photo.shot_noise, photo.jpeg_quality)


def jpeg_round_trip(rgb8: np.ndarray, quality: int) -> np.ndarray:
    """``rgb8`` (H, W, 3) uint8 encoded as a baseline JPEG at ``quality`` and decoded again (OpenCV)."""
    ok, buf = cv2.imencode(".jpg", np.ascontiguousarray(rgb8[..., ::-1]), [cv2.IMWRITE_JPEG_QUALITY, int(quality)])
    if not ok:
        raise RuntimeError("JPEG encoding failed")
    return cv2.imdecode(buf, cv2.IMREAD_COLOR)[..., ::-1].copy()


def develop(rgb: np.ndarray, photo: Photo, seed: int, name: str) -> tuple[np.ndarray, Development]:
    """The 8-bit image (H, W, 3) a camera with ``photo``'s effects writes for radiance ``rgb`` in [0, 1]."""
    dev = draw(photo, seed, name)
    x = np.asarray(rgb, dtype=np.float64) * (dev.gain * np.asarray(dev.white_balance))
    if photo.noise > 0 or photo.shot_noise > 0:
        std = np.sqrt(photo.noise**2 + photo.shot_noise * np.clip(x, 0.0, None))
        x = x + std * _rng(seed, name, 1).standard_normal(x.shape)
    out = np.round(np.clip(x, 0.0, 1.0) * 255.0).astype(np.uint8)
    if photo.jpeg_quality > 0:
        out = jpeg_round_trip(out, photo.jpeg_quality)
    return out, dev
