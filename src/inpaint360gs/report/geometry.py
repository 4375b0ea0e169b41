"""The fill's geometry at the test cameras: ``inpaint360gs evaluate --model`` (docs/guide.md, "Metrics").

Colour metrics hardly see a fill placed at the wrong depth when its texture is right, which is
what the depth-guided initialisation (paper Sec. 3.5) is for. A synthetic scene knows the true
object-free surface (``gt/depth/<stem>.npy``: z-depth per pixel, in the generator's units), so the
run's final model is rendered at each test camera (depth of the surface a pixel shows: Eq. 5's
``Σ z α T`` divided by alpha) and compared inside the unseen mask:

``roi_depth_off``: the percentage of unseen-mask pixels, over all test views, that the render
leaves empty (alpha below one half) or whose depth is off the true surface by more than
:data:`TOLERANCE` of the true depth. A scene posed by structure from motion (the realistic family)
has its cameras in the reconstruction's frame; ``gt/colmap_frame.json`` gives the scale to the
generator's units. Without ``gt/depth`` (a real capture) the value is null with the reason.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import torch

from inpaint360gs.core.errors import InputError
from inpaint360gs.io.ply import read_ply
from inpaint360gs.io.scene import Scene
from inpaint360gs.render.api import render
from inpaint360gs.views.unseen import normalised_depth

TOLERANCE = 0.05  # relative depth error beyond which a pixel's surface is off (5 %)
NO_GT_DEPTH = "no gt/depth in the scene (only synthetic scenes know the true surface)"


def _scale(scene_root: Path) -> float:
    """Generator units per scene unit (1 unless the scene's poses come from structure from motion)."""
    path = scene_root / "gt" / "colmap_frame.json"
    if not path.is_file():
        return 1.0
    try:
        scale = json.loads(path.read_text())["true_from_colmap"]["scale"]
    except (ValueError, KeyError, TypeError) as e:
        raise InputError(f"no true_from_colmap.scale ({type(e).__name__})", path) from None
    if isinstance(scale, bool) or not isinstance(scale, (int, float)) or not np.isfinite(scale) or scale <= 0:
        raise InputError(f"true_from_colmap.scale must be a positive number, got {scale!r}", path)
    return float(scale)


def depth_off(model: str | Path, scene: Scene, backend: str = "auto", tolerance: float = TOLERANCE) -> tuple[float | None, str | None]:
    """(``roi_depth_off`` in percent, None) of the model PLY ``model`` over ``scene``'s test views,
    or (None, reason) when the scene has no true depth or no unseen pixel."""
    depth_dir = Path(scene.root) / "gt" / "depth"
    views = [v for v in scene.test_views if scene.has_mask(v, "unseen_mask") and (depth_dir / f"{v.stem}.npy").is_file()]
    if not views:
        return None, NO_GT_DEPTH if not depth_dir.is_dir() else "no test view has both an unseen mask and gt/depth"
    scale = _scale(Path(scene.root))
    g = read_ply(model)
    off = total = 0
    for v in views:
        mask = scene.load_mask(v, "unseen_mask").astype(bool)
        gt = np.load(depth_dir / f"{v.stem}.npy")
        if gt.shape != mask.shape:
            raise InputError(f"true depth is {gt.shape[1]}x{gt.shape[0]}, the view {mask.shape[1]}x{mask.shape[0]} (another --resize?)",
                             depth_dir / f"{v.stem}.npy")  # fmt: skip
        with torch.no_grad():
            out = render(g, v.camera, backend=backend)
        d, a = normalised_depth(out).double().numpy() * scale, out.alpha.double().numpy()
        valid = mask & np.isfinite(gt) & (gt > 0)
        bad = (a < 0.5) | (np.abs(d - gt) > tolerance * np.where(gt > 0, gt, 1.0))
        off += int((valid & bad).sum())
        total += int(valid.sum())
    if total == 0:
        return None, "the unseen masks of the test views are empty"
    return 100.0 * off / total, None
