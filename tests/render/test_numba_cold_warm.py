"""A training run that compiles the numba kernels (empty cache) equals one that loads them from the cache,
and so do the contribution lists computed from its result (the distillation's rendering).

Regression test: the run that compiled the kernels used to differ at float-rounding level from every
later run, from the first rendered image on. Numba compiles each jitted helper a kernel calls as its own
library, loaded into the process, and links a copy of it into the caller that LLVM optimises again;
the JIT then binds the caller's calls to the first definition loaded. With fastmath the two copies
round differently, so the compiling process ran the helpers' own code and a process that loaded the
cached kernel ran the caller's copies. See the module docstring of ``render/numba_kernels.py``.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import torch
from scene_builder import orbit_cameras, write_model, write_png

import inpaint360gs
from inpaint360gs.core.gaussians import SH_C0, Gaussians

pytest.importorskip("numba")
pytestmark = pytest.mark.slow  # ~1.5 min on 2 cores: one process compiles the kernels (~30-60 s), one loads them

W, H = 48, 36
ITERATIONS = 200


def _scene(root: Path) -> Path:
    """A coloured sphere of Gaussians seen from 12 orbit views (rendered with the torch backend, so this
    process compiles nothing) and a noisy subset of it as the sparse points."""
    from inpaint360gs.render.api import render

    g = torch.Generator().manual_seed(1)
    d = torch.randn(300, 3, generator=g)
    pts = d / d.norm(dim=1, keepdim=True)
    model = Gaussians.from_points(pts, 0.5 + 0.45 * torch.sin(3 * pts + torch.tensor([0.0, 2.0, 4.0])), sh_degree=3, init_opacity=0.95)
    cams = orbit_cameras(12, width=W, h=H, f=40.0, radius=3.5) + orbit_cameras(2, width=W, h=H, f=40.0, radius=3.5, prefix="test_", phase=0.2)
    for c in cams:
        with torch.no_grad():
            write_png(root / "images" / c.name, render(model, c, backend="torch").color)
    rng = np.random.default_rng(0)
    sparse = model.means.numpy()[::3] + rng.normal(0, 0.05, size=(100, 3))
    write_model(root / "sparse" / "0", cams, sparse, (model.sh0[::3, 0] * SH_C0 + 0.5).clamp(0, 1).numpy())
    return root


# Runs `inpaint360gs train ARGS...`, then writes to REPORT the functions with rounding-changing fast-math
# instructions (reassoc, contract, arcp, afn) that a kernel compiled in this process carries as a linked
# (non-external) copy: the copies the JIT may or may not call, depending on what it loaded before.
# Only a compiling process has the kernels' LLVM IR; one that loaded them from the cache reports nothing.
_DRIVER = r"""
import re, sys
import numba
from llvmlite.binding import Linkage
from inpaint360gs.cli import main
from inpaint360gs.render import numba_contrib, numba_kernels, numba_projection

report, args = sys.argv[1], sys.argv[2:]
rc = main(["train", *args])
if rc == 0:  # the contribution lists (what the distillation renders identity features through) of the result
    import numpy as np
    from inpaint360gs.io.ply import read_ply
    from inpaint360gs.io.scene import load_scene
    from inpaint360gs.render.contributions import contributions
    c = contributions(read_ply(args[1] + "/point_cloud.ply"), load_scene(args[0]).train_views[0].camera, backend="numba")
    np.savez(args[1] + "/contributions.npz", indptr=c.indptr.numpy(), cols=c.cols.numpy(), vals=c.vals.numpy())
rounding = re.compile(r"= (?:tail |notail )?(?:fadd|fsub|fmul|fdiv|frem|call) (?:[a-z]+ )*?(?:reassoc|contract|arcp|afn|fast)\b")
lines = []
for mod in (numba_kernels, numba_projection, numba_contrib):
    for name, disp in sorted(vars(mod).items()):
        if isinstance(disp, numba.core.registry.CPUDispatcher):
            for cres in disp.overloads.values():
                for fn in cres.library._final_module.functions:
                    if not fn.is_declaration:
                        external = fn.linkage == Linkage.external
                        kind = "defines" if external else "LINKED-FASTMATH-COPY" if rounding.search(str(fn)) else "linked"
                        lines.append(f"{kind} {name}: {fn.name[:100]}")
open(report, "w").write("\n".join(lines))
sys.exit(rc)
"""


def _train(scene: Path, out: Path, cache: Path) -> list[str]:
    """Train in a fresh process whose numba cache is ``cache`` (the code under test, not an installed copy);
    returns the driver's report lines."""
    src = str(Path(inpaint360gs.__file__).resolve().parents[1])
    env = dict(os.environ, NUMBA_CACHE_DIR=str(cache), PYTHONPATH=os.pathsep.join([src, os.environ.get("PYTHONPATH", "")]))
    report = out.with_suffix(".kernels.txt")
    args = [
        str(scene), str(out), "--iterations", str(ITERATIONS), "--schedule-scale", "0.05",
        "--backend", "numba", "--threads", "2", "--checkpoint-every", "0", "--no-progress",
    ]  # fmt: skip
    # schedule 0.05: SH degree up every 50 steps, densification at step 100, opacity reset at step 150
    res = subprocess.run([sys.executable, "-c", _DRIVER, str(report), *args], env=env, capture_output=True, text=True, timeout=900)
    assert res.returncode == 0, res.stdout + res.stderr
    return report.read_text().splitlines()


def _listing(folder: Path) -> dict[str, tuple[int, int]]:
    return {str(p.relative_to(folder)): (p.stat().st_size, p.stat().st_mtime_ns) for p in folder.rglob("*") if p.is_file()}


def test_cold_and_warm_kernel_cache_train_identically(tmp_path):
    scene = _scene(tmp_path / "sphere")
    cache = tmp_path / "numba_cache"
    cache.mkdir()
    compiled = _train(scene, tmp_path / "cold", cache)  # compiles every kernel and fills the cache
    filled = _listing(cache)
    assert any(name.endswith(".nbi") for name in filled), "the cold run cached no kernels"
    assert any(line.startswith("defines ") for line in compiled), "the cold run compiled no kernel"
    _train(scene, tmp_path / "warm", cache)  # loads every kernel from the cache
    assert _listing(cache) == filled, "the warm run compiled kernels instead of loading them all from the cache"
    copies = [line for line in compiled if line.startswith("LINKED-FASTMATH-COPY")]
    cold = (tmp_path / "cold" / "point_cloud.ply").read_bytes()
    warm = (tmp_path / "warm" / "point_cloud.ply").read_bytes()
    assert cold == warm, "the run that compiled the numba kernels and the run that loaded them from the cache differ; " + "\n".join(
        ["fast-math code that kernels carry as linked copies:", *copies]
    )
    cold_c, warm_c = (np.load(tmp_path / run / "contributions.npz") for run in ("cold", "warm"))
    assert all(np.array_equal(cold_c[k], warm_c[k]) for k in ("indptr", "cols", "vals")), "contribution lists differ between cold and warm cache"
    # the cause, checked directly (a scene can happen not to show it): no kernel carries a linked copy of fast-math code
    assert not copies, "\n".join(copies)
