"""3DGS through the shared optimisation loop is bit-identical to the trainer it replaced.

The reference hash was produced by the 3DGS trainer as it was before training moved onto
:class:`inpaint360gs.gs.loop.OptimizationLoop`, with the same rasterizer kernels, scene builder,
config and seed. Any change in the order of random draws, floating-point operations or
densification edits changes it (so does a change of the kernels' rounding: then the reference must
be remade with the old trainer and the new kernels).
"""

from __future__ import annotations

import hashlib

import numpy as np
import pytest
import torch
from scene_builder import orbit_cameras, write_png

from inpaint360gs.core.gaussians import SH_C0, Gaussians
from inpaint360gs.gs.config import DensifyConfig, TrainConfig
from inpaint360gs.gs.trainer import train
from inpaint360gs.io.colmap import write_model
from inpaint360gs.io.scene import load_scene
from inpaint360gs.render.api import render

REFERENCE = {
    # backend: (Gaussians after 200 steps, sha256 of point_cloud.ply)
    "numba": (1418, "3047edf857816899cc8baef795acdee6720eb2c36850cdfc1fba69476798929f"),
}


def _sphere_scene(root):
    W, H = 48, 36
    g = torch.Generator().manual_seed(1)
    d = torch.randn(300, 3, generator=g)
    pts = d / d.norm(dim=1, keepdim=True)
    colors = 0.5 + 0.45 * torch.sin(3 * pts + torch.tensor([0.0, 2.0, 4.0]))
    model = Gaussians.from_points(pts, colors, sh_degree=3, init_opacity=0.95)
    cams = orbit_cameras(12, width=W, h=H, f=40.0, radius=3.5) + orbit_cameras(2, width=W, h=H, f=40.0, radius=3.5, prefix="test_", phase=0.2)
    for c in cams:
        with torch.no_grad():
            write_png(root / "images" / c.name, render(model, c, backend="torch").color)
    rng = np.random.default_rng(0)
    p = model.means.numpy()[::3] + rng.normal(0, 0.05, size=(100, 3))
    rgb = (model.sh0[::3, 0] * SH_C0 + 0.5).clamp(0, 1).numpy()
    write_model(root / "sparse" / "0", cams, p, rgb, shared_camera=False)
    return root


@pytest.mark.parametrize("backend", sorted(REFERENCE))
def test_3dgs_ply_bytes_match_the_reference(tmp_path, backend):
    torch.set_num_threads(2)
    scene = load_scene(_sphere_scene(tmp_path / "sphere"))
    n = 200
    dens = DensifyConfig(densify_from=20, densify_until=n - 20, densify_every=40, opacity_reset_every=100)
    cfg = TrainConfig(iterations=n, sh_degree_interval=40, means_lr_max_steps=n, densify=dens, log_every=10, checkpoint_every=0, backend=backend)
    res = train(scene, cfg, tmp_path / "run")
    digest = hashlib.sha256((tmp_path / "run" / "point_cloud.ply").read_bytes()).hexdigest()
    assert (len(res.gaussians), digest) == REFERENCE[backend]
