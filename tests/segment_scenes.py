"""Tiny hand-built Gaussian scenes for the segment tests: a textured ground plane, objects above it,
orbit cameras (``scene_builder.orbit_cameras``), and the true object of every Gaussian."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import torch
from scene_builder import orbit_cameras, write_model, write_png

from inpaint360gs.core.gaussians import SH_C0, Gaussians

W, H, F = 64, 48, 56.0


def _gaussians(points: np.ndarray, colors: np.ndarray, scales: np.ndarray, opacity: float) -> Gaussians:
    n = len(points)
    return Gaussians(
        means=torch.tensor(points, dtype=torch.float32),
        log_scales=torch.log(torch.tensor(scales, dtype=torch.float32)),
        quats=torch.tensor([[1.0, 0.0, 0.0, 0.0]]).repeat(n, 1),
        opacity_logits=torch.logit(torch.full((n,), opacity)),
        sh0=((torch.tensor(colors, dtype=torch.float32) - 0.5) / SH_C0).reshape(n, 1, 3),
        shN=torch.zeros(n, 0, 3),
    )


def ground(rng: np.random.Generator, half: float = 2.5, step: float = 0.06, z: float = 0.0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    g = np.arange(-half, half + 1e-9, step)
    xx, yy = np.meshgrid(g, g)
    p = np.stack([xx.ravel(), yy.ravel(), np.full(xx.size, z)], 1) + rng.normal(0, 0.002, (xx.size, 3))
    checker = ((np.floor(xx.ravel() / 0.3) + np.floor(yy.ravel() / 0.3)) % 2)[:, None]
    c = 0.35 + 0.3 * checker + rng.uniform(-0.05, 0.05, (xx.size, 3))
    s = np.tile([step * 0.7, step * 0.7, 0.005], (xx.size, 1))
    return p, c, s


def blob(rng: np.random.Generator, centre, radius: float, color, n: int = 350) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    d = rng.normal(size=(n, 3))
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    p = np.asarray(centre) + d * radius * rng.uniform(0.6, 1.0, (n, 1)) ** (1 / 3)
    c = np.clip(np.asarray(color) + rng.uniform(-0.05, 0.05, (n, 3)), 0, 1)
    return p, c, np.full((n, 3), 0.035 * radius / 0.2)


def disc(rng: np.random.Generator, centre, radius: float, color, step: float = 0.03) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    g = np.arange(-radius, radius + 1e-9, step)
    xx, yy = np.meshgrid(g, g)
    keep = xx**2 + yy**2 <= radius**2
    p = np.stack([xx[keep], yy[keep], np.zeros(keep.sum())], 1) + np.asarray(centre)
    c = np.clip(np.asarray(color) + rng.uniform(-0.05, 0.05, (len(p), 3)), 0, 1)
    return p, c, np.tile([step * 0.8, step * 0.8, 0.006], (len(p), 1))


def build(parts: list[tuple[np.ndarray, np.ndarray, np.ndarray]]) -> tuple[Gaussians, np.ndarray]:
    """One model from parts (part 0 = background); returns it and the part index of every Gaussian."""
    p = np.concatenate([q[0] for q in parts])
    c = np.concatenate([q[1] for q in parts])
    s = np.concatenate([q[2] for q in parts])
    owner = np.concatenate([np.full(len(q[0]), k) for k, q in enumerate(parts)])
    return _gaussians(p, c, s, 0.95), owner


def two_blobs(seed: int = 0) -> tuple[Gaussians, np.ndarray]:
    """Ground plane + two equal blobs (owners 1 and 2) standing apart on it."""
    rng = np.random.default_rng(seed)
    return build([ground(rng), blob(rng, (0.55, 0.0, 0.25), 0.2, (0.9, 0.2, 0.1)), blob(rng, (-0.55, 0.15, 0.25), 0.2, (0.1, 0.3, 0.9))])


def plate_scene(seed: int = 0) -> tuple[Gaussians, np.ndarray]:
    """Ground + a plate (owner 1, a thin disc lifted above the ground) carrying two blobs (owners 2, 3)."""
    rng = np.random.default_rng(seed)
    return build([
        ground(rng),
        disc(rng, (0.0, 0.0, 0.08), 0.5, (0.9, 0.9, 0.85)),
        blob(rng, (0.25, 0.0, 0.2), 0.12, (0.9, 0.2, 0.1), n=300),
        blob(rng, (-0.22, 0.1, 0.2), 0.12, (0.1, 0.7, 0.2), n=300),
    ])  # fmt: skip


def cameras(n: int = 12, prefix: str = "IMG_", phase: float = 0.0):
    """Orbit cameras (radius 3, 1.6 above the ground) looking at the origin: orbit radius R = 3."""
    return orbit_cameras(n, radius=3.0, height=1.6, width=W, h=H, f=F, prefix=prefix, phase=phase)


@torch.no_grad()
def true_labels(model: Gaussians, owner: np.ndarray, camera) -> np.ndarray:
    """(H, W) true object of every pixel: the owner part with the largest rendered weight, where it
    covers at least half of the pixel's alpha (0 = background part)."""
    from inpaint360gs.render.api import render

    k = int(owner.max())
    feats = torch.zeros(len(owner), k + 1)
    feats[torch.arange(len(owner)), torch.from_numpy(owner)] = 1.0
    out = render(Gaussians(**{**model.tensors(), "features": feats}), camera, with_features=True)
    w = out.features.numpy()
    best = w.argmax(2)
    ok = np.take_along_axis(w, best[..., None], 2)[..., 0] >= 0.5 * out.alpha.numpy()
    return np.where(ok, best, 0)


@torch.no_grad()
def write_scene(root: Path, model: Gaussians, n_train: int = 14) -> Path:
    """A scene folder whose images are renders of ``model`` (cameras.n_train IMG_* views, 2 test_ views)."""
    from inpaint360gs.render.api import render

    cams = cameras(n_train) + cameras(2, prefix="test_", phase=0.3)
    for c in cams:
        write_png(root / "images" / c.name, render(model, c).color.clamp(0, 1))
    pts = model.means.numpy()[:: max(1, len(model) // 300)]
    write_model(root / "sparse" / "0", cams, pts, np.full((len(pts), 3), 128, np.uint8))
    return root


def iou(a: np.ndarray, b: np.ndarray) -> float:
    u = (a | b).sum()
    return float((a & b).sum() / u) if u else 0.0


def best_iou(ids: np.ndarray, target: np.ndarray) -> float:
    """Best IoU between ``target`` (bool) and any segment of the id image."""
    return max((iou(ids == s, target) for s in np.unique(ids[ids > 0])), default=0.0)


__all__ = ["H", "W", "best_iou", "build", "cameras", "iou", "plate_scene", "true_labels", "two_blobs", "write_scene"]
