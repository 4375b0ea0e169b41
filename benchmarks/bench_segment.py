"""Raw 2D masks (the segment stage) on the synthetic benchmark: how well each object, above all each
removal target, is found in the training views, and what the stage costs.

For every scene with a trained model it runs the whole stage (``segment_stage``: load, check, prepare,
every training view, write) into a temporary folder, then scores the written id images against the
scene's ground truth (``gt/instance``, ``gt/objects.json``; evaluation code may read gt/):

* per object: the mean, over training views where the object covers more than ``--min-px`` pixels
  of gt/instance, of the best-match IoU between its gt mask and any predicted segment;
* per scene: the mean over its removal targets (``removal_target: true``) and the worst target;
  ms per view (segmenter only) and the stage's wall time.

Scenes and models follow the workflow's layout: ``DATA/<scene>/`` and ``MODELS/<scene>/3dgs/point_cloud.ply``.

    python benchmarks/bench_segment.py --data data/synthetic --models outputs                 # every scene with a model
    python benchmarks/bench_segment.py --data data/synthetic --models outputs --segmenters geometric oracle --scenes toys
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import pandas as pd


def best_match_iou(ids: np.ndarray, target: np.ndarray) -> float:
    """Best IoU between the boolean ``target`` and any segment of the id image."""
    segs, inter = np.unique(ids[target & (ids > 0)], return_counts=True)
    if not len(segs):
        return 0.0
    area = np.bincount(ids.ravel(), minlength=int(ids.max()) + 1)[segs]
    return float(np.max(inter / (area + target.sum() - inter)))


def score_scene(scene, seg_dir: Path, min_px: int) -> list[dict]:
    from inpaint360gs.io.images import read_mask, resize_mask

    objects = json.loads((scene.root / "gt" / "objects.json").read_text())
    per = {o["id"]: [] for o in objects}
    for v in scene.train_views:
        ids = read_mask(seg_dir / f"{v.stem}.png")
        gt = resize_mask(read_mask(scene.root / "gt" / "instance" / f"{v.stem}.png"), v.camera.width, v.camera.height)
        for o in objects:
            m = gt == o["id"]
            if m.sum() > min_px:
                per[o["id"]].append(best_match_iou(ids, m))
    return [
        {"object": o["label"], "id": o["id"], "target": bool(o["removal_target"]), "views": len(per[o["id"]]),
         "IoU": float(np.mean(per[o["id"]])) if per[o["id"]] else float("nan"),
         "IoU min view": float(np.min(per[o["id"]])) if per[o["id"]] else float("nan")}
        for o in objects
    ]  # fmt: skip


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=Path("data/synthetic"), help="folder of scene folders")
    ap.add_argument("--models", type=Path, default=Path("outputs"), help="folder of <scene>/3dgs/point_cloud.ply")
    ap.add_argument("--scenes", nargs="+", default=["all"], help="scene names or 'all' (every scene with a model)")
    ap.add_argument("--segmenters", nargs="+", default=["geometric"], help="registered segmenter names (sam needs its ONNX files in the environment)")
    ap.add_argument("--min-px", type=int, default=50, help="an object counts in a view when its gt mask has more pixels than this")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--csv", type=Path, help="also write the per-object table here")
    args = ap.parse_args()

    import torch

    from inpaint360gs.cli.common import set_threads
    from inpaint360gs.io.ply import read_ply
    from inpaint360gs.io.scene import load_scene
    from inpaint360gs.segment import get_segmenter, segment_stage

    set_threads(args.threads)
    names = sorted(p.parent.parent.name for p in args.models.glob("*/3dgs/point_cloud.ply")) if args.scenes == ["all"] else args.scenes
    names = [n for n in names if (args.data / n / "gt" / "objects.json").is_file()]
    if not names:
        print(f"no scene with both {args.data}/<scene>/gt and {args.models}/<scene>/3dgs/point_cloud.ply", file=sys.stderr)
        return 1
    objects, scenes = [], []
    for name in names:
        scene = load_scene(args.data / name, load_masks=False)
        ply = args.models / name / "3dgs" / "point_cloud.ply"
        model = read_ply(ply)
        for sname in args.segmenters:
            with tempfile.TemporaryDirectory() as tmp:
                t0 = time.perf_counter()
                info = segment_stage(scene, model, Path(tmp) / "segment", get_segmenter(sname), model_path=ply)
                wall = time.perf_counter() - t0
                rows = score_scene(scene, Path(tmp) / "segment", args.min_px)
            cam = scene.train_views[0].camera
            for r in rows:
                objects.append({"scene": name, "segmenter": sname, **r})
            targets = [r["IoU"] for r in rows if r["target"]]
            scenes.append({
                "scene": name, "segmenter": sname, "size": f"{cam.width}x{cam.height}", "train views": len(scene.train_views),
                "objects (gt)": len(rows), "objects (3D)": info["prepared"].get("objects_3d", ""),
                "target IoU (mean)": float(np.mean(targets)), "target IoU (worst)": float(np.min(targets)),
                "all objects IoU (mean)": float(np.nanmean([r["IoU"] for r in rows])),
                "ms / view": info["timings"]["ms_per_view"], "prepare (s)": info["timings"]["prepare_seconds"], "stage wall (s)": round(wall, 2),
            })  # fmt: skip
            print(f"{name} {sname}: targets {scenes[-1]['target IoU (mean)']:.3f} (worst {scenes[-1]['target IoU (worst)']:.3f}), stage {wall:.1f} s", flush=True)
    sdf = pd.DataFrame(scenes).set_index(["scene", "segmenter"])
    odf = pd.DataFrame(objects).set_index(["scene", "segmenter", "object"])
    print(f"\nSegment stage, best-match IoU per object averaged over training views where it covers > {args.min_px} px; {args.threads} threads, torch {torch.__version__}\n")
    print(sdf.to_markdown(floatfmt=".3f"))
    print()
    print(odf.to_markdown(floatfmt=".3f"))
    if args.csv:
        odf.to_csv(args.csv)
    return 0


if __name__ == "__main__":
    sys.exit(main())
