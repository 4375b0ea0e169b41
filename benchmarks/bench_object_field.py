"""The object-aware Gaussian field on the embedded benchmark, scored against the generator's ground
truth: association consistency, rendered id maps after distillation, removal residual / collateral /
AMCR, and stage timings (paper Sec. 3.2-3.4, supp. Eq. 1).

For every scene it runs ``inpaint360gs run --until remove`` (through :class:`Runner`, skipping stages
that are up to date) on a trained 3DGS, with the default segmenter, the ``oracle`` segmenter, and
ablation a) (2D tracking instead of Key Object Management) on the oracle masks, then prints:

* association: for each ground-truth object and each training view where it covers > 50 px, the
  associated id covering most of its pixels; "consistency" = share of those views where that id is
  the object's most frequent one (and not background). Target >= 95%.
* id map IoU: the distilled field's rendered id map on the HELD-OUT views vs ``gt/instance``, each
  object matched to its most frequent associated id; mean over objects. Target >= 0.85.
* removal (training views): residual, collateral and AMCR against the true footprint share, the
  library's ground-truth removal scores (docs/architecture.md, "Ground-truth removal scores"; the
  limits there: residual and collateral <= 1 %, AMCR <= 1.5x the true footprint share).

Ground truth is read here only, for scoring; the method stages never see it (except the oracle
segmenter, whose rows are labelled).

    python benchmarks/bench_object_field.py --data data/synthetic --models outputs --work outputs/bench_object_field --scenes all
    python benchmarks/bench_object_field.py --data data/synthetic --workflow outputs --variants geometric/kom geometric/tracker   # score the workflow's runs (--seed: which seed's)
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]


def scene_names(spec: list[str]) -> list[str]:
    from dataset_tools.synth.catalogue import BENCHMARK_SCENES  # 'all': the ten classic scenes

    return list(BENCHMARK_SCENES) if spec == ["all"] else spec


def gt_instance(scene_dir: Path, view) -> np.ndarray:
    from PIL import Image

    return np.asarray(Image.open(scene_dir / "gt" / "instance" / f"{view.stem}.png"))


def association_scores(scene, scene_dir: Path, assoc_dir: Path, objects: list[int]) -> tuple[dict, dict]:
    """Per object: consistency over training views, and its most frequent associated id."""
    from inpaint360gs.io.images import read_mask

    votes: dict[int, list[int]] = {o: [] for o in objects}
    for v in scene.train_views:
        gt = gt_instance(scene_dir, v)
        assoc = read_mask(assoc_dir / "object_mask" / f"{v.stem}.png")
        for o in objects:
            px = gt == o
            if px.sum() > 50:
                votes[o].append(int(np.bincount(assoc[px].ravel()).argmax()))
    cons, match = {}, {}
    for o, ids in votes.items():
        if not ids:
            continue
        modal = int(np.bincount(ids).argmax())
        match[o] = modal
        cons[o] = float(np.mean([i == modal and i != 0 for i in ids]))
    return cons, match


def idmap_iou(field, scene, scene_dir: Path, match: dict) -> dict:
    inter = {o: 0 for o in match}
    union = {o: 0 for o in match}
    for v in scene.holdout_views:
        ids, _ = field.render_ids(v.camera)
        ids = ids.numpy()
        gt = gt_instance(scene_dir, v)
        for o, a in match.items():
            p, g = ids == a, gt == o
            inter[o] += int((p & g).sum())
            union[o] += int((p | g).sum())
    return {o: inter[o] / union[o] for o in match if union[o] > 0}


def removal_scores(removed_dir: Path, scene) -> dict:
    """The library's ground-truth removal scores (:func:`inpaint360gs.evaluate.removal.removal_scores`,
    the workflow's `score_removal` rule; correct for scenes posed by structure from motion too)."""
    from inpaint360gs.evaluate.removal import removal_scores as scores

    s = scores(removed_dir, scene)["scores"]
    info = json.loads((removed_dir / "removal.json").read_text())
    return {
        "residual_percent": s["residual"],
        "collateral_percent": s["collateral"],
        "amcr_percent": s["amcr"],
        "gt_footprint_percent": s["gt_footprint_share"],
        "amcr_ratio": s["amcr_ratio"],
        "removal_seconds": info.get("seconds"),
    }


def run_variant(scene_dir: Path, model: Path, out: Path, segmenter: str, association: str, threads: int) -> dict:
    from inpaint360gs.io.scene import load_scene
    from inpaint360gs.pipeline.run import RunConfig, Runner
    from inpaint360gs.associate.config import AssociationConfig

    scene = load_scene(scene_dir, load_masks=False)
    cfg = RunConfig(segmenter=segmenter, association=AssociationConfig(method=association).resolved())
    runner = Runner(scene, out, cfg, model=model, progress=False)
    t = {}
    for stage in ("segment", "associate", "distill", "remove"):
        t0 = time.perf_counter()
        what = dict(runner.run(stage))[stage]
        t[stage] = round(time.perf_counter() - t0, 1) if what == "ran" else None
    return {"scene": scene, "runner": runner, "seconds": t}


def workflow_variant(out: Path, scene_dir: Path, name: str, segmenter: str, association: str) -> dict:
    """The same stages as the workflow ran them (``make benchmark``): folders under
    ``OUT/<scene>/seed<k>/<segmenter>/<association>/`` (``segmenter`` = ``seed<k>/<segmenter>``),
    stage seconds from its ``benchmark:`` files."""
    from types import SimpleNamespace

    from inpaint360gs.core.errors import InputError
    from inpaint360gs.io.scene import load_scene
    from inpaint360gs.report.records import read_benchmark

    base = out / name / segmenter
    lay = SimpleNamespace(associate=base / association / "associate", distill=base / association / "distill", removed=base / association / "removed")
    bench = out / "benchmarks" / name / segmenter
    t = {}
    for stage, tsv in (("segment", bench / "segment.tsv"), ("associate", bench / association / "associate.tsv"),
                       ("distill", bench / association / "distill.tsv"), ("remove", bench / association / "remove.tsv")):  # fmt: skip
        try:
            t[stage] = round(read_benchmark(tsv)["seconds"], 1)
        except InputError:
            t[stage] = None
    return {"scene": load_scene(scene_dir, load_masks=False), "runner": SimpleNamespace(layout=lay), "seconds": t}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, default=ROOT / "data" / "synthetic", help="generated scene folders")
    ap.add_argument("--models", type=Path, default=ROOT / "outputs", help="trained 3DGS: MODELS/<scene>/3dgs/point_cloud.ply")
    ap.add_argument("--work", type=Path, default=ROOT / "outputs" / "bench_object_field")
    ap.add_argument("--scenes", nargs="+", default=["all"])
    ap.add_argument("--variants", nargs="+", default=["geometric/kom", "oracle/kom", "oracle/tracker"], help="segmenter/association pairs")
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--json", type=Path, default=None, help="also write the rows here")
    ap.add_argument("--workflow", type=Path, default=None, help="score what the workflow wrote under this out_dir instead of running the stages")
    ap.add_argument("--seed", type=int, default=0, help="with --workflow: which of its seeds (OUT/<scene>/seed<k>/)")
    args = ap.parse_args()
    sys.path.insert(0, str(ROOT))
    from inpaint360gs.cli.common import set_threads

    set_threads(args.threads)  # also makes torch's first multi-threaded vector-math call reproducible
    from inpaint360gs.distill.field import IdentityField

    rows = []
    for name in scene_names(args.scenes):
        scene_dir = args.data / name
        model = args.models / name / "3dgs" / "point_cloud.ply"
        meta = json.loads((scene_dir / "gt" / "objects.json").read_text())
        objects = [o["id"] for o in meta]
        targets = [o["id"] for o in meta if o["removal_target"]]
        for variant in args.variants:
            segmenter, association = variant.split("/")
            if args.workflow is not None:
                run = f"seed{args.seed}/{segmenter}"
                if not (args.workflow / name / run / association / "removed" / "removal.json").is_file():
                    continue
                r = workflow_variant(args.workflow, scene_dir, name, run, association)
            else:
                r = run_variant(scene_dir, model, args.work / name / variant.replace("/", "_"), segmenter, association, args.threads)
            lay = r["runner"].layout
            cons, match = association_scores(r["scene"], scene_dir, lay.associate, objects)
            field = IdentityField.load(lay.distill)
            ious = idmap_iou(field, r["scene"], scene_dir, match)
            rem = removal_scores(Path(lay.removed), r["scene"])
            row = {
                "scene": name, "segmenter": segmenter, "association": association,
                "consistency_min": min(cons.values()) if cons else None, "consistency_targets": float(np.mean([cons[t] for t in targets if t in cons])),
                "idmap_iou_mean": float(np.mean(list(ious.values()))) if ious else None,
                "idmap_iou_targets": float(np.mean([ious[t] for t in targets if t in ious])) if any(t in ious for t in targets) else None,
                **rem, "seconds": r["seconds"],
            }  # fmt: skip
            rows.append(row)
            print(json.dumps(row), flush=True)
    cols = ["scene", "segmenter", "association", "consistency_min", "consistency_targets", "idmap_iou_mean", "idmap_iou_targets",
            "residual_percent", "collateral_percent", "amcr_percent", "gt_footprint_percent", "amcr_ratio"]  # fmt: skip
    print("\n| " + " | ".join(cols) + " | stage seconds (segment, associate, distill, remove) |")
    print("|" + "---|" * (len(cols) + 1))
    for r in rows:
        cells = [f"{r[c]:.3f}" if isinstance(r[c], float) else str(r[c]) for c in cols]
        s = r["seconds"]
        print("| " + " | ".join(cells) + f" | {s['segment']}, {s['associate']}, {s['distill']}, {s['remove']} |")
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))
    return 0


if __name__ == "__main__":
    sys.exit(main())
