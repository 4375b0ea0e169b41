"""3DGS on a capture with few SfM points against the same capture with a dense point cloud.

A synthetic scene posed by structure from motion (``poses: colmap``; the realistic family's
``plush`` layout is the plain-backdrop case where SfM finds few points) is trained twice per seed
with the same settings: once from its own SfM points, once from a *dense twin*: the same folder
(copies of its images and files, the same COLMAP cameras) whose ``sparse/0`` holds ``--points`` points back-projected from the
generator's true depth (``gt/depth``, converted to the SfM frame's units with
``gt/colmap_frame.json``) at random pixels of the training photos, coloured by those pixels. The
twin is what a good SfM cloud would give; the gap in held-out PSNR is what the sparse start costs
(target: within 1 dB). Each run is ``inpaint360gs train`` in its own process (the cpu preset's
budget unless ``--iterations``/``--extra`` say otherwise). Prints one row per run and the gap per seed.

    python benchmarks/bench_sparse_init.py data/plush-dev1 --work outputs/bench_sparse_init --seeds 0 1 2
    python benchmarks/bench_sparse_init.py data/plush-dev1 --work outputs/bench_sparse_init --seeds 0 1 2 "--extra=--support-init off" --tag=-sfm-only

The SfM-start runs take ``train``'s default ``--support-init auto`` (on a plain support: the support
points); ``--support-init off`` gives the bare SfM start.

``--extra`` goes to the SfM-start runs only (what is being tried on the sparse start); the dense
twin's runs always use the plain settings and are reused when their folder holds a finished run.
"""

from __future__ import annotations

import argparse
import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np

from inpaint360gs.pipeline.presets import PRESETS

TRAIN = PRESETS["cpu"].train


def dense_twin(scene_root: Path, out: Path, n_points: int, seed: int = 0) -> int:
    """Write the dense twin of ``scene_root`` into ``out`` (a copy with a new ``sparse/0``); returns its point count."""
    from inpaint360gs.io.colmap import write_model
    from inpaint360gs.io.scene import load_scene

    scene = load_scene(scene_root)
    frame = json.loads((scene_root / "gt" / "colmap_frame.json").read_text())
    scale = float(frame["true_from_colmap"]["scale"])  # true units per SfM unit
    views = [v for v in scene.train_views]
    rng = np.random.default_rng(seed)
    per_view = int(np.ceil(n_points / len(views)))
    xyz, rgb = [], []
    for v in views:
        cam = v.camera
        z = np.load(scene_root / "gt" / "depth" / f"{Path(v.name).stem}.npy").astype(np.float64) / scale
        img = scene.load_image_raw(v)
        h, w = z.shape
        pick = rng.choice(h * w, size=min(per_view, h * w), replace=False)
        i, j = np.divmod(pick, w)
        zz = z[i, j]
        ok = np.isfinite(zz) & (zz > 0)
        i, j, zz = i[ok], j[ok], zz[ok]
        x_cam = np.stack([(j + 0.5 - cam.cx) / cam.fx * zz, (i + 0.5 - cam.cy) / cam.fy * zz, zz], -1)
        R = cam.R.double().numpy()
        t = cam.t.double().numpy()
        xyz.append((x_cam - t) @ R)  # R^T (x_cam - t)
        px = img[i, j, :3]
        rgb.append(px.astype(np.float64) / (255.0 if px.dtype == np.uint8 else 1.0))
    if out.exists():
        shutil.rmtree(out)
    out.mkdir(parents=True)
    for entry in scene_root.iterdir():  # copies: a stage reads no link that leads out of its scene folder
        if entry.is_dir() and entry.name != "sparse":
            shutil.copytree(entry, out / entry.name)
        elif entry.is_file():
            shutil.copy2(entry, out / entry.name)
    all_views = sorted(scene.views, key=lambda v: v.name)
    write_model(out / "sparse" / "0", [v.camera for v in all_views], np.concatenate(xyz), np.concatenate(rgb))
    return int(sum(len(p) for p in xyz))


def train(scene: Path, out: Path, seed: int, args, extra: str) -> dict:
    if not (out / "metrics.json").is_file():
        _train(scene, out, seed, args, extra)
    m = json.loads((out / "metrics.json").read_text())
    with open(out / "train_log.csv") as f:  # the first row's count: the Gaussians it started from
        header, first = f.readline().strip().split(","), f.readline().strip().split(",")
    return {"n_init": int(first[header.index("num_gaussians")]), **m}


def _train(scene: Path, out: Path, seed: int, args, extra: str) -> None:
    cmd = [
        sys.executable, "-m", "inpaint360gs.cli", "train", str(scene), str(out), "--iterations", str(args.iterations),
        "--schedule-scale", "auto", "--max-gaussians", str(TRAIN.densify.max_gaussians), "--threads", str(args.threads),
        "--no-progress", "--seed", str(seed), "--overwrite", *extra.split(),
    ]  # fmt: skip
    proc = subprocess.run(cmd, capture_output=True, text=True)
    if proc.returncode != 0:
        sys.exit(f"bench_sparse_init: {' '.join(cmd)} failed ({proc.returncode}): {proc.stderr.strip().splitlines()[-1:]}")


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", type=Path, help="a generated scene folder posed by SfM (gt/colmap_frame.json)")
    ap.add_argument("--work", type=Path, default=Path("outputs/bench_sparse_init"), help="the twin and the runs go here")
    ap.add_argument("--points", type=int, default=30000, help="points of the dense twin (default 30000)")
    ap.add_argument("--seeds", type=int, nargs="+", default=[0, 1, 2])
    ap.add_argument("--iterations", type=int, default=TRAIN.iterations)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--extra", default="", help="extra arguments for `inpaint360gs train` of the SfM-start runs, one string")
    ap.add_argument("--tag", default="", help="suffix of the run folders (compare settings side by side)")
    args = ap.parse_args()

    name = args.scene.name
    twin = args.work / f"{name}-densecloud"
    if not (twin / "sparse" / "0").exists():
        dense_twin(args.scene, twin, args.points)
    rows = []
    for seed in args.seeds:
        for variant, root, tag, extra in (("sfm", args.scene, args.tag, args.extra), ("dense", twin, "", "")):
            m = train(root, args.work / "runs" / f"{name}-{variant}{tag}-s{seed}", seed, args, extra)
            rows.append({"variant": variant, "seed": seed, **{k: m.get(k) for k in ("n_init", "num_gaussians", "psnr", "ssim", "train_seconds")}})
            print(json.dumps(rows[-1]), flush=True)
    print(f"\n{name}, {args.iterations} steps{' ' + args.extra if args.extra else ''}\n")
    print("| seed | Gaussians at start (SfM) | at the end (SfM start) | at the end (dense start) | held-out PSNR SfM | dense | gap (dB) |")
    print("|---|---|---|---|---|---|---|")  # gap: dense - SfM start
    gaps = []
    for seed in args.seeds:
        s = next(r for r in rows if r["seed"] == seed and r["variant"] == "sfm")
        d = next(r for r in rows if r["seed"] == seed and r["variant"] == "dense")
        gaps.append(d["psnr"] - s["psnr"])
        print(f"| {seed} | {s['n_init']} | {s['num_gaussians']} | {d['num_gaussians']} | {s['psnr']:.2f} | {d['psnr']:.2f} | {gaps[-1]:+.2f} |")
    print(f"\nworst gap {max(gaps):+.2f} dB (target <= 1 dB)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
