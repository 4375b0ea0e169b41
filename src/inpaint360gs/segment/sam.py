"""The ``sam`` segmenter: SAM / HQ-SAM / MobileSAM automatic mask generation through onnxruntime,
from model files the user supplies (the paper's raw masks come from HQ-SAM, Sec. 3.2). Optional:
``pip install 'inpaint360gs[sam]'`` (onnxruntime); nothing is downloaded.

Two ONNX files:

* **image encoder**: one input, either ``(1, 3, S, S)`` — the image resized so its longest side is S,
  normalised with SAM's pixel mean and std (0–255 scale) and zero-padded at the bottom and right
  (what ``Sam.preprocess`` does) — or ``(H', W', 3)`` raw 0–255 pixels resized to longest side S,
  for encoders exported with their preprocessing inside. S comes from the file when its input shape
  is static, else from ``image_size`` (SAM's 1024). Outputs: the image embedding, plus whatever else
  the decoder takes by the same name (e.g. HQ-SAM's ``interm_embeddings``); an output named
  ``image_embeddings``, else the first, feeds the decoder's ``image_embeddings``.
* **prompt decoder**: the official ``segment-anything`` ONNX export (``SamOnnxModel``): inputs
  ``image_embeddings``, ``point_coords`` (1, P, 2) in the resized frame, ``point_labels`` (1, P),
  ``mask_input`` (1, 1, 4h, 4w), ``has_mask_input`` (1,), ``orig_im_size`` (2,) = (H, W); outputs
  ``masks`` (1, M, H, W) logits at the original size, ``iou_predictions`` (1, M), ``low_res_masks``.
  M = 4 (all mask tokens, the export's default) uses tokens 1–3 like SAM's ``multimask_output``;
  M = 1 (``--return-single-mask`` exports) uses the one.

Automatic generation follows SAM's ``SamAutomaticMaskGenerator`` (one crop layer): a
``points_per_side``² grid of single positive point prompts (each with SAM's padding point, label −1),
masks kept when their predicted IoU exceeds ``pred_iou_thresh`` and their stability score (IoU of the
masks thresholded at ±``stability_score_offset`` around ``mask_threshold``) reaches
``stability_score_thresh``; box NMS at ``box_nms_thresh`` by predicted IoU; optional removal of holes
and islands below ``min_mask_region_area`` pixels followed by NMS again. The kept masks are flattened
into one id image, smaller masks on top (:func:`.masks.flatten_masks`).
"""

from __future__ import annotations

import os
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import cv2
import numpy as np
import torch

from inpaint360gs.core.errors import InputError
from inpaint360gs.segment.base import Segmenter
from inpaint360gs.segment.masks import flatten_masks, remove_small_regions

ENV_ENCODER = "INPAINT360GS_SAM_ENCODER"
ENV_DECODER = "INPAINT360GS_SAM_DECODER"
PIXEL_MEAN = np.array([123.675, 116.28, 103.53], np.float32)
PIXEL_STD = np.array([58.395, 57.12, 57.375], np.float32)
DECODER_INPUTS = ("image_embeddings", "point_coords", "point_labels", "mask_input", "has_mask_input", "orig_im_size")


@dataclass(frozen=True)
class SamConfig:
    """Settings of SAM's automatic mask generator (its defaults) and where the model files are."""

    encoder: str | None = None  # ONNX image encoder; None = $INPAINT360GS_SAM_ENCODER
    decoder: str | None = None  # ONNX prompt decoder; None = $INPAINT360GS_SAM_DECODER
    points_per_side: int = 32
    pred_iou_thresh: float = 0.88
    stability_score_thresh: float = 0.95
    stability_score_offset: float = 1.0
    box_nms_thresh: float = 0.7
    min_mask_region_area: int = 0
    mask_threshold: float = 0.0
    image_size: int = 1024  # encoder input side when the ONNX file leaves it dynamic

    def validate(self) -> None:
        """Raise :class:`InputError` for a setting out of range."""
        if self.points_per_side < 1 or self.image_size < 1 or self.min_mask_region_area < 0:
            raise InputError("points_per_side and image_size must be >= 1, min_mask_region_area >= 0")
        for name in ("pred_iou_thresh", "stability_score_thresh", "box_nms_thresh"):
            if not 0.0 <= getattr(self, name) <= 1.0:
                raise InputError(f"{name} must be in [0, 1], got {getattr(self, name)}", setting=f"SamConfig.{name}")

    def paths(self) -> tuple[Path, Path]:
        """(encoder, decoder) from the settings or the environment; InputError when missing."""
        out = []
        for given, env, name in ((self.encoder, ENV_ENCODER, "encoder"), (self.decoder, ENV_DECODER, "decoder")):
            value = given or os.environ.get(env)
            if not value:
                raise InputError(f"the sam segmenter needs the {name} FILE.onnx (or ${env})", setting=f"SamConfig.{name}")
            p = Path(value)
            if not p.is_file():
                raise InputError("ONNX file not found", p)
            out.append(p)
        return out[0], out[1]


def point_grid(n: int) -> np.ndarray:
    """(n², 2) points (x, y) in [0, 1]², cell centres of an n × n grid, row by row."""
    c = (np.arange(n) + 0.5) / n
    xx, yy = np.meshgrid(c, c)
    return np.stack([xx.ravel(), yy.ravel()], 1)


def resized_size(h: int, w: int, side: int) -> tuple[int, int]:
    """(h', w') with the longest side ``side`` (SAM's ResizeLongestSide rounding)."""
    s = side / max(h, w)
    return int(h * s + 0.5), int(w * s + 0.5)


def box_of(mask: np.ndarray) -> np.ndarray:
    """(x0, y0, x1, y1) inclusive pixel box of a non-empty mask."""
    ys = np.flatnonzero(mask.any(1))
    xs = np.flatnonzero(mask.any(0))
    return np.array([xs[0], ys[0], xs[-1], ys[-1]], np.float64)


def box_nms(boxes: np.ndarray, order: np.ndarray, thresh: float) -> list[int]:
    """Greedy NMS: indices kept, visiting ``order`` (best first); a box is dropped when its IoU with a
    kept one exceeds ``thresh``."""
    keep: list[int] = []
    area = (boxes[:, 2] - boxes[:, 0]) * (boxes[:, 3] - boxes[:, 1])
    for i in order:
        ok = True
        for j in keep:
            iw = min(boxes[i, 2], boxes[j, 2]) - max(boxes[i, 0], boxes[j, 0])
            ih = min(boxes[i, 3], boxes[j, 3]) - max(boxes[i, 1], boxes[j, 1])
            inter = max(iw, 0.0) * max(ih, 0.0)
            union = area[i] + area[j] - inter
            if union > 0 and inter / union > thresh:
                ok = False
                break
        if ok:
            keep.append(int(i))
    return keep


def _session(path: Path):
    try:
        import onnxruntime as ort
    except ImportError:
        raise InputError("the sam segmenter needs onnxruntime (pip install 'inpaint360gs[sam]')", setting="segmenter") from None
    opts = ort.SessionOptions()
    opts.intra_op_num_threads = max(1, torch.get_num_threads())
    opts.inter_op_num_threads = 1
    try:
        return ort.InferenceSession(str(path), sess_options=opts, providers=["CPUExecutionProvider"])
    except Exception as e:  # onnxruntime raises its own exception types for unreadable graphs
        raise InputError(f"not a loadable ONNX model ({type(e).__name__}: {str(e).splitlines()[0][:200] if str(e) else ''})", path) from None


class SamSegmenter(Segmenter):
    name = "sam"

    def __init__(self, config: SamConfig | None = None, **overrides):
        cfg = config or SamConfig()
        if overrides:
            cfg = replace(cfg, **{k: v for k, v in overrides.items() if v is not None})
        cfg.validate()
        self.config = cfg
        self._enc = self._dec = None

    # --- model files --------------------------------------------------------------------------------

    def input_files(self, scene) -> list[Path]:
        """The encoder and decoder ONNX files."""
        return list(self.config.paths())

    def prepare(self, scene, model) -> None:
        """Open the SAM encoder and decoder ONNX sessions and check their inputs."""
        enc_path, dec_path = self.config.paths()
        self._enc, self._dec = _session(enc_path), _session(dec_path)
        self._enc_path, self._dec_path = enc_path, dec_path
        names = {i.name for i in self._dec.get_inputs()}
        missing = [n for n in DECODER_INPUTS if n not in names]
        if missing:
            raise InputError(f"not a SAM prompt decoder: missing inputs {missing} (expected the segment-anything ONNX export)", dec_path)
        outs = [o.name for o in self._dec.get_outputs()]
        if len(outs) < 2:
            raise InputError("not a SAM prompt decoder: expected outputs masks, iou_predictions[, low_res_masks]", dec_path)
        self._out_masks = "masks" if "masks" in outs else outs[0]
        self._out_iou = "iou_predictions" if "iou_predictions" in outs else outs[1]
        inputs = self._enc.get_inputs()
        if len(inputs) != 1 or len(inputs[0].shape) not in (3, 4):
            raise InputError("not a SAM image encoder: expected one input of shape (1, 3, S, S) or (H, W, 3)", enc_path)
        shape = inputs[0].shape
        self._enc_input = inputs[0].name
        self._nchw = len(shape) == 4
        static = [d for d in (shape[2:] if self._nchw else shape[:2]) if isinstance(d, int) and d > 0]
        self._side = max(static) if static else self.config.image_size

    # --- one image ----------------------------------------------------------------------------------

    def _encode(self, rgb8: np.ndarray) -> dict[str, np.ndarray]:
        h, w = rgb8.shape[:2]
        nh, nw = resized_size(h, w, self._side)
        img = cv2.resize(rgb8, (nw, nh), interpolation=cv2.INTER_LINEAR).astype(np.float32)
        if self._nchw:
            x = np.zeros((self._side, self._side, 3), np.float32)  # padding is 0 after normalisation
            x[:nh, :nw] = (img - PIXEL_MEAN) / PIXEL_STD
            x = x.transpose(2, 0, 1)[None]
        else:
            x = img
        names = [o.name for o in self._enc.get_outputs()]
        outs = dict(zip(names, self._enc.run(None, {self._enc_input: x})))
        if "image_embeddings" not in outs:
            outs["image_embeddings"] = outs[names[0]]
        return outs

    def decoder_feed(self, rgb8: np.ndarray) -> dict[str, np.ndarray]:
        """The decoder's inputs for one (H, W, 3) uint8 image, all but the prompt (encoder run once)."""
        if self._dec is None:
            raise RuntimeError("SamSegmenter.prepare() must run before segment()")
        h, w = rgb8.shape[:2]
        emb = self._encode(rgb8)
        feed = {i.name: emb[i.name] for i in self._dec.get_inputs() if i.name in emb}
        eh, ew = emb["image_embeddings"].shape[-2:]
        mshape = next(i.shape for i in self._dec.get_inputs() if i.name == "mask_input")
        mshape = [d if isinstance(d, int) and d > 0 else s for d, s in zip(mshape, (1, 1, 4 * eh, 4 * ew))]
        feed.update(mask_input=np.zeros(mshape, np.float32), has_mask_input=np.zeros(1, np.float32), orig_im_size=np.array([h, w], np.float32))
        return feed

    def point_logits(self, feed: dict[str, np.ndarray], x: float, y: float) -> tuple[np.ndarray, np.ndarray]:
        """Mask logits (M, H, W) and predicted IoUs (M,) for one positive point (x, y) in original
        pixels (with SAM's padding point); M = 3 multimask tokens for 4-token decoders."""
        h, w = (int(v) for v in feed["orig_im_size"])
        nh, nw = resized_size(h, w, self._side)
        feed["point_coords"] = np.array([[[x * nw / w, y * nh / h], [0.0, 0.0]]], np.float32)
        feed["point_labels"] = np.array([[1.0, -1.0]], np.float32)
        logits, iou = self._dec.run([self._out_masks, self._out_iou], feed)
        logits, iou = logits[0], iou[0]
        if logits.shape[0] == 4:  # all mask tokens: SAM's multimask output is tokens 1..3
            logits, iou = logits[1:], iou[1:]
        return logits, iou

    def generate(self, rgb8: np.ndarray) -> list[np.ndarray]:
        """SAM's automatic masks of one (H, W, 3) uint8 image: boolean masks, kept ones only."""
        cfg = self.config
        h, w = rgb8.shape[:2]
        feed = self.decoder_feed(rgb8)
        masks, ious = [], []
        for x, y in point_grid(cfg.points_per_side) * [w, h]:
            logits, iou = self.point_logits(feed, x, y)
            for lg, q in zip(logits, iou):
                if q <= cfg.pred_iou_thresh:
                    continue
                hi = (lg > cfg.mask_threshold + cfg.stability_score_offset).sum()
                lo = (lg > cfg.mask_threshold - cfg.stability_score_offset).sum()
                if (hi / lo if lo else 0.0) < cfg.stability_score_thresh:
                    continue
                m = lg > cfg.mask_threshold
                if m.any():
                    masks.append(m)
                    ious.append(float(q))
        if not masks:
            return []
        boxes = np.stack([box_of(m) for m in masks])
        keep = box_nms(boxes, np.argsort(-np.asarray(ious), kind="stable"), cfg.box_nms_thresh)
        masks = [masks[i] for i in keep]
        if cfg.min_mask_region_area > 0:
            cleaned = [remove_small_regions(m, cfg.min_mask_region_area) for m in masks]
            masks = [m for m, _ in cleaned if m.any()]
            unchanged = np.array([not c for m, c in cleaned if m.any()], np.float64)
            if masks:
                boxes = np.stack([box_of(m) for m in masks])
                keep = box_nms(boxes, np.argsort(-unchanged, kind="stable"), cfg.box_nms_thresh)
                masks = [masks[i] for i in keep]
        return masks

    def segment(self, view, image: torch.Tensor) -> np.ndarray:
        """(H, W) uint16 id image of SAM's automatic masks of ``image``."""
        rgb8 = (image.clamp(0, 1) * 255 + 0.5).to(torch.uint8).numpy()
        masks = self.generate(rgb8)
        if not masks:
            return np.zeros(rgb8.shape[:2], np.uint16)
        return flatten_masks(masks)

    def settings(self) -> dict:
        """The configuration, plus the model files once prepared."""
        d = asdict(self.config)
        if self._dec is not None:
            d.update(encoder=str(self._enc_path), decoder=str(self._dec_path), encoder_input_side=self._side)
        return d
