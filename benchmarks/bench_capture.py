"""A removal on a capture without ground truth, scored by what can be measured without object-free
photos (docs/architecture.md, "Real captures"; :mod:`inpaint360gs.evaluate.capture`): PSNR against
the photos outside the footprint grown by 15 px (3DGS, removed, inpainted; training and held-out
views), what stands in the footprint column after removal and after inpainting, the fill's texture
and brightness against a 20-px ring, and the stage wall times of ``OUT/run.json``. Reads the OUT
folder of ``inpaint360gs run`` (the workflow's stages: ``inpaint360gs capture-scores``):

    python benchmarks/bench_capture.py data/kitchen outputs/kitchen --resize 4
    python benchmarks/bench_capture.py data/kitchen outputs/kitchen --resize 4 --figure docs/images/kitchen_removal.jpg --views IMG_03,IMG_12,IMG_19

Several runs (``inpaint360gs run --seed S`` into one OUT each) are scored one by one, then the median
and the worst of every score over them are printed against the run check's limits: a method is
judged by its worst run (``--figure`` then shows the run that loses the most PSNR outside the hole):

    python benchmarks/bench_capture.py data/kitchen runs/kitchen_s0 runs/kitchen_s1 runs/kitchen_s2 --resize 4

Works on synthetic scenes too (their ``test_`` views are not read).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("scene", type=Path)
    ap.add_argument("runs", type=Path, nargs="+", help="OUT of inpaint360gs run (several: one per seed)")
    ap.add_argument("--resize", type=int, default=None, help="the run's --resize (default: what its distill.json records)")
    ap.add_argument("--json", type=Path, default=None, help="also write the numbers here")
    ap.add_argument("--figure", type=Path, default=None, help="before / removed / inpainted at --views")
    ap.add_argument("--views", default="", help="comma-separated training views (default: 3 spread views)")
    ap.add_argument("--threads", type=int, default=2)
    args = ap.parse_args()

    import numpy as np

    from inpaint360gs.cli.common import set_threads
    from inpaint360gs.evaluate.capture import CaptureRun, figure, format_scores, format_worst_case, score_capture, worst_case
    from inpaint360gs.io.images import write_image
    from inpaint360gs.io.scene import load_scene

    set_threads(args.threads)
    resize = args.resize
    if resize is None:
        rec = args.runs[0] / "distill" / "distill.json"
        resize = int(json.loads(rec.read_text()).get("inputs", {}).get("resize", 1)) if rec.is_file() else 1
    scene = load_scene(args.scene, resize=resize, load_masks=False, unregistered="warn")
    every, worst_renders, worst_outside = [], None, None
    for run in args.runs:
        scores, renders = score_capture(scene, CaptureRun.of_run(run))
        rec = run / "run.json"
        if rec.is_file():
            scores["seconds"] = json.loads(rec.read_text()).get("seconds", {})
        print(f"{args.scene} (run {run}, resize {resize})")
        print(format_scores(scores))
        if scores.get("seconds"):
            print("Stage wall times (s): " + ", ".join(f"{k} {v:.0f}" for k, v in scores["seconds"].items()) + f"; total {sum(scores['seconds'].values()):.0f}")
        every.append({"run": str(run), **scores})
        # the worst run loses the most outside the hole from its own 3DGS (runs differ in their 3DGS)
        lost = max(row["3dgs"] - (row.get("inpainted") or row["removed"]) for row in scores["psnr_outside"].values())
        if worst_outside is None or lost > worst_outside:
            worst_renders, worst_outside = renders, lost
    summary = worst_case(every) if len(every) > 1 else None
    if summary is not None:
        totals = [sum(s["seconds"].values()) for s in every if s.get("seconds")]
        print(format_worst_case(summary, len(every)))
        if totals:
            print(f"  {'whole run (s)':26s} {float(np.median(totals)):8.0f} {max(totals):8.0f}")
    if args.json:
        data = every[0] if summary is None else {"runs": every, "worst_case": summary}
        args.json.write_text(json.dumps(data, indent=1) + "\n")
    if args.figure:
        train = [v.name for v in scene.train_views]
        names = [scene.view(n).name for n in args.views.split(",") if n] or [train[i] for i in np.linspace(0, len(train) - 1, 3).round().astype(int)]
        write_image(args.figure, figure(worst_renders, names))
        print(f"{args.figure}: rows = 3DGS with the object, after removal, after inpainting; views {names}" + ("; the worst run" if summary else ""))
    return 0


if __name__ == "__main__":
    from inpaint360gs.core.errors import InputError

    try:
        sys.exit(main())
    except (InputError, OSError) as e:  # one line naming the file and the problem, as the CLIs do
        sys.exit(f"bench_capture.py: error: {e}")
