"""Inpainting after removal on the embedded benchmark (paper Sec. 3.4-3.5, Tab. 1 and 3): the full
method against the two naive baselines and with each ablation switch b)-e) turned off alone, plus
multi-view consistency and stage times.

It reads what the workflow wrote (``make benchmark``: ``OUT/<scene>/<segmenter>/eval/<method>.json``
from ``inpaint360gs evaluate``, ``OUT/<scene>/<segmenter>/methods/<method>/inpaint.json`` from
``inpaint360gs inpaint``), so every number comes from the stages as users run them; scenes where a
method is missing are listed and left out of every average (all averages cover the same scenes).

Printed:

* per scene and on average: ``roi_psnr``, ``roi_lpips``, ``masked_psnr``, ``masked_lpips`` (and
  full-image PSNR/LPIPS) of every method (metric conventions: README "Metrics");
* checks: the full method beats (i) ``removal_only`` and (ii) ``per_view_2d`` on average on each of
  the four; each of ``abl_b`` .. ``abl_e`` is worse than ``full`` on average in ``roi_lpips`` or
  ``roi_psnr`` (``abl_a`` changes the association, measured by ``bench_object_field.py``, and is
  listed too);
* multi-view consistency: the photometric error between adjacent virtual views of the 2D inpainting,
  reprojected through the inpainted depth inside the filled region (``reprojection_error`` of
  ``inpaint.json``), with recursive conditioning (``full``) and without (``abl_d``);
* seconds of the inpainting stage per scene and part (virtual views, masks, 2D, 3D), and the whole
  pipeline's stage times from the workflow's ``benchmark:`` files.

    python benchmarks/bench_inpaint.py --out outputs [--segmenter geometric] [--scenes cone toys]
"""

from __future__ import annotations

import argparse
import json
import math
from pathlib import Path

METHODS = ["full", "removal_only", "per_view_2d", "abl_a", "abl_b", "abl_c", "abl_d", "abl_e"]
METRICS = [("roi_psnr", +1), ("roi_lpips", -1), ("masked_psnr", +1), ("masked_lpips", -1), ("psnr", +1), ("lpips", -1)]
STAGES = ["train_3dgs", "segment", "associate", "distill", "remove", "inpaint", "evaluate"]


def read_json(path: Path) -> dict | None:
    try:
        return json.loads(path.read_text())
    except (OSError, ValueError):
        return None


def bench_seconds(path: Path) -> float | None:
    """Mean wall seconds of a Snakemake benchmark file (None when it is missing or unreadable)."""
    from inpaint360gs.core.errors import InputError
    from inpaint360gs.report.records import read_benchmark

    try:
        return read_benchmark(path)["seconds"]
    except InputError:
        return None


def fmt(v, nd=3) -> str:
    return "—" if v is None or (isinstance(v, float) and not math.isfinite(v)) else f"{v:.{nd}f}"


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, required=True, help="the workflow's out_dir")
    ap.add_argument("--segmenter", default="geometric")
    ap.add_argument("--scenes", nargs="*", default=None, help="default: every scene with results")
    args = ap.parse_args()

    scenes = args.scenes or sorted(p.parent.parent.name for p in args.out.glob(f"*/{args.segmenter}/eval"))
    ev = {s: {m: read_json(args.out / s / args.segmenter / "eval" / f"{m}.json") for m in METHODS} for s in scenes}
    present = [m for m in METHODS if any(ev[s][m] for s in scenes)]
    complete = [s for s in scenes if all(ev[s][m] for m in present)]
    incomplete = sorted(set(scenes) - set(complete))
    print(f"segmenter {args.segmenter}; methods {present}; scenes with every method: {complete}" + (f"; left out (missing a method): {incomplete}" if incomplete else ""))

    def val(s, m, k):
        e = ev[s][m]
        v = None if e is None else e["mean"].get(k)
        return None if v is None else float(v)

    avg = {m: {k: sum(val(s, m, k) for s in complete) / len(complete) for k, _ in METRICS} for m in present} if complete else {}
    head = "| scene | method | " + " | ".join(k for k, _ in METRICS) + " |"
    print("\n" + head + "\n|" + "---|" * (len(METRICS) + 2))
    for s in complete + ["average"]:
        for m in present:
            row = avg[m] if s == "average" else {k: val(s, m, k) for k, _ in METRICS}
            print(f"| {s} | {m} | " + " | ".join(fmt(row[k]) for k, _ in METRICS) + " |")
    if not complete:
        return 1

    def better(a, b, k, sign):
        return sign * (a - b) > 0

    print("\nChecks on the average over", len(complete), "scene(s):")
    for base in ("removal_only", "per_view_2d"):
        if base in present and "full" in present:
            res = {k: better(avg["full"][k], avg[base][k], k, sg) for k, sg in METRICS[:4]}
            print(f"- full beats {base}: " + ", ".join(f"{k} {'yes' if ok else 'NO'} ({fmt(avg['full'][k])} vs {fmt(avg[base][k])})" for k, ok in res.items()))
    for ab in ("abl_a", "abl_b", "abl_c", "abl_d", "abl_e"):
        if ab in present and "full" in present:
            worse = {k: better(avg["full"][k], avg[ab][k], k, sg) for k, sg in METRICS[:2]}
            print(f"- {ab} worse than full in roi_lpips or roi_psnr: {'yes' if any(worse.values()) else 'NO'} "
                  f"(roi_psnr {fmt(avg[ab]['roi_psnr'])} vs {fmt(avg['full']['roi_psnr'])}, roi_lpips {fmt(avg[ab]['roi_lpips'])} vs {fmt(avg['full']['roi_lpips'])})")  # fmt: skip

    print("\nMulti-view consistency of the 2D inpainting (reprojection error between adjacent virtual views, filled region):")
    print("| scene | with conditioning (full) | without (abl_d) | share of pixels filled from earlier views |\n|---|---|---|---|")
    for s in complete:
        rec = {m: read_json(args.out / s / args.segmenter / "methods" / m / "inpaint.json") for m in ("full", "abl_d")}
        e = {m: (r or {}).get("reprojection_error") for m, r in rec.items()}
        print(f"| {s} | {fmt(e['full'], 4)} | {fmt(e['abl_d'], 4)} | {fmt((rec['full'] or {}).get('filled_from_earlier_views'), 3)} |")

    print("\nInpainting stage seconds (inpaint.json of `full`):")
    parts = ["visibility_s", "cameras_s", "occluders_s", "unseen_masks_s", "inpaint_2d_s", "init_s", "refine_3d_s", "total_s"]
    print("| scene | " + " | ".join(parts) + " |\n|" + "---|" * (len(parts) + 1))
    for s in complete:
        r = read_json(args.out / s / args.segmenter / "methods" / "full" / "inpaint.json") or {}
        sec = r.get("seconds", {})
        print(f"| {s} | " + " | ".join(fmt(sec.get(p), 1) for p in parts) + " |")

    print("\nWall seconds per stage of the full method (workflow benchmark files; the machine may be shared):")
    print("| scene | " + " | ".join(STAGES) + " | total |\n|" + "---|" * (len(STAGES) + 2))
    b = args.out / "benchmarks"
    for s in complete:
        paths = {
            "train_3dgs": b / s / "train_3dgs.tsv",
            "segment": b / s / args.segmenter / "segment.tsv",
            "associate": b / s / args.segmenter / "kom" / "associate.tsv",
            "distill": b / s / args.segmenter / "kom" / "distill.tsv",
            "remove": b / s / args.segmenter / "kom" / "remove.tsv",
            "inpaint": b / s / args.segmenter / "methods" / "full" / "inpaint.tsv",
            "evaluate": b / s / args.segmenter / "methods" / "full" / "evaluate.tsv",
        }
        secs = {k: bench_seconds(p) for k, p in paths.items()}
        total = sum(v for v in secs.values() if v is not None)
        print(f"| {s} | " + " | ".join(fmt(secs[k], 0) for k in STAGES) + f" | {total:.0f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
