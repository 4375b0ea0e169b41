"""Metrics speed: one scene's evaluation (``evaluate_stage``) and LPIPS forward+backward.

Usage: python benchmarks/bench_metrics.py [--data /tmp/metrics_data] [--scene cone] [--repeats 3]
       [--lpips-repeats 7] [--threads N] [--out results/benchmarks/metrics.txt]

Budgets (2-core CPU machine): evaluating a scene of 16 test views at 256x192 with every metric
(PSNR/SSIM/LPIPS-VGG/LPIPS-Alex in the full, masked and roi conventions, fd_vgg16, kid_vgg16, AMCR;
no Inception) <= 20 s; LPIPS forward+backward of one 256x192 pair (gradient for the render, fixed
ground truth, as in the 3D inpainting loss) <= 0.3 s per network.

Timing only: the scene comes from the project's generator (``dataset_tools.cli synth``, generated
into --data when absent) and the "renders" are its own test images blurred and noised, so the
metric values are not results of any method. The machine may be shared: the load average before
and after and the CPU time (all threads) are printed beside wall times.
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import time
from datetime import datetime, timezone
from pathlib import Path

import inpaint360gs  # noqa: F401  (sets OMP_WAIT_POLICY=PASSIVE before torch loads)

ROOT = Path(__file__).resolve().parents[1]
BUDGET_EVAL_S, BUDGET_LPIPS_S = 20.0, 0.3


def git_commit() -> str:
    def git(*args: str) -> str:
        return subprocess.run(["git", *args], cwd=ROOT, capture_output=True, text=True).stdout.strip()

    commit = git("rev-parse", "--short", "HEAD") or "unknown"
    dirty = git("status", "--porcelain", "--", ".", ":(exclude)results")
    return commit + (" (uncommitted changes)" if dirty else "")


def ensure_scene(data: Path, name: str) -> Path:
    scene = data / name
    if not (scene / "scene.json").is_file():
        env = dict(os.environ, PYTHONPATH=os.pathsep.join([str(ROOT / "src"), str(ROOT), os.environ.get("PYTHONPATH", "")]))
        subprocess.run([sys.executable, "-m", "dataset_tools.cli", "synth", str(data), "--scenes", name, "--quiet"], check=True, env=env, cwd=ROOT)
    return scene


def make_renders(scene_dir: Path, out: Path) -> tuple[int, tuple[int, int]]:
    """Blurred + noised copies of the test images (timing only, not a method's output)."""
    import cv2
    import numpy as np

    from inpaint360gs.io.images import write_image
    from inpaint360gs.io.scene import load_scene

    scene = load_scene(scene_dir, load_masks=False)
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(0)
    views = scene.test_views
    for v in views:
        img = scene.load_image_raw(v, allow_test=True).astype(np.float32)
        img = cv2.GaussianBlur(img, (5, 5), 1.2) + rng.normal(0, 6, img.shape).astype(np.float32)
        write_image(out / f"{v.stem}.png", np.clip(img, 0, 255).astype(np.uint8))
    return len(views), (views[0].camera.width, views[0].camera.height)


def timed(fn) -> tuple[float, float]:
    t, c = time.perf_counter(), time.process_time()
    fn()
    return time.perf_counter() - t, time.process_time() - c


def bench_lpips(net: str, dtype, repeats: int, width: int, height: int) -> tuple[float, float, float]:
    """Median wall / CPU seconds of forward+backward of one pair, and the value's relative deviation from float32."""
    import torch

    from inpaint360gs.metrics import lpips

    gen = torch.Generator().manual_seed(0)
    gt = torch.rand(3, height, width, generator=gen)
    render = (gt + 0.1 * torch.randn(gt.shape, generator=gen)).clamp(0, 1)

    def step():
        x = render.clone().requires_grad_(True)
        lpips(x.to(dtype), gt.to(dtype), net).backward()

    for _ in range(2):
        step()
    runs = [timed(step) for _ in range(repeats)]
    with torch.no_grad():
        ref = lpips(render, gt, net).item()
        dev = abs(lpips(render.to(dtype), gt.to(dtype), net).item() - ref) / ref
    return statistics.median(r[0] for r in runs), statistics.median(r[1] for r in runs), dev


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("/tmp/metrics_data"), help="scene folder root (generated if absent)")
    ap.add_argument("--scene", default="cone")
    ap.add_argument("--repeats", type=int, default=3, help="warm scene evaluations")
    ap.add_argument("--lpips-repeats", type=int, default=7)
    ap.add_argument("--threads", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--out", type=Path, default=None, help="also write the report here")
    args = ap.parse_args()

    import torch

    from inpaint360gs.evaluate.stage import evaluate_stage

    torch.set_num_threads(args.threads)
    lines: list[str] = []

    def say(s: str = "") -> None:
        print(s, flush=True)
        lines.append(s)

    say(f"$ python {' '.join([os.path.relpath(sys.argv[0], ROOT), *sys.argv[1:]])}")
    say(f"commit {git_commit()}, {datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC, {os.cpu_count()} cores")
    say(f"torch {torch.__version__}, threads {torch.get_num_threads()}, OMP_WAIT_POLICY={os.environ.get('OMP_WAIT_POLICY')}")
    load_before = os.getloadavg()

    scene_dir = ensure_scene(args.data, args.scene)
    renders = args.data / f"{args.scene}_renders_timing_only"
    n, (w, h) = make_renders(scene_dir, renders)
    say(f"scene {args.scene}: {n} test views at {w}x{h}; renders = blurred + noised test images (timing only)")
    say()

    cold = timed(lambda: evaluate_stage(renders, scene_dir, nets=("vgg", "alex")))
    warm = [timed(lambda: evaluate_stage(renders, scene_dir, nets=("vgg", "alex"))) for _ in range(args.repeats)]
    ev_wall, ev_cpu = statistics.median(r[0] for r in warm), statistics.median(r[1] for r in warm)
    say("| case | median wall s | median CPU s (all threads) | budget | within |")
    say("|---|---|---|---|---|")
    say(f"| evaluate_stage, {n} views {w}x{h}, all metrics, vgg+alex, fd/kid, no Inception (warm, {args.repeats} runs) | {ev_wall:.2f} | {ev_cpu:.2f} | {BUDGET_EVAL_S:.0f} s | {'yes' if ev_wall <= BUDGET_EVAL_S else 'NO'} |")
    say(f"| evaluate_stage, first call in the process (loads weights, builds networks) | {cold[0]:.2f} | {cold[1]:.2f} | - | - |")
    devs = {}
    for net in ("vgg", "alex"):
        for dtype in (torch.float32, torch.bfloat16):
            wall, cpu, dev = bench_lpips(net, dtype, args.lpips_repeats, w, h)
            tag = "float32 (the metric)" if dtype == torch.float32 else "bfloat16 (loss option)"
            devs[(net, str(dtype))] = dev
            say(f"| LPIPS-{net} forward+backward, one {w}x{h} pair, {tag} ({args.lpips_repeats} runs) | {wall:.3f} | {cpu:.3f} | {BUDGET_LPIPS_S} s | {'yes' if wall <= BUDGET_LPIPS_S else 'NO'} |")
    load_after = os.getloadavg()
    say()
    say(f"bfloat16 LPIPS vs float32 on the benchmark pair, relative difference: vgg {devs[('vgg', 'torch.bfloat16')]:.1e}, alex {devs[('alex', 'torch.bfloat16')]:.1e}")
    say(f"load average (1, 5, 15 min) before {tuple(round(x, 2) for x in load_before)}, after {tuple(round(x, 2) for x in load_after)}")
    if args.out:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
