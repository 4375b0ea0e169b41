"""Object-ID distillation (paper Sec. 3.3) on the synthetic benchmark: held-out id IoU, time, memory.

Until the association stage exists, each scene's ground-truth instance masks (``gt/instance/<stem>.png``,
uint8 object ids consistent across views) stand in for the associated masks: this script copies the
training views' masks into an association-shaped folder (``object_mask/`` + ``objects.json``); the
library stage itself never reads ``gt/``. Each scene is distilled by the ``inpaint360gs distill`` CLI
in its own process (wall time includes start-up, peak RSS is that run's alone), then the distilled
field renders an id map at every held-out view through the ordinary rasterizer, scored against
``gt/instance``: IoU per object pooled over the held-out views, mean over objects (target >= 0.85).
Targets for 49 views at 256x192 on 2 cores: <= 4 min including the weight cache.

``--prune`` adds a table for one scene over ``--min-weight`` values: what dropping small cached
weights saves (memory, time) and costs (dropped weight per pixel, held-out IoU).

    python benchmarks/bench_distill.py --scenes cone toys --data data/synthetic --models outputs
    python benchmarks/bench_distill.py --scenes cone --prune --min-weights 0.001 0.003 0.01

Scenes whose model (``MODELS/<scene>/3dgs/point_cloud.ply``) is missing are listed and skipped.
"""

from __future__ import annotations

import inpaint360gs  # noqa: F401  (first: sets OMP_WAIT_POLICY before torch starts its thread pool)

import argparse
import json
import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import cv2
import numpy as np
import pandas as pd


def make_assoc(scene_dir: Path, dst: Path) -> Path:
    """An association-shaped folder from the scene's ground truth (benchmark only: stands in for Sec. 3.2)."""
    from inpaint360gs.io.scene import load_scene

    scene = load_scene(scene_dir, load_masks=False)
    masks = dst / "object_mask"
    if dst.exists():
        shutil.rmtree(dst)
    masks.mkdir(parents=True)
    for v in scene.train_views:
        shutil.copyfile(scene_dir / "gt" / "instance" / f"{v.stem}.png", masks / f"{v.stem}.png")
    objects = json.loads((scene_dir / "gt" / "objects.json").read_text())
    (dst / "objects.json").write_text(json.dumps({"objects": [{"id": o["id"], "label": o.get("label", "")} for o in objects], "segmenter": "gt (benchmark)"}, indent=1))
    return dst


def held_out_scores(scene_dir: Path, out: Path) -> dict:
    """Id maps rendered at the held-out views vs gt/instance: per-object IoU pooled over views."""
    from inpaint360gs.distill import IdentityField
    from inpaint360gs.io.scene import load_scene

    scene = load_scene(scene_dir, load_masks=False)
    field = IdentityField.load(out)
    inter = np.zeros(256)
    union = np.zeros(256)
    correct = total = 0
    for v in scene.holdout_views:
        ids, _ = field.render_ids(v.camera)
        pred = ids.numpy()
        gt = cv2.imread(str(scene_dir / "gt" / "instance" / f"{v.stem}.png"), cv2.IMREAD_UNCHANGED)
        correct += int((pred == gt).sum())
        total += gt.size
        for o in set(field.object_ids) | set(np.unique(gt).tolist()):
            inter[o] += np.sum((pred == o) & (gt == o))
            union[o] += np.sum((pred == o) | (gt == o))
    objects = [o for o in field.object_ids if o != 0 and union[o] > 0]
    iou = {o: inter[o] / union[o] for o in objects}
    return {
        "views": len(scene.holdout_views),
        "mean_object_iou": float(np.mean(list(iou.values()))) if iou else float("nan"),
        "min_object_iou": float(min(iou.values())) if iou else float("nan"),
        "background_iou": float(inter[0] / union[0]) if union[0] else float("nan"),
        "pixel_accuracy": correct / max(total, 1),
    }


def run_one(scene_dir: Path, model: Path, assoc: Path, out: Path, args, extra: list[str]) -> tuple[dict, float]:
    cmd = [
        sys.executable, "-m", "inpaint360gs.cli", "distill", str(scene_dir), str(model), str(assoc), str(out),
        "--iterations", str(args.iterations), "--threads", str(args.threads), "--seed", "0", "--no-progress", "--overwrite", *extra,
    ]  # fmt: skip
    t0 = time.perf_counter()
    proc = subprocess.run(cmd, capture_output=True, text=True)
    wall = time.perf_counter() - t0
    if proc.returncode != 0:
        raise RuntimeError(f"{scene_dir.name}: distill failed: {proc.stderr.strip().splitlines()[-1:]}")
    return json.loads((out / "distill.json").read_text()), wall


def row_of(name: str, rep: dict, wall: float, held: dict) -> dict:
    t = rep["timing_s"]
    return {
        "scene": name, "objects": len(rep["object_ids"]) - 1, "Gaussians": rep["num_gaussians"],
        "W entries/px": rep["weights_cache"]["entries_per_pixel"], "W (MiB)": rep["weights_cache"]["mib"],
        "W (s)": t["weights_cache"], "train (s)": t["train"], "total (s)": t["total"], "wall incl. start-up (s)": round(wall, 1),
        "peak RSS (MiB)": rep["peak_rss_mb"], "train-view mIoU": rep["final"]["train_views"]["mean_object_iou"],
        "held-out mIoU": round(held["mean_object_iou"], 4), "held-out min IoU": round(held["min_object_iou"], 4),
        "held-out bg IoU": round(held["background_iou"], 4), "held-out pixel acc": round(held["pixel_accuracy"], 5),
    }  # fmt: skip


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", nargs="+", default=["cone"], help="scene names or 'all'")
    ap.add_argument("--data", type=Path, default=Path("data/synthetic"), help="scene folders (from inpaint360gs-dataset synth)")
    ap.add_argument("--models", type=Path, default=Path("outputs"), help="trained models: MODELS/<scene>/3dgs/point_cloud.ply")
    ap.add_argument("--work", type=Path, default=Path("outputs/bench_distill"), help="association stand-ins and runs go here")
    ap.add_argument("--iterations", type=int, default=2000)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--prune", action="store_true", help="also distill the first scene with each --min-weights value")
    ap.add_argument("--min-weights", type=float, nargs="+", default=[0.001, 0.003, 0.01])
    args = ap.parse_args()

    from dataset_tools.synth.catalogue import BENCHMARK_SCENES  # 'all': the ten classic scenes

    names = list(BENCHMARK_SCENES) if args.scenes == ["all"] else args.scenes
    print(f"load average at start: {' '.join(f'{x:.2f}' for x in os.getloadavg())} (shared {os.cpu_count()}-core machine)", flush=True)
    rows, missing = [], []
    for name in names:
        scene_dir, model = args.data / name, args.models / name / "3dgs" / "point_cloud.ply"
        if not model.is_file() or not scene_dir.is_dir():
            missing.append(name)
            continue
        assoc = make_assoc(scene_dir, args.work / "assoc" / name)
        out = args.work / "runs" / name
        rep, wall = run_one(scene_dir, model, assoc, out, args, [])
        rows.append(row_of(name, rep, wall, held_out_scores(scene_dir, out)))
        print(f"{name}: held-out mIoU {rows[-1]['held-out mIoU']:.4f} in {wall:.0f} s (load average {os.getloadavg()[0]:.2f})", flush=True)
    if missing:
        print(f"skipped (no scene or model yet): {', '.join(missing)}")
    if not rows:
        return 1
    df = pd.DataFrame(rows).set_index("scene").astype(float)
    if len(df) > 1:
        df.loc["average"] = df.mean(numeric_only=True)
    print(f"\nObject-ID distillation, {args.iterations} steps, gt instance masks as the associated masks, {args.threads} threads\n")
    print(df.to_markdown(floatfmt=".4g"))

    if args.prune:
        name = rows[0]["scene"]
        scene_dir, model = args.data / name, args.models / name / "3dgs" / "point_cloud.ply"
        assoc = args.work / "assoc" / name
        prows = [{"min weight": 0.0, **rows[0]}]
        for mw in args.min_weights:
            out = args.work / "prune" / f"{name}_{mw:g}"
            rep, wall = run_one(scene_dir, model, assoc, out, args, ["--min-weight", f"{mw:g}"])
            prows.append({"min weight": mw, **row_of(name, rep, wall, held_out_scores(scene_dir, out)), "dropped weight/px": rep["weights_cache"]["dropped_weight_per_pixel"]})
            print(f"{name} --min-weight {mw:g}: held-out mIoU {prows[-1]['held-out mIoU']:.4f} in {wall:.0f} s", flush=True)
        prows[0]["dropped weight/px"] = 0.0
        cols = ["min weight", "W entries/px", "W (MiB)", "dropped weight/px", "W (s)", "train (s)", "total (s)", "peak RSS (MiB)", "held-out mIoU", "held-out min IoU"]
        print(f"\nPruning the cached weights ({name}): entries with alpha*T below the threshold dropped\n")
        print(pd.DataFrame(prows)[cols].to_markdown(index=False, floatfmt=".4g"))
    print(f"\nload average at end: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
