"""Feature images of one fixed set of Gaussians whose features change between renders, with each
view's projection done once (the removal's fill masks and silhouette test: the same Gaussians,
another 0/1 feature per selection; README "Viewer").

:func:`inpaint360gs.render.api.render` projects, shades and bins every Gaussian into tiles on each
call; only the last step, compositing, reads the features. :class:`FeatureRenders` keeps, per view,
what the numba backend composites (the packed splats, their tile lists, the colour and depth
channels) and composites new features over it: the same kernel on the same inputs, so the features
are bit for bit those of ``render(..., with_features=True).features``; only over the tiles where a
Gaussian with a nonzero feature lies (elsewhere they are 0, as the kernel composites them there: a
selection's masks cost the tiles it covers). Other backends (torch, gsplat) render in full each time."""

from __future__ import annotations

import threading

import numpy as np
import torch

from inpaint360gs.core.camera import Camera
from inpaint360gs.core.gaussians import Gaussians
from inpaint360gs.render.tiles import TILE

NEAR, FAR, EPS2D = 0.01, 1e10, 0.3  # render()'s defaults


class FeatureRenders:
    """``features(key, camera, feats)``: (H, W, F) composited ``feats`` (N, F) of ``gaussians`` at
    ``camera``, the view's projection cached under ``key`` (a view's name; one camera per key).
    Thread-safe (the viewer fills it in a background thread while a click may use it)."""

    def __init__(self, gaussians: Gaussians, backend: str = "auto"):
        from inpaint360gs.render.backends import resolve_backend

        self.gaussians = gaussians
        self.backend = backend
        self._numba = resolve_backend(backend, gaussians.means.device, gaussians.means.dtype).name == "numba"
        self._views: dict[str, tuple] = {}
        self._locks: dict[str, threading.Lock] = {}
        self._guard = threading.Lock()

    def holds(self, key: str) -> bool:
        return key in self._views

    @torch.no_grad()
    def prepare(self, key: str, camera: Camera) -> None:
        """Project and bin the Gaussians for ``camera`` under ``key`` (once; the first call's camera)."""
        if not self._numba or key in self._views:
            return
        with self._guard:
            lock = self._locks.setdefault(key, threading.Lock())
        with lock:
            if key in self._views:
                return
            from inpaint360gs.render.backends import resolve_backend
            from inpaint360gs.render.numba_arrays import to_f32
            from inpaint360gs.render.numba_backend import prepare

            g = self.gaussians
            dev, dt = g.means.device, g.means.dtype
            rasterizer = resolve_backend(self.backend, dev, dt)
            cam = camera.to(device=dev, dtype=dt)
            degree = g.sh_degree
            sh = torch.cat([g.sh0, g.shN[:, : (degree + 1) ** 2 - 1]], dim=1)
            means2d, conics, depths, radii, rgb = rasterizer.project_and_shade(g, sh, cam, degree, near=NEAR, far=FAR, eps2d=EPS2D)
            packed = prepare(means2d, conics, torch.sigmoid(g.opacity_logits), radii, depths, cam.width, cam.height)
            base = to_f32(torch.cat([rgb, depths[:, None]], dim=-1))
            self._views[key] = (packed, base, cam.width, cam.height)

    @staticmethod
    def _tiles_near(near, margin: int, width: int, height: int, tiles_x: int, n_tiles: int) -> np.ndarray:
        """(n_tiles,) bool: the tiles within ``margin`` (< TILE) pixels of the pixels ``near``."""
        x, y = (np.asarray(a, np.int64) for a in near)
        out = np.zeros(n_tiles, bool)
        xs = [np.clip(x - margin, 0, width - 1) // TILE, np.clip(x + margin, 0, width - 1) // TILE]
        ys = [np.clip(y - margin, 0, height - 1) // TILE, np.clip(y + margin, 0, height - 1) // TILE]
        for tx in xs:  # a square of side 2 margin + 1 < TILE spans at most two tiles each way
            for ty in ys:
                out[ty * tiles_x + tx] = True
        return out

    @torch.no_grad()
    def features(self, key: str, camera: Camera, feats: torch.Tensor, *, near=None, margin: int = 0) -> torch.Tensor:
        """(H, W, F) float features ``feats`` (N, F) composited at ``camera`` (Eq. 2), as
        ``render(g, camera, with_features=True).features`` with ``g.features = feats``. ``near``:
        (x, y) pixel arrays; when given, only the pixels within ``margin`` (< 16) of them are wanted
        (the tiles holding none are left 0)."""
        if not self._numba:
            from inpaint360gs.render.api import render

            g = self.gaussians.map(lambda t: t)
            g.features = feats
            return render(g, camera, with_features=True, backend=self.backend).features
        import numba

        from inpaint360gs.render import numba_kernels as K
        from inpaint360gs.render.numba_arrays import set_numba_threads, to_f32

        self.prepare(key, camera)
        (pk, offsets, gids, order, tiles_x), base, width, height = self._views[key]
        f = to_f32(feats.to(self.gaussians.means.dtype))
        # a tile none of whose Gaussians has a nonzero feature composites 0 (+0.0) everywhere, the
        # kernel's own answer there: only the tiles holding one are composited (all their Gaussians)
        holds = (f != 0).any(axis=1)[gids]
        touched = np.zeros(len(offsets) - 1, bool)
        last = np.full(len(offsets) - 1, -1, np.int64)  # per tile: the list position of its last Gaussian with a nonzero feature
        busy = np.flatnonzero(np.diff(offsets) > 0)
        if len(busy):
            last[busy] = np.maximum.reduceat(np.where(holds, np.arange(len(gids)), -1), offsets[busy])
            touched[busy] = last[busy] >= offsets[busy]
        if near is not None and margin < TILE:
            touched &= self._tiles_near(near, margin, width, height, tiles_x, len(touched))
        order = order[touched[order]]
        # behind a tile's last Gaussian with a nonzero feature, each one adds weight * 0 = +0 to the
        # features: each touched tile's list is cut there (the same bits; what lies behind an object,
        # most of a tile's list, is not composited)
        lengths = np.where(touched, last - offsets[:-1] + 1, 0)
        cut = np.zeros(len(offsets), offsets.dtype)
        np.cumsum(lengths, out=cut[1:])
        starts = np.repeat(offsets[:-1] - cut[:-1], lengths)  # cut position -> its position in gids
        gids = gids[starts + np.arange(int(cut[-1]))]
        offsets = cut
        # the weights a pixel gives each Gaussian do not depend on the channels, and fewer than four
        # channels are each accumulated by the kernel's one-channel loop, as render() accumulates the
        # channels after its colour and depth: the features alone give the same bits (a fill mask's
        # one channel composites in a fraction of the time of five)
        lead = 0 if f.shape[1] < 4 else base.shape[1]
        channels = np.ascontiguousarray(f if lead == 0 else np.concatenate([base, f], axis=1))
        set_numba_threads()
        img, _, _, _ = K.forward(pk, channels, offsets, gids, order, numba.get_num_threads(), width, height, tiles_x)
        return torch.from_numpy(img[..., lead:].copy()).to(self.gaussians.means.dtype)
