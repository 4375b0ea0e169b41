"""2D inpainters (paper Sec. 3.5) on the embedded benchmark's ground truth: the measured choice of
the RGB and depth defaults of ``inpaint360gs.inpaint.inpainters``.

For each scene under ``--data`` and each of its ``test_*`` views with a non-empty ``unseen_mask``
(255 = the region an inpainting method must hallucinate), the object-free ground-truth image is
inpainted inside that mask by every method and scored against itself inside the mask:

- RGB: PSNR over the mask pixels (per image, then averaged), ROI LPIPS (the VGG LPIPS spatial map
  averaged over mask pixels, the ``roi_*`` convention of docs/architecture.md) when
  ``inpaint360gs.metrics.lpips`` is importable, and seconds per image;
- depth: ``gt/depth/<stem>.npy`` (exact z-depth of the object-free view) inpainted inside the same
  mask, median absolute relative error over the mask pixels (per image, then averaged), the share
  of mask pixels off by more than 5%, and seconds per image.

This is a measurement, not a method stage, so it reads ground truth (test pixels and ``gt/``).
Timings are medians over the images in this one process (docs/architecture.md, "Environment").

    python benchmarks/bench_inpainters.py                          # every ready scene in /work/data/synthetic
    python benchmarks/bench_inpainters.py --data DIR --scenes cone toys --lama-onnx lama.onnx
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import subprocess
import sys
import time
from datetime import datetime, timezone
from pathlib import Path

import numpy as np
import pandas as pd

DEFAULT_DATA = Path("/work/data/synthetic")
RELATIVE_TOLERANCE = 0.05


def _commit() -> str:
    try:
        out = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, cwd=Path(__file__).parent)
        dirty = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], capture_output=True, text=True, cwd=Path(__file__).parent)
        return out.stdout.strip() + ("+changes" if dirty.stdout.strip() else "")
    except OSError:
        return "unknown"


def _lpips_roi():
    """ROI LPIPS function (img, ref, mask) -> float, or (None, reason)."""
    try:
        import torch

        from inpaint360gs.metrics.lpips import lpips_map
    except ImportError as e:
        return None, f"LPIPS column skipped: inpaint360gs.metrics.lpips is not importable ({e})"

    def roi(img: np.ndarray, ref: np.ndarray, mask: np.ndarray) -> float:
        a = torch.from_numpy(np.ascontiguousarray(img.transpose(2, 0, 1), dtype=np.float32))
        b = torch.from_numpy(np.ascontiguousarray(ref.transpose(2, 0, 1), dtype=np.float32))
        with torch.inference_mode():
            m = lpips_map(a, b)[0, 0].numpy()
        return float(m[mask].mean())

    return roi, "LPIPS: VGG, spatial map averaged over mask pixels (roi convention)"


def _views(scene_dir: Path):
    """(stem, image float (H, W, 3), mask bool, depth or None) of the test views with a non-empty unseen mask."""
    from inpaint360gs.io.scene import load_scene

    scene = load_scene(scene_dir)
    for v in scene.test_views:
        if not scene.has_mask(v):
            continue
        mask = scene.load_mask(v)
        if not mask.any() or mask.all():
            continue
        img = scene.load_image(v, allow_test=True).numpy()
        dpath = scene_dir / "gt" / "depth" / f"{v.stem}.npy"
        depth = np.load(dpath).astype(np.float32) if dpath.is_file() else None
        yield v.stem, img, mask, depth


def _make(spec: str, opts: dict):
    """``name`` or ``name:key=value,key=value`` (a variant with options, e.g. ``plane:planes=1``)."""
    from inpaint360gs.inpaint.inpainters import make_inpainter

    name, _, rest = spec.partition(":")
    extra = {}
    for kv in filter(None, rest.split(",")):
        k, _, v = kv.partition("=")
        extra[k] = float(v) if "." in v else int(v) if v.lstrip("-").isdigit() else v
    return make_inpainter(name, **{**opts, **extra})


def _psnr(out: np.ndarray, ref: np.ndarray, mask: np.ndarray) -> float:
    mse = float(np.mean((out[mask].astype(np.float64) - ref[mask]) ** 2))
    return float("inf") if mse == 0 else 10.0 * np.log10(1.0 / mse)


def main() -> int:
    from inpaint360gs.inpaint.inpainters import DEFAULT_DEPTH, DEFAULT_RGB, DEPTH_METHODS, RGB_METHODS

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--data", type=Path, nargs="+", default=[DEFAULT_DATA], help="folders of scenes")
    ap.add_argument("--scenes", nargs="+", help="scene names (default: every scene folder with test views)")
    ap.add_argument("--rgb", nargs="+", help=f"RGB methods, 'none', or variants name:key=value,... (default: {' '.join(m for m in RGB_METHODS if m != 'lama')}, + lama with --lama-onnx)")
    ap.add_argument("--depth", nargs="+", help="depth methods, 'none', or variants (default: all, lama only with --lama-onnx)")
    ap.add_argument("--lama-onnx", type=Path, help="LaMa ONNX checkpoint (default: $INPAINT360GS_LAMA_ONNX)")
    ap.add_argument("--no-lpips", action="store_true")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--depth-noise", type=float, default=0.0,
                    help="multiply known depth by (1 + N(0, sigma)) before inpainting (seeded; scored against the clean depth): "
                    "a stand-in for the noise of rendered depth")
    ap.add_argument("--per-scene", action="store_true", help="also print one table per scene")
    args = ap.parse_args()

    lama = args.lama_onnx or os.environ.get("INPAINT360GS_LAMA_ONNX")
    rgb_methods = args.rgb or [m for m in RGB_METHODS if m != "lama" or lama]
    depth_methods = args.depth or [m for m in DEPTH_METHODS if m != "lama" or lama]
    rgb_methods, depth_methods = ([m for m in ms if m != "none"] for ms in (rgb_methods, depth_methods))
    opts = {"seed": args.seed, **({"lama_onnx": lama} if lama else {})}
    rgb_inp = {m: _make(m, opts) for m in rgb_methods}
    depth_inp = {m: _make(m, opts) for m in depth_methods}
    lpips_fn, lpips_note = (None, "LPIPS column skipped (--no-lpips)") if args.no_lpips or not rgb_methods else _lpips_roi()

    scene_dirs = []
    for root in args.data:
        names = args.scenes or sorted(p.name for p in root.iterdir() if (p / "unseen_mask").is_dir())
        scene_dirs += [root / n for n in names if (root / n / "unseen_mask").is_dir()]
    if not scene_dirs:
        print("no scenes with unseen masks found", file=sys.stderr)
        return 2

    print(f"commit {_commit()}, {datetime.now(timezone.utc):%Y-%m-%d %H:%M} UTC, {os.cpu_count()} cores, python {platform.python_version()}")
    print(f"defaults in the module: rgb={DEFAULT_RGB}, depth={DEFAULT_DEPTH}; seed {args.seed}; {lpips_note}")
    if args.depth_noise > 0:
        print(f"known depth multiplied by 1 + N(0, {args.depth_noise}) before inpainting; errors against the clean depth")
    rgb_rows, depth_rows = [], []
    warm = False
    for sd in scene_dirs:
        key = f"{sd.parent.name}/{sd.name}"
        views = list(_views(sd))
        h, w = views[0][1].shape[:2] if views else (0, 0)
        print(f"{sd}: {len(views)} test views with an unseen mask, {w}x{h}, mask share {np.mean([v[2].mean() for v in views]):.3f}", flush=True)
        if not warm and views:  # imports, compilation and session start-up out of the timings
            for inp in rgb_inp.values():
                inp.rgb(views[0][1], views[0][2])
            for inp in depth_inp.values():
                if views[0][3] is not None:
                    inp.depth(views[0][3], views[0][2])
            warm = True
        for stem, img, mask, depth in views:
            for name, inp in rgb_inp.items():
                t0 = time.perf_counter()
                out = inp.rgb(img, mask)
                dt = time.perf_counter() - t0
                assert np.array_equal(out[~mask], img[~mask])
                row = {"scene": key, "size": f"{w}x{h}", "view": stem, "method": name, "PSNR": _psnr(out, img, mask), "s": dt}
                if lpips_fn is not None:
                    row["LPIPS"] = lpips_fn(out, img, mask)
                rgb_rows.append(row)
            if depth is None:
                continue
            given = depth
            if args.depth_noise > 0:
                noise = np.random.default_rng([args.seed, len(depth_rows)]).normal(0.0, args.depth_noise, depth.shape)
                given = (depth * np.clip(1.0 + noise, 0.5, 1.5)).astype(np.float32)
            for name, inp in depth_inp.items():
                t0 = time.perf_counter()
                out = inp.depth(given, mask)
                dt = time.perf_counter() - t0
                assert np.array_equal(out[~mask], given[~mask])
                rel = np.abs(out[mask].astype(np.float64) - depth[mask]) / depth[mask]
                depth_rows.append({"scene": key, "size": f"{w}x{h}", "view": stem, "method": name, "median abs rel": float(np.median(rel)),
                                   "mean abs rel": float(rel.mean()), f"> {RELATIVE_TOLERANCE:.0%}": float(np.mean(rel > RELATIVE_TOLERANCE)), "s": dt})  # fmt: skip

    def table(rows, order, sort_key, ascending):
        df = pd.DataFrame(rows)
        agg = {c: "mean" for c in df.columns if c not in ("scene", "size", "view", "method", "s")}
        agg["view"] = "count"
        out = df.groupby("method").agg(agg).rename(columns={"view": "images"})
        for size in sorted(df["size"].unique(), key=lambda s: -int(s.split("x")[0])):  # median seconds per image, per size
            out[f"median s / image {size}"] = df[df["size"] == size].groupby("method")["s"].median()
        return out.reindex(order).sort_values(sort_key, ascending=ascending)

    pd.set_option("display.width", 200)
    if rgb_rows:
        df = table(rgb_rows, rgb_methods, "PSNR", False)
        print("\nRGB inside the unseen mask, all scenes (PSNR over mask pixels per image, then mean; higher better)\n")
        print(df.to_markdown(floatfmt=".4g"))
    if depth_rows:
        df = table(depth_rows, depth_methods, "median abs rel", True)
        print("\nDepth inside the unseen mask, all scenes (median |d - gt| / gt over mask pixels per image, then mean; lower better)\n")
        print(df.to_markdown(floatfmt=".4g"))
    if args.per_scene:
        for sd in scene_dirs:
            key = f"{sd.parent.name}/{sd.name}"
            r = [x for x in rgb_rows if x["scene"] == key]
            d = [x for x in depth_rows if x["scene"] == key]
            print(f"\n{key} ({sd})\n")
            if r:
                print(table(r, rgb_methods, "PSNR", False).to_markdown(floatfmt=".4g"))
            if d:
                print()
                print(table(d, depth_methods, "median abs rel", True).to_markdown(floatfmt=".4g"))
    return 0


if __name__ == "__main__":
    sys.exit(main())
