"""Dataset building through COLMAP on the synthetic benchmark (the numbers of results/README.md's dataset-building table).

For each scene: render it with the generator, export the captures as plain photos (no poses), run
``build`` (joint pycolmap SfM, one shared camera, undistortion, leak removal) and score the result
against the generator's truth:

* registration: registered / total images;
* poses after Sim(3) alignment: max camera-centre error in % of the orbit radius, max rotation error;
* leaks: points without an object-inclusive observation (the removal rule; must be 0), and the
  geometric check with the visibility oracle (``synth_export.leak_check``) on the kept points and,
  for comparison, on the points the rule removed;
* unseen masks derived from the exact object masks vs the generator's exact unseen masks (IoU);
* build wall time (budget: <= 3 min for 64 images at 256x192 on this machine).

Usage: python benchmarks/bench_build.py [--scenes cone toys ...] [--matcher auto] [--json out.json]
Generated scenes are cached under --work (default /tmp/inpaint360gs_bench_build).

Real photos (no ground truth, so no pose or leak scores): ``--photos DIR [--sfm-max-size 1000 0 ...]``
builds DIR once per working size (``build --sfm-max-size``; 0 = full size) and prints registration,
points, reprojection error, where the time went and the CPU seconds, with the load average before
each run (timings mean little on a busy machine).
"""

from __future__ import annotations

import argparse
import json
import shutil
import time
from pathlib import Path

import cv2
import numpy as np


def run_scene(name: str, work: Path, matcher: str, camera_model: str) -> dict:
    from dataset_tools.capture.colmap import SfMConfig
    from dataset_tools.capture.leaks import leaked_point_ids, object_free_influence
    from dataset_tools.capture.pipeline import BuildConfig, build_dataset
    from dataset_tools.capture.synth_export import export_raw_captures, leak_check, object_free_observations, score_build, to_truth_frame
    from dataset_tools.capture.unseen import derive_unseen_masks, load_object_masks, mask_iou
    from dataset_tools.synth import generate_scene
    from inpaint360gs.io.colmap import read_model

    truth = work / "truth" / name
    if not (truth / "scene.json").is_file():
        generate_scene(name, work / "truth", overwrite=True)
    cap = work / "captures" / name
    if not cap.is_dir():
        export_raw_captures(truth, cap, object_masks=True, unseen_masks=True)
    out = work / "built" / f"{name}_{matcher}_{camera_model}"
    t0 = time.perf_counter()
    report = build_dataset(cap, out, BuildConfig(
        sfm=SfMConfig(matcher=matcher, camera_model=camera_model), unseen_masks=cap / "unseen_masks",
        overwrite=True, progress=False))
    build_s = time.perf_counter() - t0
    score = score_build(out, truth)
    rec = read_model(out / "sparse" / "0")
    pids = list(rec.points3D)
    kept = leak_check(truth, to_truth_frame(rec, truth, np.array([rec.point3D(p).xyz for p in pids])), score.leaks["tolerance_m"])
    flagged_test_obs = object_free_observations(rec, [pids[i] for i in np.flatnonzero(kept.leaked)])
    # how far the object-free observations move each kept point, in % of its distance to the nearest object-inclusive camera
    shift = object_free_influence(rec, pids, relative=True) * 100
    tol = score.leaks["tolerance_m"]
    removed = leak_check(truth, to_truth_frame(rec, truth, report.leaked_xyz), tol) if len(report.leaked_xyz) else None
    derived = derive_unseen_masks(out, load_object_masks(out, cap / "object_masks"))
    ious = [mask_iou(derived[n], cv2.imread(str(out / "unseen_mask" / n), 0) > 127) for n in sorted(derived)]
    return {
        "scene": name,
        "images": report.registration["total"],
        "registered": report.registration["registered"],
        "matcher": report.registration["matcher"],
        "center_err_max_pct": score.poses.center_err_max_pct,
        "center_err_mean_pct": score.poses.center_err_mean_pct,
        "rot_err_max_deg": score.poses.rot_err_max_deg,
        "rot_err_mean_deg": score.poses.rot_err_mean_deg,
        "points": report.points["final"],
        "removed_by_rule": report.points["leak_removal"]["removed"],
        "removed_single_view": report.points["leak_removal"]["removed_single_view"],
        "removed_small_angle": report.points["leak_removal"]["removed_small_angle"],
        "rule_violations": len(leaked_point_ids(rec)),
        "leak_tolerance_pct": 100 * tol / score.poses.orbit_radius,
        "geo_flagged_kept": score.leaks["leaked"],
        "geo_flagged_kept_with_test_obs": int((flagged_test_obs > 0).sum()),
        "geo_flagged_removed": int(removed.leaked.sum()) if removed is not None else 0,
        "off_surface_kept": score.leaks["off_surface"],
        "kept_with_test_obs": int(np.count_nonzero(shift)),
        "test_shift_median_pct": float(np.nanmedian(shift[shift > 0])) if np.any(shift > 0) else 0.0,
        "test_shift_p99_pct": float(np.nanpercentile(shift[shift > 0], 99)) if np.any(shift > 0) else 0.0,
        "test_shift_max_pct": float(np.nanmax(shift)) if len(shift) else 0.0,
        "flagged_test_shift_max_pct": float(np.nanmax(shift[kept.leaked], initial=0.0)),
        "unseen_iou_mean": float(np.mean(ious)),
        "unseen_iou_min": float(np.min(ious)),
        "reproj_px": report.points["mean_reprojection_error_px"],
        "build_s": build_s,
        "timings": report.timings,
    }


def run_photos(photos: Path, sizes: list[int], work: Path, repeat: int, seed: int, json_path: Path | None,
               matcher: str = "auto", camera_model: str = "SIMPLE_RADIAL", affine: bool = True) -> None:
    """Build a folder of real photos at each working size; print one row per run."""
    import os
    import resource

    from dataset_tools.capture.colmap import SfMConfig
    from dataset_tools.capture.pipeline import BuildConfig, build_dataset
    from dataset_tools.capture.posecheck import pose_accuracy, reconstruction_poses
    from inpaint360gs.io.colmap import read_model

    def cpu_s() -> float:
        r = resource.getrusage(resource.RUSAGE_SELF)
        return r.ru_utime + r.ru_stime

    stages = ("resize_s", "features_s", "matching_s", "mapping_s", "undistort_s", "write_s")
    print(f"{photos.resolve().parent.name}/{photos.name} ({'affine-covariant' if affine else 'plain'} SIFT)")
    print(f"{'max size':>8} {'SfM size':>10} {'reg':>7} {'points':>6} {'px full':>7} {'px SfM':>6} "
          + " ".join(f"{s[:-2]:>9}" for s in stages) + f" {'total s':>7} {'CPU s':>6} {'load':>5} {'Δctr%':>6} {'Δrot°':>6}"
          "  not registered")
    rows = []
    first = None  # poses of the first run: the others are compared with them
    for size in sizes:
        for k in range(repeat):
            load = os.getloadavg()[0]
            c0 = cpu_s()
            report = build_dataset(photos, work / f"photos_{size}", BuildConfig(
                sfm=SfMConfig(sfm_max_size=size, seed=seed + k, matcher=matcher, camera_model=camera_model,
                              estimate_affine_shape=affine), min_registered=0.0, overwrite=True, progress=False))
            cpu = cpu_s() - c0
            poses = reconstruction_poses(read_model(work / f"photos_{size}" / "sparse" / "0"))
            first = first or poses
            agree = pose_accuracy(poses, first) if len(set(poses) & set(first)) >= 3 else None
            reg, t = report.registration, report.timings
            row = {"sfm_max_size": size, "seed": seed + k, "sfm_size": reg["sfm_size"], "registered": reg["registered"],
                   "total": reg["total"], "unregistered": sorted(reg["unregistered"]), "points_sfm": report.points["sfm"],
                   "points": report.points["final"], "reproj_px": reg["mean_reprojection_error_px"],
                   "reproj_sfm_px": reg["sfm_reprojection_error_px"], "timings": t, "cpu_s": cpu, "load1": load,
                   "vs_first": agree.to_dict() if agree else None}
            rows.append(row)
            print(f"{size or 'full':>8} {'x'.join(map(str, reg['sfm_size'])):>10} {reg['registered']:>3}/{reg['total']:<3} "
                  f"{report.points['sfm']:6d} {row['reproj_px']:7.3f} {row['reproj_sfm_px']:6.3f} "
                  + " ".join(f"{t.get(s, 0.0):9.1f}" for s in stages)
                  + f" {t['total_s']:7.1f} {cpu:6.1f} {load:5.2f} "
                  + (f"{agree.center_err_max_pct:6.2f} {agree.rot_err_max_deg:6.2f}" if agree else f"{'-':>6} {'-':>6}")
                  + f"  {' '.join(row['unregistered']) or '-'}", flush=True)
    print("columns: points = SfM points (before leak removal); px full / px SfM = mean reprojection error in "
          "full-size pixels / in pixels of the working size; stage columns and total in wall seconds; CPU s = "
          "process CPU seconds (all threads); load = 1-min load average before the run; Δctr% / Δrot° = largest "
          "camera-centre (% of the camera spread) and rotation difference from the first run's poses after a "
          "similarity alignment")
    if json_path:
        json_path.write_text(json.dumps(rows, indent=2) + "\n")


def main() -> None:
    from dataset_tools.synth.catalogue import BENCHMARK_SCENES  # 'all': the ten classic scenes

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenes", nargs="*", default=["all"], help="scene names or 'all' (default)")
    ap.add_argument("--matcher", default="auto", choices=["auto", "exhaustive", "sequential"])
    ap.add_argument("--camera-model", default="SIMPLE_RADIAL")
    ap.add_argument("--work", type=Path, default=Path("/tmp/inpaint360gs_bench_build"))
    ap.add_argument("--json", type=Path, default=None)
    ap.add_argument("--clean", action="store_true", help="delete cached scenes first")
    ap.add_argument("--photos", type=Path, default=None, help="a folder of real photos (build's layouts) instead of the synthetic scenes")
    ap.add_argument("--sfm-max-size", type=int, nargs="+", default=None, metavar="PX",
                    help="--photos: working sizes to build at (default: build's default; 0 = full size)")
    ap.add_argument("--repeat", type=int, default=1, help="--photos: runs per size (seeds seed, seed+1, ...)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--no-affine-shape", action="store_true", help="--photos: plain SIFT (build --no-affine-shape)")
    args = ap.parse_args()
    if args.photos is not None:
        from dataset_tools.capture.colmap import SFM_MAX_SIZE

        cv2.setNumThreads(2)
        args.work.mkdir(parents=True, exist_ok=True)
        run_photos(args.photos, args.sfm_max_size or [SFM_MAX_SIZE], args.work, args.repeat, args.seed, args.json,
                   args.matcher, args.camera_model, not args.no_affine_shape)
        return
    if "all" in args.scenes:
        args.scenes = list(BENCHMARK_SCENES)
    cv2.setNumThreads(2)  # COLMAP runs with 2 threads (SfMConfig.num_threads); this machine has 2 cores
    if args.clean and args.work.exists():
        shutil.rmtree(args.work)
    args.work.mkdir(parents=True, exist_ok=True)

    rows = []
    hdr = (f"{'scene':8} {'imgs':>4} {'reg':>4} {'ctr%max':>7} {'rot°max':>7} {'points':>6} {'rule':>4} "
           f"{'removed':>7} {'1-view':>6} {'<1.5°':>5} {'τ%R':>5} {'geo kept':>8} {'w/ test':>7} {'geo rmvd':>8} {'testobs':>7} {'shift50':>7} {'shift99':>7} {'shiftmax':>8} {'IoU':>5} {'px':>5} {'build s':>7}")
    print(hdr)
    for name in args.scenes:
        r = run_scene(name, args.work, args.matcher, args.camera_model)
        rows.append(r)
        print(f"{r['scene']:8} {r['images']:4d} {r['registered']:4d} {r['center_err_max_pct']:7.3f} "
              f"{r['rot_err_max_deg']:7.3f} {r['points']:6d} {r['rule_violations']:4d} {r['removed_by_rule']:7d} {r['removed_single_view']:6d} {r['removed_small_angle']:5d} "
              f"{r['leak_tolerance_pct']:5.2f} {r['geo_flagged_kept']:8d} {r['geo_flagged_kept_with_test_obs']:7d} {r['geo_flagged_removed']:8d} {r['kept_with_test_obs']:7d} {r['test_shift_median_pct']:7.3f} {r['test_shift_p99_pct']:7.3f} {r['test_shift_max_pct']:8.3f} "
              f"{r['unseen_iou_mean']:5.3f} {r['reproj_px']:5.3f} {r['build_s']:7.1f}", flush=True)
    ok = [r["registered"] == r["images"] and r["center_err_max_pct"] <= 1.0 and r["rot_err_max_deg"] <= 0.5
          and r["rule_violations"] == 0 for r in rows]
    print(f"\ntargets (all registered, centre <= 1% R, rotation <= 0.5°, 0 points without an object-inclusive "
          f"observation): {sum(ok)}/{len(rows)} scenes; slowest build {max(r['build_s'] for r in rows):.1f} s "
          f"(budget 180 s); geometric check flags {sum(r['geo_flagged_kept'] for r in rows)} kept points in all, "
          f"{sum(r['geo_flagged_kept_with_test_obs'] for r in rows)} of them observed by an object-free view "
          f"(largest shift by object-free views among flagged points {max(r['flagged_test_shift_max_pct'] for r in rows):.3f}% of depth)")
    print("columns: rule = kept points with no object-inclusive observation; removed = points the rule deleted (1-view: by one object-inclusive view only, <1.5°: by rays within 1.5°); "
          "τ%R = leak-check tolerance (3x median distance to the nearest seen surface); geo kept/rmvd = points the "
          "oracle check flags among kept/removed ones (w/ test: flagged kept points an object-free view observes); testobs = kept points an object-free view observes; shift50/99/max = median/99th percentile/max over them of how far the object-free observations move the point (triangulation with vs without them, % of its distance to the nearest object-inclusive camera); IoU = derived vs exact unseen masks")
    if args.json:
        args.json.write_text(json.dumps(rows, indent=2) + "\n")


if __name__ == "__main__":
    main()
