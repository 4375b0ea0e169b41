"""The ``oracle`` segmenter: ground-truth instance masks with SAM-like damage (synthetic scenes only).

It exists to measure the later stages (association, distillation, removal) apart from the segmenter,
with masks that look like an automatic segmenter's rather than perfect ones. A method stage normally
must not read ``gt/`` (docs/architecture.md, "Scene format"); this one does **by design**, is never a
default, and everything it produces says so (segment.json: ``"segmenter": "oracle"``,
``"reads_ground_truth": true``), so tables can label its rows.

Per training view it reads ``SCENE/gt/instance/<stem>.png`` (uint8 object id per pixel, 0 =
background) and applies, with a generator seeded by ``seed`` and the view's name (same inputs, same
output):

* **missed small parts**: an object's connected components smaller than ``min_part_px`` vanish;
* **eroded / dilated edges**: each object's mask grows or shrinks by up to ``edge_px`` pixels, and
  by at most ``edge_rel`` × its equivalent radius (√(area/π), at least 1 px), so small objects are not
  wiped out; an erosion never takes more than a disk eroded by ``edge_rel`` × its radius loses,
  1 − (1 − ``edge_rel``)² ≈ 28% of the pixels (thin objects lose a band along their whole outline: the
  radius shrinks until the share holds, else the mask is left as it was);
* **merges**: with probability ``merge_prob`` per view, two touching objects become one segment;
* **splits**: with probability ``split_prob`` each object is cut in two along a random line through
  a point near its centre (both sides must keep ``min_part_px``);
* **shuffled ids**: segments are numbered in a random order per view.

Masks are composed larger first, smaller on top (as :func:`.masks.flatten_masks`), so a dilated small
object overlaps a large neighbour rather than vanishing under it.
"""

from __future__ import annotations

import zlib
from dataclasses import asdict, dataclass, replace
from pathlib import Path

import cv2
import numpy as np
import torch

from inpaint360gs.core.errors import InputError
from inpaint360gs.core.files import inside
from inpaint360gs.core.layout import GT_DIR
from inpaint360gs.io.images import read_mask, resize_mask
from inpaint360gs.segment.base import Segmenter
from inpaint360gs.segment.masks import components, flatten_masks

INSTANCE_DIR = "instance"


@dataclass(frozen=True)
class OracleConfig:
    seed: int = 0
    split_prob: float = 0.15  # per object and view
    merge_prob: float = 0.15  # per view: one pair of touching objects merged
    edge_px: int = 2  # edges move by up to this many pixels (erosion or dilation) ...
    edge_rel: float = 0.15  # ... and by at most this fraction of the object's equivalent radius (>= 1 px)
    min_part_px: int = 0  # components below this vanish; 0 = 2e-4 of the image (>= 4 px)

    def validate(self) -> None:
        """Raise :class:`InputError` (naming the field) for a setting out of range."""
        for name in ("split_prob", "merge_prob"):
            v = getattr(self, name)
            if not 0.0 <= v <= 1.0:
                raise InputError(f"{name} must be in [0, 1], got {v}", setting=f"OracleConfig.{name}")
        if self.edge_px < 0 or self.min_part_px < 0 or self.seed < 0 or self.edge_rel < 0:
            raise InputError("edge_px, edge_rel, min_part_px and seed must be >= 0")


def _disk(r: int) -> np.ndarray:
    return cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * r + 1, 2 * r + 1))


def _touching(a: np.ndarray, b: np.ndarray) -> bool:
    return bool((cv2.dilate(a.astype(np.uint8), _disk(1)).astype(bool) & b).any())


def _erode(mask: np.ndarray, r: int, keep_share: float, min_px: int) -> np.ndarray:
    """``mask`` eroded by the largest radius <= ``r`` that keeps ``keep_share`` of its pixels (and at
    least ``min_px``), or unchanged. A thin object loses a band of about its perimeter times the
    radius, so a radius scaled by its equivalent radius alone could take most of it (a banana, a
    stool's legs); the share keeps every shape to the loss of a disk eroded by ``edge_rel`` x its radius."""
    area = int(mask.sum())
    for k in range(r, 0, -1):
        e = cv2.erode(mask.astype(np.uint8), _disk(k)).astype(bool)
        n = int(e.sum())
        if n >= keep_share * area and n >= min_px:
            return e
    return mask


def _split(mask: np.ndarray, rng: np.random.Generator, min_px: int) -> list[np.ndarray]:
    """The mask cut in two by a random line through a point near its centroid (or whole)."""
    ys, xs = np.nonzero(mask)
    cy, cx = ys.mean(), xs.mean()
    spread = 0.25 * np.array([ys.std(), xs.std()])
    py, px = cy + rng.normal() * spread[0], cx + rng.normal() * spread[1]
    a = rng.uniform(0, np.pi)
    side = (xs - px) * np.sin(a) - (ys - py) * np.cos(a) > 0
    if side.sum() < min_px or (~side).sum() < min_px:
        return [mask]
    one = np.zeros_like(mask)
    one[ys[side], xs[side]] = True
    return [one, mask & ~one]


def damage(instance: np.ndarray, cfg: OracleConfig, rng: np.random.Generator) -> np.ndarray:
    """SAM-like damage of a ground-truth instance image (see the module docstring); (H, W) uint16."""
    h, w = instance.shape
    min_px = cfg.min_part_px or max(4, round(2e-4 * h * w))
    objects = []
    for oid in np.unique(instance[instance > 0]):
        m = instance == oid
        n, cc, area = components(m)
        keep = np.flatnonzero(area >= min_px) + 1
        m = np.isin(cc, keep)  # missed small parts
        if not m.any():
            continue
        top = min(cfg.edge_px, max(1, round(cfg.edge_rel * np.sqrt(m.sum() / np.pi))))
        r = int(rng.integers(-top, top + 1)) if cfg.edge_px else 0
        if r > 0:
            m = cv2.dilate(m.astype(np.uint8), _disk(r)).astype(bool)
        elif r < 0:
            m = _erode(m, -r, (1.0 - cfg.edge_rel) ** 2, min_px)
        objects.append(m)
    if len(objects) >= 2 and rng.random() < cfg.merge_prob:
        pairs = [(i, j) for i in range(len(objects)) for j in range(i + 1, len(objects)) if _touching(objects[i], objects[j])]
        if pairs:
            i, j = pairs[int(rng.integers(len(pairs)))]
            objects[i] = objects[i] | objects[j]
            del objects[j]
    segments = []
    for m in objects:
        segments += _split(m, rng, min_px) if rng.random() < cfg.split_prob else [m]
    if not segments:
        return np.zeros((h, w), np.uint16)
    ids = flatten_masks(segments, min_area=min_px)
    n = int(ids.max())
    lut = np.zeros(n + 1, np.uint16)
    lut[1:] = rng.permutation(n) + 1  # shuffled ids
    return lut[ids]


class OracleSegmenter(Segmenter):
    name = "oracle"
    reads_ground_truth = True

    def __init__(self, config: OracleConfig | None = None, *, seed: int | None = None):
        cfg = config or OracleConfig()
        if seed is not None:
            cfg = replace(cfg, seed=seed)
        cfg.validate()
        self.config = cfg
        self._files: dict[str, Path] = {}

    def input_files(self, scene) -> list[Path]:
        """Each training view's ground-truth instance mask ``gt/instance/<stem>.png``, inside the scene."""
        folder = inside(scene.root, f"{GT_DIR}/{INSTANCE_DIR}")
        if not folder.is_dir():
            raise InputError(f"the oracle segmenter needs ground-truth instance masks ({GT_DIR}/{INSTANCE_DIR}/, synthetic scenes only)", folder)
        return [inside(scene.root, f"{GT_DIR}/{INSTANCE_DIR}/{v.stem}.png") for v in scene.train_views]

    def prepare(self, scene, model) -> None:
        """Find each training view's ground-truth instance mask; :class:`InputError` when one is missing."""
        for v, p in zip(scene.train_views, self.input_files(scene)):
            m = read_mask(p)  # decodes: a corrupt file fails here, before any output
            cam = v.camera  # the mask is at full size (downscaled by the scene's factor) or at the view's size
            if (round(m.shape[0] / scene.resize), round(m.shape[1] / scene.resize)) != (cam.height, cam.width) and m.shape != (cam.height, cam.width):
                raise InputError(f"instance mask is {m.shape[1]}x{m.shape[0]} but view {v.name} is {cam.width}x{cam.height}", p)
            self._files[v.name] = p

    def segment(self, view, image: torch.Tensor) -> np.ndarray:
        """The view's ground-truth instance mask, damaged as configured (seeded per view)."""
        if view.name not in self._files:
            raise RuntimeError("OracleSegmenter.prepare() must run before segment()")
        gt = resize_mask(read_mask(self._files[view.name]), view.camera.width, view.camera.height)  # nearest: no new ids
        rng = np.random.default_rng([self.config.seed, zlib.crc32(view.name.encode())])
        return damage(gt, self.config, rng)

    def settings(self) -> dict:
        """The configuration, as a dict."""
        return asdict(self.config)
