"""Rasterizer speed: projection + binning + forward + backward per backend, with a stage breakdown.

Usage:  python benchmarks/bench_rasterizer.py [--repeats 15] [--torch-repeats 5] [--threads 2]

Scene generator (seeded, ``make_scene``): a pinhole camera at the origin looking down +z sees a
textured-world stand-in of the kind 3DGS produces after training. 75% of the Gaussians lie on
surfaces (a floor plane, a back wall, three spheres in front of it), flattened along the surface
normal (thickness 10-30% of the in-plane size) with a random in-plane rotation; 15% float within
0.3 of those surfaces with random orientation; 10% lie outside the view (behind the camera, or
beyond the frustum) so that culling is exercised. In-plane sizes are log-normal in *pixels*
(median 1.6 px standard deviation, 95% between ~0.4 and ~6 px, a tail up to ~40 px), converted to
world units at each Gaussian's depth, i.e. "most footprints a few pixels, some larger", as in
trained 3DGS models. Opacities are spread over 0.05-1 (a Beta(0.6, 0.6) stretched onto that
range); colours are degree-3 SH with small view-dependent terms. The loss is a fixed random
weighting of colour and depth (plus alpha), so every gradient path is used.

Process settings (printed; ``--no-tuning`` keeps the defaults). The script re-executes itself once with
- ``MALLOC_MMAP_THRESHOLD_=1073741824 MALLOC_TRIM_THRESHOLD_=4294967296``: glibc returning freed big
  blocks to the OS makes the torch backend 2-4x slower and noisy (every iteration re-faults hundreds
  of MB); with these, freed memory stays in the process;
- ``OMP_WAIT_POLICY=PASSIVE``: torch and numba each run an OpenMP pool; spin-waiting idle threads
  of one starve the other on 2 cores (also set by ``import inpaint360gs`` before torch loads).
Timings are medians after warm-up, taken in one process, so the backends' ratio is meaningful even
though this shared machine's absolute speed drifts; CPU time (all threads) is printed beside wall
time because it is less sensitive to other jobs on the machine.
"""

from __future__ import annotations

import argparse
import math
import os
import statistics
import sys
import time

TUNING_ENV = {"MALLOC_MMAP_THRESHOLD_": "1073741824", "MALLOC_TRIM_THRESHOLD_": "4294967296", "OMP_WAIT_POLICY": "PASSIVE"}


def _maybe_reexec(argv: list[str]) -> None:
    if "--no-tuning" in argv or all(os.environ.get(k) == v for k, v in TUNING_ENV.items()):
        return
    env = dict(os.environ, **TUNING_ENV)
    os.execve(sys.executable, [sys.executable, os.path.abspath(__file__), *argv], env)


def make_scene(n: int, width: int, height: int, seed: int = 0):
    """(Gaussians, Camera): the seeded synthetic 'trained-like' scene described in the module docstring."""
    import torch

    from inpaint360gs.core.gaussians import Gaussians
    from inpaint360gs.core.camera import Camera

    gen = torch.Generator().manual_seed(seed)

    def rand(*s):
        return torch.rand(*s, generator=gen, dtype=torch.float64)

    def randn(*s):
        return torch.randn(*s, generator=gen, dtype=torch.float64)

    f = 0.9 * width  # ~58 degree horizontal field of view
    cam = Camera(torch.eye(3), torch.zeros(3), f, f, width / 2, height / 2, width, height)
    n_surf, n_float = int(0.75 * n), int(0.15 * n)
    n_out = n - n_surf - n_float

    def surface_points(m):
        """Points and unit normals on floor (y = 1.2), back wall (z = 7) and three spheres."""
        kind = torch.multinomial(torch.tensor([0.35, 0.35, 0.3]), m, replacement=True, generator=gen)
        pts, nrm = torch.zeros(m, 3, dtype=torch.float64), torch.zeros(m, 3, dtype=torch.float64)
        k = kind == 0  # floor, visible from z = 1.5 to 7
        c = int(k.sum())
        z = 1.5 + 5.5 * rand(c)
        pts[k] = torch.stack([(rand(c) - 0.5) * 1.2 * z, torch.full((c,), 1.2, dtype=torch.float64), z], -1)
        nrm[k] = torch.tensor([0.0, -1.0, 0.0], dtype=torch.float64)
        k = kind == 1  # back wall
        c = int(k.sum())
        pts[k] = torch.stack([(rand(c) - 0.5) * 8.4, (rand(c) - 0.5) * 6.4 - 0.6, torch.full((c,), 7.0, dtype=torch.float64)], -1)
        nrm[k] = torch.tensor([0.0, 0.0, -1.0], dtype=torch.float64)
        k = kind == 2  # spheres
        c = int(k.sum())
        centers = torch.tensor([[-0.9, 0.5, 3.5], [0.6, 0.6, 4.2], [0.1, 0.2, 2.8]], dtype=torch.float64)
        radius = torch.tensor([0.7, 0.6, 0.4], dtype=torch.float64)
        which = torch.randint(0, 3, (c,), generator=gen)
        d = randn(c, 3)
        d = d / d.norm(dim=-1, keepdim=True)
        pts[k] = centers[which] + radius[which, None] * d
        nrm[k] = d
        return pts, nrm

    p_s, n_s = surface_points(n_surf)
    p_f, _ = surface_points(n_float)
    p_f = p_f + 0.3 * (rand(n_float, 3) - 0.5) * 2
    # outside the view: behind the camera or far to the side
    p_o = torch.stack([(rand(n_out) - 0.5) * 20, (rand(n_out) - 0.5) * 10, (rand(n_out) - 0.5) * 8 - 3], -1)
    p_o[:, 0] += torch.sign(p_o[:, 0]) * 6
    means = torch.cat([p_s, p_f, p_o])

    # sizes: log-normal in pixels at the Gaussian's depth
    sigma_px = torch.exp(math.log(1.6) + 0.7 * randn(n)).clamp(0.2, 40.0)
    depth = means[:, 2].abs().clamp_min(0.5)
    s_world = sigma_px * depth / f
    scales = torch.stack([s_world * (0.6 + 0.8 * rand(n)), s_world * (0.6 + 0.8 * rand(n)), s_world], -1)
    # surface Gaussians: flat along the normal (third axis = normal)
    thin = 0.1 + 0.2 * rand(n_surf)
    scales[:n_surf, 2] = s_world[:n_surf] * thin
    quats = randn(n, 4)
    # rotate the z axis onto the surface normal, then spin randomly about it
    z = torch.tensor([0.0, 0.0, 1.0], dtype=torch.float64)
    axis = torch.linalg.cross(z.expand(n_surf, 3), n_s)
    sin = axis.norm(dim=-1)
    cos = (n_s * z).sum(-1)
    ang = torch.atan2(sin, cos)
    axis = torch.where(sin[:, None] > 1e-9, axis / sin.clamp_min(1e-12)[:, None], torch.tensor([1.0, 0.0, 0.0], dtype=torch.float64))
    q_align = torch.cat([torch.cos(ang / 2)[:, None], torch.sin(ang / 2)[:, None] * axis], -1)
    spin = 2 * math.pi * rand(n_surf)
    q_spin = torch.stack([torch.cos(spin / 2), torch.zeros(n_surf, dtype=torch.float64), torch.zeros(n_surf, dtype=torch.float64), torch.sin(spin / 2)], -1)
    quats[:n_surf] = _qmul(q_align, q_spin)

    beta = torch.distributions.Beta(torch.tensor(0.6, dtype=torch.float64), torch.tensor(0.6, dtype=torch.float64))
    torch.manual_seed(seed)  # Beta sampling uses the global generator
    opac = 0.05 + 0.95 * beta.sample((n,)).clamp(1e-4, 1 - 1e-4)
    sh0 = (rand(n, 1, 3) - 0.5) / 0.28209479177387814 * 0.9
    shN = 0.05 * randn(n, 15, 3)
    g = Gaussians(means, torch.log(scales), quats, torch.logit(opac), sh0, shN, 0.5 * randn(n, 8))
    return g.to(dtype=torch.float32), cam


def _qmul(a, b):
    import torch

    aw, ax, ay, az = a.unbind(-1)
    bw, bx, by, bz = b.unbind(-1)
    return torch.stack(
        [aw * bw - ax * bx - ay * by - az * bz, aw * bx + ax * bw + ay * bz - az * by,
         aw * by - ax * bz + ay * bw + az * bx, aw * bz + ax * by - ay * bx + az * bw], -1
    )  # fmt: skip


def _peak_rss_probe(backend: str, n: int, W: int, H: int, seed: int) -> None:
    """Run in a fresh process: print the peak RSS growth (MB) of one step, after loading the kernels on a tiny scene.

    The peak is the kernel's high-water mark (VmHWM, reset through /proc/self/clear_refs after warm-up),
    not ru_maxrss, which a child inherits from its parent across fork+exec.
    """
    import torch

    g, cam = make_scene(n, W, H, seed)
    weights = (torch.rand(H, W, 3), torch.rand(H, W))
    g0, cam0 = make_scene(50, 32, 32, 1)
    _step(g0, cam0, backend, (torch.rand(32, 32, 3), torch.rand(32, 32)))

    def status_kb(key: str) -> int:
        with open("/proc/self/status") as f:
            return next(int(line.split()[1]) for line in f if line.startswith(key + ":"))

    try:
        with open("/proc/self/clear_refs", "w") as f:
            f.write("5")  # reset VmHWM to the current RSS
    except OSError:
        pass
    base = status_kb("VmRSS")
    _step(g, cam, backend, weights)
    print((status_kb("VmHWM") - base) / 1024)


def memory_probe(backend: str, n: int, W: int, H: int, seed: int) -> float:
    """Peak RSS growth (MB) of one training-like step, measured in a fresh process."""
    import subprocess

    code = (
        f"import sys, torch; sys.path.insert(0, {os.path.dirname(os.path.abspath(__file__))!r}); "
        f"torch.set_num_threads({torch_threads()}); import bench_rasterizer as b; "
        f"b._peak_rss_probe({backend!r}, {n}, {W}, {H}, {seed})"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    return max(0.0, float(out.stdout.strip().splitlines()[-1]))


def torch_threads() -> int:
    import torch

    return torch.get_num_threads()


def _step(g, cam, backend, weights):
    """One training-like step: render + weighted colour/depth/alpha loss + backward; returns the output."""
    from inpaint360gs.render import render

    params = g.map(lambda t: t.detach().requires_grad_(True))
    out = render(params, cam, backend=backend)
    wc, wd = weights
    loss = (out.color * wc).sum() + (out.depth * wd).sum() + 0.1 * out.alpha.sum()
    loss.backward()
    return out


def _median_ms(fn, repeats: int, warmup: int = 2) -> tuple[float, list[float], float]:
    """(median wall ms, all wall ms, median process-CPU ms) of ``fn`` after ``warmup`` untimed calls."""
    for _ in range(warmup):
        fn()
    ts, cpu = [], []
    for _ in range(repeats):
        c0, t0 = time.process_time(), time.perf_counter()
        fn()
        ts.append((time.perf_counter() - t0) * 1e3)
        cpu.append((time.process_time() - c0) * 1e3)
    return statistics.median(ts), ts, statistics.median(cpu)


def breakdown_numba(g, cam, weights, repeats: int) -> dict[str, float]:
    """Median ms of each numba-path stage, run separately on the same inputs."""
    import numba
    import numpy as np
    import torch

    from inpaint360gs.render import numba_kernels as K
    from inpaint360gs.render.numba_arrays import set_numba_threads, to_f32
    from inpaint360gs.render.numba_backend import prepare
    from inpaint360gs.render.numba_projection import project_and_shade_numba

    set_numba_threads()
    W, H = cam.width, cam.height
    params = g.map(lambda t: t.detach().requires_grad_(True))

    def proj():
        """Projection + SH as the numba backend runs them (fused kernel pair)."""
        m2d, con, dep, rad, rgb = project_and_shade_numba(params.means, params.quats, params.log_scales, params.sh, cam, 3)
        return (m2d, con, dep, rad), torch.cat([rgb, dep[:, None]], -1), torch.sigmoid(params.opacity_logits)

    (m2d, con, dep, rad), ch_t, op_t = proj()
    ch = to_f32(ch_t)
    args = (m2d, con, op_t, rad, dep, W, H)
    pk, offsets, gids, order, tiles_x = prepare(*args)
    img, tf, last, n_eval = K.forward(pk, ch, offsets, gids, order, numba.get_num_threads(), W, H, tiles_x)
    d_img = np.ascontiguousarray(np.concatenate([weights[0].numpy(), weights[1].numpy()[..., None]], -1), np.float32)
    d_alpha = np.full((H, W), 0.1, np.float32)
    rows = K.backward(pk, ch, offsets, gids, order, numba.get_num_threads(), W, H, tiles_x, tf, last, d_img, d_alpha)
    grads = torch.from_numpy(K.reduce_rows(rows, gids, pk.shape[0]))

    def proj_bwd():
        (pm, pc, _, _), cc, oo = proj()
        torch.autograd.backward([pm, pc, oo, cc], [grads[:, :2], grads[:, 2:5], grads[:, 5], grads[:, 6:]])

    stages = {
        "projection+SH fwd": lambda: proj(),
        "projection+SH fwd+bwd": proj_bwd,
        "binning + packing": lambda: prepare(*args),
        "raster forward": lambda: K.forward(pk, ch, offsets, gids, order, numba.get_num_threads(), W, H, tiles_x),
        "raster backward": lambda: K.backward(pk, ch, offsets, gids, order, numba.get_num_threads(), W, H, tiles_x, tf, last, d_img, d_alpha),
        "gradient reduction": lambda: K.reduce_rows(rows, gids, pk.shape[0]),
    }
    res = {}
    for name, fn in stages.items():
        med, _, cpu = _median_ms(fn, repeats)
        res[name] = (med, cpu)
    res["_intersections"] = float(gids.shape[0])
    res["_visible"] = float((rad > 0).sum())
    res["_evaluations"] = float(n_eval.sum())
    return res


def bench_case(n: int, W: int, H: int, repeats: int, torch_repeats: int, seed: int) -> list[str]:
    import torch

    from inpaint360gs.render import available_backends

    g, cam = make_scene(n, W, H, seed)
    gen = torch.Generator().manual_seed(seed + 1)
    weights = (torch.rand(H, W, 3, generator=gen), 0.05 * torch.rand(H, W, generator=gen))
    lines = []
    bd = breakdown_numba(g, cam, weights, repeats) if "numba" in available_backends() else None
    results = {}
    for backend in [b for b in ("numba", "torch") if b in available_backends()]:
        reps = repeats if backend == "numba" else torch_repeats
        med, ts, cpu = _median_ms(lambda: _step(g, cam, backend, weights), reps, warmup=2 if backend == "numba" else 1)
        results[backend] = (med, min(ts), max(ts), cpu, memory_probe(backend, n, W, H, seed))
    head = f"{n} Gaussians, {W}x{H}"
    if bd:
        lines.append(
            f"{head}: visible {int(bd['_visible'])}, tile intersections {int(bd['_intersections'])} "
            f"(mean {bd['_intersections'] / n:.2f} per Gaussian, {bd['_intersections'] / max(bd['_visible'], 1):.2f} per visible one), "
            f"forward pixel x Gaussian evaluations {bd['_evaluations'] / 1e6:.2f} M"
        )
    lines.append("| backend | median ms (projection+binning+fwd+bwd) | min | max | median CPU ms (all threads) | peak RSS growth of one step, MB (fresh process) |")
    lines.append("|---|---|---|---|---|---|")
    for b, (med, lo, hi, cpu, mb) in results.items():
        lines.append(f"| {b} | {med:.1f} | {lo:.1f} | {hi:.1f} | {cpu:.1f} | {mb:.0f} |")
    if "numba" in results and "torch" in results:
        t, nb = results["torch"], results["numba"]
        lines.append(f"speed-up numba vs torch (same process): {t[0] / nb[0]:.1f}x wall, {t[3] / nb[3]:.1f}x CPU time")
    if bd:
        lines.append("numba stage breakdown (each stage timed alone; median wall ms / median CPU ms):")
        for k, v in bd.items():
            if not k.startswith("_"):
                lines.append(f"  {k:>22}: {v[0]:7.2f} / {v[1]:7.2f}")
        fwd_s = bd["raster forward"][0] / 1e3
        lines.append(f"  raster forward: {bd['_evaluations'] / fwd_s / 1e9:.2f} G pixel x Gaussian evaluations / s (wall)")
    return lines


def main(argv: list[str] | None = None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=15, help="timed repeats for numba (median reported)")
    ap.add_argument("--torch-repeats", type=int, default=5, help="timed repeats for the torch backend")
    ap.add_argument("--threads", type=int, default=2, help="torch and numba threads")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--cases", default="30000x320x240,5000x160x120", help="comma list of NxWxH")
    ap.add_argument("--no-tuning", action="store_true", help="keep glibc's malloc thresholds and OpenMP's wait policy")
    args = ap.parse_args(argv)
    _maybe_reexec(argv)
    import torch

    torch.set_num_threads(args.threads)
    os.environ.setdefault("NUMBA_NUM_THREADS", str(args.threads))
    import numba

    from inpaint360gs.render import available_backends

    print(f"torch {torch.__version__}, numba {numba.__version__}, threads {args.threads}, backends {available_backends()}")
    print("environment: " + ", ".join(f"{k}={os.environ.get(k, 'default')}" for k in TUNING_ENV))
    for case in args.cases.split(","):
        n, W, H = (int(v) for v in case.lower().split("x"))
        print()
        print("\n".join(bench_case(n, W, H, args.repeats, args.torch_repeats, args.seed)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
