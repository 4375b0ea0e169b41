"""``inpaint360gs table record`` and ``table paper``: the paper's tables (Tabs. 1-3, supp. per-scene
and detailed runtime) from hand-made evaluation JSONs and Snakemake benchmark files; the averages
against hand computation, the best / second / third marks, scene sets that differ, bad input."""

from __future__ import annotations

import json
import math
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from inpaint360gs.cli import main
from inpaint360gs.report.records import MEAN_METRICS

HEADER = "s\th:m:s\tmax_rss\tmax_vms\tmax_uss\tmax_pss\tio_in\tio_out\tmean_load\tcpu_time"
SHA = "ab" * 32


def eval_json(path: Path, psnr: float, ssim: float, lpips: float, fid: float | None = None, fd: float = 10.0) -> str:
    """An evaluation JSON shaped like ``inpaint360gs evaluate``'s: masked_* = value + 10 (PSNR),
    roi_* = value - 1 (PSNR); SSIM/LPIPS variants the same value; AMCR 6 %."""
    mean = {}
    for k in MEAN_METRICS:
        base = {"psnr": psnr, "ssim": ssim, "lpips": lpips, "lpips_alex": lpips}[k.split("_", 1)[1] if k.startswith(("masked_", "roi_")) else k]
        mean[k] = base + (10.0 if k == "masked_psnr" else -1.0 if k == "roi_psnr" else 0.0)
    data = {
        "scene": "data/x", "renders_dir": str(path.parent / "renders"), "num_views": 3, "mean": mean,
        "scene_metrics": {"fid": fid, "fd_vgg16": fd, "kid_vgg16": 0.01, "unseen_share": 5.0, "amcr": 6.0, "silhouette_test": 16.0,
                          "roi_depth_off": 10.0},
        "null_reasons": {"per_view": {}, "mean": {}, "scene_metrics": {} if fid is not None else {"fid": "no Inception weights"}},
        "weights": {"lpips_vgg": {"path": "/somewhere/vgg16.ckpt", "sha256": SHA}, "inception": None},
    }
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data))
    return str(path)


def scores_json(path: Path, residual: float = 0.2, collateral: float = 0.1, footprint: float = 5.0, amcr: float = 6.0) -> str:
    """A removal scores JSON shaped like ``inpaint360gs score-removal``'s."""
    data = {"scene": "data/x", "removal": str(path.parent / "removed"),
            "scores": {"amcr": amcr, "residual": residual, "collateral": collateral, "gt_footprint_share": footprint,
                       "amcr_ratio": amcr / footprint}, "null_reasons": {}}
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(data))
    return str(path)


def bench(path: Path, *seconds: float, rss: str = "512.5") -> str:
    rows = [f"{s}\t0:00:{int(s):02d}\t{rss}\t900\t400\t450\t1\t2\t50\t{s * 1.5}" for s in seconds]
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text("\n".join([HEADER, *rows]) + "\n")
    return str(path)


def cli(capsys, *argv: str) -> tuple[int, str, str]:
    capsys.readouterr()
    code = main(list(argv))
    out, err = capsys.readouterr()
    return code, out, err


def record(capsys, out: Path, labels: dict, *extra: str) -> str:
    argv = ["table", "record", str(out)]
    for k, v in labels.items():
        argv += ["--label", f"{k}={v}"]
    code, _, err = cli(capsys, *argv, *extra)
    assert code == 0, err
    return str(out)


def test_record_holds_metrics_stage_times_and_storage(tmp_path, capsys):
    ev = eval_json(tmp_path / "eval.json", 25.0, 0.8, 0.1)
    (tmp_path / "a.ply").write_bytes(b"ply\n" + bytes(1996))
    (tmp_path / "b.ply").write_bytes(b"ply\n" + bytes(2996))
    out = record(capsys, tmp_path / "rec.json", {"scene": "cone", "method": "full", "segmenter": "geometric"},
                 "--eval", ev, "--stage", f"train={bench(tmp_path / 't.tsv', 100, 140)}",
                 "--stage", f"inpaint={bench(tmp_path / 'i.tsv', 60, rss='NA')}",
                 "--model", str(tmp_path / "a.ply"), str(tmp_path / "b.ply"))
    rec = json.loads(Path(out).read_text())
    assert rec["labels"] == {"scene": "cone", "method": "full", "segmenter": "geometric", "kind": "method"}
    assert rec["metrics"]["psnr"] == 25.0 and rec["metrics"]["masked_psnr"] == 35.0 and rec["metrics"]["roi_lpips"] == 0.1
    assert rec["metrics"]["fid"] is None and rec["null_reasons"]["fid"] == "no Inception weights"
    assert rec["metrics"]["fd_vgg16"] == 10.0 and rec["skip_reason"] is None
    assert rec["stages"]["train"]["seconds"] == 120.0 and rec["stages"]["train"]["repeats"] == 2
    assert rec["stages"]["train"]["max_rss_mb"] == 512.5 and rec["stages"]["train"]["cpu_seconds"] == 180.0
    assert rec["stages"]["inpaint"]["max_rss_mb"] is None
    assert rec["model"]["bytes"] == 5000 and rec["model"]["storage_mb"] == pytest.approx(0.005)
    assert rec["weights"]["lpips_vgg"]["sha256"] == SHA


def test_record_without_ground_truth_needs_a_reason(tmp_path, capsys):
    labels = ["--label", "scene=kitchen", "--label", "method=full", "--label", "segmenter=geometric"]
    code, _, err = cli(capsys, "table", "record", str(tmp_path / "r.json"), *labels)
    assert code == 2 and len(err.strip().splitlines()) == 1 and "--skip-reason" in err
    assert not (tmp_path / "r.json").exists()
    code, _, err = cli(capsys, "table", "record", str(tmp_path / "r.json"), *labels, "--skip-reason", "no ground truth")
    assert code == 0, err
    rec = json.loads((tmp_path / "r.json").read_text())
    assert all(v is None for v in rec["metrics"].values()) and rec["skip_reason"] == "no ground truth"


# --- the paper's tables ------------------------------------------------------------------------

# (method, segmenter, kind, extra labels) -> scene -> (psnr, ssim, lpips); every run at seeds 0 and 1,
# seed k adding 0.3 * k to the PSNR (so differences between rows are the same at both seeds). Tab. 1
# compares s1, s2, s5 (spin has no s3); the ablations a) and e) share s1-s3 with the method, b) only s1, s2.
RUNS = {
    ("spin", "none", "baseline", (("name", "SPIn-NeRF"),)): {"s1": (20, 0.95, 0.5), "s2": (21, 0.95, 0.4), "s5": (22, 0.95, 0.45)},  # no s3
    ("gaug", "none", "baseline", (("name", "GauGroup"),)): {"s1": (24, 0.7, 0.3), "s2": (22, 0.7, 0.1), "s3": (23, 0.7, 0.2), "s5": (23.5, 0.7, 0.15)},
    ("full", "geometric", "method", ()): {"s1": (25, 0.8, 0.1), "s2": (27, 0.9, 0.2), "s3": (26, 0.85, 0.15), "s5": (26.5, 0.85, 0.18)},
    ("wo_depth_init", "geometric", "ablation", ()): {"s1": (24, 0.8, 0.2), "s2": (25, 0.8, 0.2)},  # its own block: no s3
    ("tracker", "geometric", "ablation", (("ablation", "a"), ("name", "2D tracker association"))): {"s1": (23, 0.7, 0.3), "s2": (24, 0.7, 0.3), "s3": (1, 0.1, 0.9)},
    ("wo_hybrid", "geometric", "ablation", ()): {"s1": (25.1, 0.8, 0.1), "s2": (26.9, 0.9, 0.2), "s3": (26, 0.85, 0.15)},  # no effect
}
SEEDS = (0, 1)
COMMON = ("s1", "s2", "s5")  # the runs every row of Tab. 1 has
# removal scores above a limit (the others: residual 0.2 %, collateral 0.1 %, AMCR 1.2x the true footprint)
ABOVE = {("full", "s2", 1): {"residual": 3.5}, ("gaug", "s1", 0): {"footprint": 3.0}}
# stage -> seconds per (method, scene); gaug has only a training stage
STAGES = {
    ("full", "s1"): {"train": (100, 140), "inpaint": (60,), "evaluate": (30,)},
    ("full", "s2"): {"train": (180,), "inpaint": (120,), "evaluate": (30,)},
    ("full", "s3"): {"train": (600,), "inpaint": (600,), "evaluate": (30,)},
    ("gaug", "s1"): {"train": (300,)},
    ("gaug", "s2"): {"train": (420,)},
}


@pytest.fixture
def records(tmp_path, capsys) -> list[str]:
    paths = []
    for (method, seg, kind, extra), scenes in RUNS.items():
        for scene, (psnr, ssim, lpips) in scenes.items():
            for seed in SEEDS:
                d = tmp_path / "runs" / method / scene / str(seed)
                args = ["--eval", eval_json(d / "eval.json", psnr + 0.3 * seed, ssim, lpips, fd=100 - psnr),
                        "--removal-scores", scores_json(d / "scores.json", **ABOVE.get((method, scene, seed), {}))]
                for stage, secs in STAGES.get((method, scene), {}).items():
                    args += ["--stage", f"{stage}={bench(d / f'{stage}.tsv', *secs)}"]
                if method == "full":
                    (d / "point_cloud.ply").write_bytes(b"ply\n" + bytes(1_999_996))
                    args += ["--model", str(d / "point_cloud.ply")]
                labels = {"scene": scene, "method": method, "segmenter": seg, "kind": kind, "seed": seed, **dict(extra)}
                paths.append(record(capsys, d / "record.json", labels, *args))
    # a scene without ground truth: listed, never averaged
    paths.append(record(capsys, tmp_path / "runs" / "full" / "s4" / "record.json", {"scene": "s4", "method": "full", "segmenter": "geometric", "seed": 0},
                        "--skip-reason", "no object-free captures"))
    return paths


def _paper(capsys, tmp_path, paths, *extra) -> tuple[int, str]:
    code, _, err = cli(capsys, "table", "paper", *paths, "--out-dir", str(tmp_path / "tables"), *extra)
    return code, err


def _read(csv: Path) -> pd.DataFrame:
    """A table's CSV with numbers as numbers and the empty text cells (marks, labels) as ''."""
    df = pd.read_csv(csv)
    for c in df.columns:
        if df[c].dtype == object or c.endswith("_mark"):
            df[c] = df[c].astype(object).where(df[c].notna(), "")
    return df


def _md_rows(md: str) -> dict[str, list[str]]:
    return {line.split("|")[1].strip(): [c.strip() for c in line.split("|")[1:-1]] for line in md.splitlines() if line.startswith("| ") and "---" not in line}


def _runs(method: str, metric: str, scenes=COMMON) -> dict:
    """The fixture's values of ``metric`` per (scene, seed), as the tables pair them."""
    key = next(k for k in RUNS if k[0] == method)
    i = {"psnr": 0, "ssim": 1, "lpips": 2}[metric]
    return {(s, str(k)): RUNS[key][s][i] + (0.3 * k if metric == "psnr" else 0.0) for s in scenes for k in SEEDS}


def test_table1_means_seed_spread_intervals_and_marks(tmp_path, capsys, records):
    from inpaint360gs.report.stats import paired_difference, seed_spread

    cfg = tmp_path / "config.yaml"
    cfg.write_text("seed: 7\nscenes: [s1, s2]\n")
    code, err = _paper(capsys, tmp_path, records, "--config", str(cfg))
    assert code == 0, err
    out = tmp_path / "tables"
    names = {p.name for p in out.iterdir()}
    for t in ("per_scene", "table1_average", "table3_ablation", "table2_runtime", "table2_runtime_detail"):
        assert {f"{t}.csv", f"{t}.md", f"{t}.tex"} <= names
    assert "provenance.json" in names and not [n for n in names if n.startswith(".")]

    # means over the runs every row has (spin has no s3: s1, s2 and s5 at both seeds), baselines first
    t1 = _read(out / "table1_average.csv")
    means = t1[t1["row_type"] == "mean"].set_index("method")
    assert list(means.index) == ["spin", "gaug", "full"]
    assert means.loc["full", "psnr"] == pytest.approx(78.5 / 3 + 0.15) and means.loc["gaug", "psnr"] == pytest.approx(69.5 / 3 + 0.15)
    assert means.loc["full", "masked_psnr"] == pytest.approx(78.5 / 3 + 10.15) and "roi_psnr" not in t1.columns  # masked PSNR's twin
    assert means.loc["full", "ssim"] == pytest.approx(0.85) and means.loc["gaug", "lpips"] == pytest.approx(0.55 / 3)
    assert (means["n_runs"] == 6).all() and (means["n_scenes"] == 3).all()
    assert "fid" not in t1.columns and means.loc["full", "fd_vgg16"] == pytest.approx(100 - 78.5 / 3)
    # the seed spread: the seeds' scene averages differ by 0.3
    assert means.loc["full", "psnr_std"] == pytest.approx(seed_spread(_runs("full", "psnr"))) == pytest.approx(0.3 / math.sqrt(2))
    assert means.loc["full", "unseen_share"] == pytest.approx(5.0) and means.loc["full", "amcr"] == pytest.approx(6.0)
    assert means.loc["full", "silhouette_test"] == pytest.approx(16.0) and means.loc["full", "residual"] == pytest.approx((5 * 0.2 + 3.5) / 6)
    # Δ rows: the method minus each baseline, paired per run, the interval resampling the three scenes
    diffs = t1[t1["row_type"] == "difference"].set_index("vs")
    assert list(diffs.index) == ["spin", "gaug"] and set(diffs["method"]) == {"full"} and (diffs["n_scenes"] == 3).all()
    iv = paired_difference(_runs("full", "lpips"), _runs("gaug", "lpips"))
    assert iv.scenes == 3 and diffs.loc["gaug", "lpips"] == pytest.approx(iv.mean) == pytest.approx((-0.2 + 0.1 + 0.03) / 3)
    assert (diffs.loc["gaug", "lpips_ci_low"], diffs.loc["gaug", "lpips_ci_high"]) == pytest.approx((iv.low, iv.high))
    iv = paired_difference(_runs("full", "psnr"), _runs("gaug", "psnr"))
    assert diffs.loc["gaug", "psnr"] == pytest.approx(3.0) and diffs.loc["gaug", "psnr_ci_low"] == pytest.approx(iv.low) and iv.low > 0
    assert diffs.loc["gaug", "psnr_mark"] == "better" and diffs.loc["gaug", "lpips_mark"] == "tied"
    assert diffs.loc["spin", "ssim_mark"] == "worse"
    # marks: PSNR full better than both (intervals exclude 0), SSIM spin better than both; LPIPS full and
    # gaug cannot be told apart (full -0.2 on s1, +0.1 on s2): tied for first, spin not
    assert means.loc["full", "psnr_mark"] == "best" and means.loc["spin", "ssim_mark"] == "best"
    assert means.loc["full", "lpips_mark"] == "tied" and means.loc["gaug", "lpips_mark"] == "tied" and means.loc["spin", "lpips_mark"] == ""
    assert means.loc["gaug", "psnr_mark"] == "" and means.loc["full", "amcr_mark"] == ""

    md = (out / "table1_average.md").read_text()
    rows = _md_rows(md)
    assert rows["full"][5] == "**26.32 ± 0.21**" and rows["GauGroup"][5] == "23.32 ± 0.21" and rows["SPIn-NeRF"][7] == "**0.9500 ± 0.0000**"
    assert rows["full"][10] == "0.1600 ± 0.0000 (tied)" and rows["GauGroup"][10] == "0.1833 ± 0.0000 (tied)"
    assert rows["Δ full − GauGroup"][5] == f"+3.00 [{iv.low:.2f}, {iv.high:.2f}] better"
    assert rows["Δ full − GauGroup"][10].endswith(" tied") and rows["Δ full − GauGroup"][-1] == ""  # unseen share: not compared
    assert "FID substitute" in md and "no Inception weights" in md and "95% bootstrap interval" in md and "intervals resample scenes" in md
    assert "Run s3 (seed 0) is left out of every average: gaug/none, full/geometric have metrics there, spin/none not" in md
    assert "Averaged over 6 run(s): 3 scene(s) (s1, s2, s5) × seed(s) 0, 1." in md
    assert "Scene s4 (seed 0) of full/geometric has no metrics (no object-free captures)" in md
    assert "ROI PSNR is not averaged" in md
    # the runs above a removal limit, by name, under the table (ablation runs included)
    assert "ABOVE LIMIT: s1 (seed 0) [none]: amcr_ratio 2.00× > 1.5×; method(s) gaug." in md
    assert "ABOVE LIMIT: s2 (seed 1) [geometric]: residual 3.50 % > 1 %; method(s) full." in md
    assert md.count("ABOVE LIMIT") == 2
    tex = (out / "table1_average.tex").read_text()
    assert r"\toprule" in tex and r"\bottomrule" in tex and r"PSNR $\uparrow$" in tex and r"LPIPS $\downarrow$" in tex
    full_line = next(line for line in tex.splitlines() if line.startswith("full &"))
    assert r"\textbf{26.32 $\pm$ 0.21}" in full_line and r"0.1600 $\pm$ 0.0000 (tied)" in full_line
    assert next(line for line in tex.splitlines() if line.startswith(r"$\Delta$ full $-$ GauGroup &"))

    prov = json.loads((out / "provenance.json").read_text())
    assert prov["config"]["content"] == cfg.read_text() and prov["seeds"] == [0, 1] and prov["seeds_source"] == "record seed labels"
    assert prov["bootstrap"]["resamples"] == 10000 and prov["bootstrap"]["seed"] == 0 and prov["bootstrap"]["confidence"] == 0.95
    assert prov["bootstrap"]["resampling_unit"] == "scene" and prov["bootstrap"]["min_scenes"] == 3
    assert prov["weights"] == [{"name": "lpips_vgg", "file": "vgg16.ckpt", "sha256": SHA, "records": 38}]
    assert [r["path"] for r in prov["records"]] == records
    assert {"torch", "numpy", "snakemake", "pycolmap", "onnxruntime"} <= set(prov["packages"])
    assert prov["machine"]["cpu_count"] >= 1 and prov["git_commit"]
    assert "table1_average.tex" in prov["outputs"]

    # the same records give the same numbers in any order (the bootstrap's generator is seeded, the pairs sorted)
    code, _, err = cli(capsys, "table", "paper", *reversed(records), "--out-dir", str(tmp_path / "again"))
    assert code == 0, err
    again = (tmp_path / "again" / "table1_average.csv").read_text().splitlines()
    assert sorted(again) == sorted((out / "table1_average.csv").read_text().splitlines())
    code, _, err = cli(capsys, "table", "paper", *records, "--out-dir", str(tmp_path / "other"), "--bootstrap-seed", "3", "--confidence", "0.5")
    assert code == 0, err
    other = pd.read_csv(tmp_path / "other" / "table1_average.csv").set_index(["row_type", "vs"]).loc[("difference", "gaug")]
    assert other["lpips_ci_high"] - other["lpips_ci_low"] < diffs.loc["gaug", "lpips_ci_high"] - diffs.loc["gaug", "lpips_ci_low"]


def test_per_scene_ablations_and_runtime(tmp_path, capsys, records):
    code, err = _paper(capsys, tmp_path, records)
    assert code == 0, err
    out = tmp_path / "tables"
    # per scene: every run, every seed, s4 with its reason; no marks
    ps = pd.read_csv(out / "per_scene.csv", keep_default_na=False)
    assert len(ps) == 39 and set(ps["seed"]) == {0, 1}
    s4 = ps[ps["scene"] == "s4"].iloc[0]
    assert s4["note"] == "no object-free captures" and s4["psnr"] == ""
    s2_full = ps[(ps["scene"] == "s2") & (ps["method"] == "full")]
    assert list(s2_full["seed"]) == [0, 1] and [float(x) for x in s2_full["psnr"]] == pytest.approx([27.0, 27.3])
    assert list(ps[ps["scene"] == "s1"]["method"])[:6] == ["spin", "spin", "gaug", "gaug", "full", "full"]
    above = ps[ps["note"].str.startswith("above limit")]
    assert list(zip(above["scene"], above["method"], above["seed"], above["note"])) == [
        ("s1", "gaug", 0, "above limit: amcr_ratio 2.00× > 1.5×"), ("s2", "full", 1, "above limit: residual 3.50 % > 1 %")]
    assert [float(x) for x in ps[ps["scene"] == "s2"]["roi_psnr"][:1]] == [20.0]  # per scene keeps ROI PSNR
    ps_md = (out / "per_scene.md").read_text()
    assert "no object-free captures" in ps_md and "**" not in ps_md.split("Notes:")[0]
    assert r"	extbf" not in (out / "per_scene.tex").read_text()

    # Tab. 3: b) has no s3, so it is a block of its own; a) and e) share the full method's runs
    t3 = _read(out / "table3_ablation.csv")
    assert list(t3["row"]) == ["Ours (full)", "a) 2D tracker association", "e) w/o hybrid supervision", "Δ a) − Ours", "Δ e) − Ours",
                               "Ours (full)", "b) w/o depth-guided initialisation", "Δ b) − Ours"]
    assert list(t3["block"]) == [1] * 5 + [2] * 3 and list(t3["n_runs"]) == [6] * 5 + [4] * 3 and list(t3["n_scenes"]) == [3] * 5 + [2] * 3
    assert list(t3["psnr"])[:3] == pytest.approx([26.15, (23 + 24 + 1) / 3 + 0.15, 26.15]) and t3["psnr"][5] == pytest.approx(26.15)
    da, de, db = (t3[t3["row"] == f"Δ {x}) − Ours"].iloc[0] for x in "aeb")
    assert da["psnr_mark"] == "worse" and da["lpips_mark"] == "worse" and db["psnr"] == pytest.approx(-1.5)
    # b) on two scenes: its interval measures the seeds' noise only: no verdict, no first place in its block
    assert db["psnr_mark"] == "seed noise only" and db["psnr_ci_low"] <= db["psnr_ci_high"]
    block2 = t3[t3["block"] == 2]
    assert (block2[block2["row_type"] == "mean"][["psnr_mark", "lpips_mark", "ssim_mark"]] == "").all().all()
    assert de["psnr"] == pytest.approx(0.0) and de["psnr_mark"] == "tied" and de["ssim_ci_low"] == 0 == de["ssim_ci_high"]
    t3_md = (out / "table3_ablation.md").read_text()
    assert "3 scene(s) (s1, s2, s3) × seed(s) 0, 1" in t3_md and "seed noise only" in t3_md
    assert "e) w/o hybrid supervision (geometric; 3 scene(s) (s1, s2, s3) × seed(s) 0, 1): no measurable effect on 10 compared metric(s)" in t3_md
    assert ("b) w/o depth-guided initialisation (geometric; 2 scene(s) (s1, s2) × seed(s) 0, 1): seed noise only: 2 scene(s), fewer than "
            "the 3 a verdict needs") in t3_md
    assert "a) 2D tracker association (geometric; 3 scene(s) (s1, s2, s3) × seed(s) 0, 1): worse on PSNR, masked PSNR" in t3_md
    tex3 = (out / "table3_ablation.tex").read_text().splitlines()
    second = next(i for i, line in enumerate(tex3) if line.startswith("2 & Ours"))
    assert tex3[second - 1] == r"\midrule" and not any(line == r"\midrule" for line in tex3[second - 5:second - 1])  # a rule between blocks

    # Tab. 2: minutes per stage over the runs both have (s1, s2 at seeds 0, 1); total without evaluation; no marks
    t2 = pd.read_csv(out / "table2_runtime.csv").set_index("method")
    assert list(t2.index) == ["gaug", "full"] and (t2["n_runs"] == 4).all()
    assert t2.loc["full", "train_min"] == pytest.approx(2.5) and t2.loc["full", "inpaint_min"] == pytest.approx(1.5)
    assert t2.loc["full", "evaluate_min"] == pytest.approx(0.5) and t2.loc["full", "total_min"] == pytest.approx(4.0)
    assert t2.loc["gaug", "train_min"] == pytest.approx(6.0) and math.isnan(t2.loc["gaug", "inpaint_min"])
    assert t2.loc["gaug", "total_min"] == pytest.approx(6.0) and t2.loc["full", "storage_mb"] == pytest.approx(2.0)
    assert t2.loc["full", "peak_rss_mb"] == pytest.approx(512.5)
    t2_md = (out / "table2_runtime.md").read_text()
    assert "—" in t2_md and "total = train + inpaint" in t2_md and "spin/none has no stage benchmarks for s1 (seed 0)" in t2_md
    assert "**" not in t2_md.split("Notes:")[0]
    det = pd.read_csv(out / "table2_runtime_detail.csv", keep_default_na=False)
    full = det[det["method"] == "full"].set_index("scene")
    assert list(full.index) == ["s1", "s2", "s3", "average"] and list(full["n_runs"]) == [2, 2, 2, 4]
    assert full.loc["s3", "note"] == "not in the average" and full.loc["average", "train_min"] == pytest.approx(2.5)
    assert full.loc["s1", "total_min"] == pytest.approx(3.0)


def test_fid_column_when_every_run_has_it_and_seeds(tmp_path, capsys):
    paths = []
    for m, fid in (("full", 30.0), ("base", 40.0)):
        ev = eval_json(tmp_path / m / "eval.json", 25, 0.8, 0.1, fid=fid)
        paths.append(record(capsys, tmp_path / m / "r.json", {"scene": "s1", "method": m, "segmenter": "g", "kind": "baseline" if m == "base" else "method"}, "--eval", ev))
    code, err = _paper(capsys, tmp_path, paths, "--seeds", "0", "1")
    assert code == 0, err
    t1 = _read(tmp_path / "tables" / "table1_average.csv").set_index(["row_type", "method"])
    assert t1.loc[("mean", "full"), "fid"] == 30.0 and "fd_vgg16" not in t1.columns
    # one run of one scene: no interval and no verdict, so no first place, however large the difference
    assert t1.loc[("difference", "full"), "fid"] == -10.0 and math.isnan(t1.loc[("difference", "full"), "fid_ci_low"])
    assert t1.loc[("difference", "full"), "fid_mark"] == "seed noise only"
    assert t1.loc[("mean", "full"), "fid_mark"] == "" == t1.loc[("mean", "base"), "fid_mark"]
    tex = (tmp_path / "tables" / "table1_average.tex").read_text()
    assert r"\textbf" not in tex.split(r"\caption")[0] and "30.00 &" in tex and "-10.00 seed noise only" in tex
    md3 = (tmp_path / "tables" / "table3_ablation.md").read_text()
    assert "No ablation records" in md3
    prov = json.loads((tmp_path / "tables" / "provenance.json").read_text())
    assert prov["seeds"] == [0, 1] and prov["config"] is None


def test_views_sweep_table_and_plot(tmp_path, capsys):
    """Sweep records (the full method at other L) give views_sweep.{csv,md,tex,png}: one row per L,
    means over the scenes every L has, sorted by L; without sweep records none is written."""
    paths = []
    for L, fds in ((30, (10.0, 14.0)), (10, (20.0, 30.0)), (20, (12.0, 18.0))):
        for scene, fd in zip(("s1", "s2"), fds):
            ev = eval_json(tmp_path / f"L{L}" / scene / "eval.json", 25, 0.8, 0.1, fd=fd)
            kind, method = ("method", "full") if L == 30 else ("sweep", f"full_L{L}")
            labels = {"scene": scene, "method": method, "segmenter": "g", "kind": kind, "virtual_views": L}
            paths.append(record(capsys, tmp_path / f"L{L}" / scene / "r.json", labels, "--eval", ev))
    code, err = _paper(capsys, tmp_path, paths)
    assert code == 0, err
    sweep = pd.read_csv(tmp_path / "tables" / "views_sweep.csv")
    assert list(sweep["virtual_views"]) == [10, 20, 30]
    assert list(sweep["fd_vgg16"]) == [25.0, 15.0, 12.0]
    assert (tmp_path / "tables" / "views_sweep.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    code, err = _paper(capsys, tmp_path / "nosweep", [p for p in paths if "/L30/" in p])
    assert code == 0, err
    assert not (tmp_path / "nosweep" / "tables" / "views_sweep.csv").exists()


# --- bad input: one line, exit 2, nothing written ----------------------------------------------


def _good(tmp_path, capsys, name="a", scene="s1"):
    ev = eval_json(tmp_path / name / "eval.json", 25, 0.8, 0.1)
    return record(capsys, tmp_path / name / "r.json", {"scene": scene, "method": "full", "segmenter": "g"}, "--eval", ev)


def _seeded_twice(tmp_path, capsys):
    """Two records of scene s1 at seed 1 (the first one, ``_good``, has no seed: not a duplicate of either)."""
    ev = eval_json(tmp_path / "c" / "eval.json", 25, 0.8, 0.1)
    first = record(capsys, tmp_path / "c" / "r.json", {"scene": "s1", "method": "full", "segmenter": "g", "seed": 1}, "--eval", ev)
    p = Path(first).read_text()
    (tmp_path / "d.json").write_text(p)
    return first + "\0" + str(tmp_path / "d.json")


def _nan_record(tmp_path, capsys):
    p = Path(_good(tmp_path, capsys, "b", "s2"))
    p.write_text(p.read_text().replace('"psnr": 25.0', '"psnr": NaN'))
    return str(p)


def _bad_kind_record(tmp_path, capsys):
    p = Path(_good(tmp_path, capsys, "b", "s2"))
    p.write_text(p.read_text().replace('"kind": "method"', '"kind": "methd"'))
    return str(p)


PAPER_CASES = {
    "duplicate-run": (lambda t, c: _good(t, c, "b"), "appears twice"),
    "duplicate-seed": (lambda t, c: _seeded_twice(t, c), "seed 1 appears twice"),
    "nan-in-record": (_nan_record, "non-finite value NaN"),
    "missing-record": (lambda t, c: str(t / "nope.json"), "not found"),
    "invalid-json": (lambda t, c: (t / "x.json").write_text("{oops") and str(t / "x.json"), "not valid JSON"),
    "not-a-record": (lambda t, c: (t / "x.json").write_text('{"scene": "s1"}') and str(t / "x.json"), "not a table record"),
    "bad-kind": (_bad_kind_record, "kind must be one of"),
}


@pytest.mark.parametrize("case", sorted(PAPER_CASES))
def test_paper_bad_input(tmp_path, capsys, case):
    make, words = PAPER_CASES[case]
    first = _good(tmp_path, capsys)
    bad = make(tmp_path, capsys)
    (tmp_path / "tables").mkdir()
    (tmp_path / "tables" / "table1_average.md").write_text("previous")
    code, err = _paper(capsys, tmp_path, [first, *bad.split("\0")])
    bad = bad.split("\0")[-1]
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and lines[0].startswith("inpaint360gs table: error: "), err
    assert words in lines[0] and Path(bad).name in lines[0]
    assert [p.name for p in (tmp_path / "tables").iterdir()] == ["table1_average.md"]
    assert (tmp_path / "tables" / "table1_average.md").read_text() == "previous"


RECORD_CASES = {
    "eval-nan": (lambda t: ["--eval", (t / "e.json").write_text(
        json.dumps(json.loads(Path(eval_json(t / "e.json", 25, 0.8, 0.1)).read_text())).replace("25.0", "NaN")) and str(t / "e.json")], "non-finite"),
    "eval-missing": (lambda t: ["--eval", str(t / "nope.json")], "not found"),
    "eval-not-evaluation": (lambda t: ["--eval", (t / "e.json").write_text("[]") and str(t / "e.json")], "no 'mean'"),
    "bench-missing": (lambda t: ["--eval", eval_json(t / "e.json", 25, 0.8, 0.1), "--stage", f"train={t / 'nope.tsv'}"], "not found"),
    "bench-nan": (lambda t: ["--eval", eval_json(t / "e.json", 25, 0.8, 0.1), "--stage",
                             "train=" + ((t / "b.tsv").write_text(f"{HEADER}\nnan\t0\t1\t1\t1\t1\t1\t1\t1\t1\n") and str(t / "b.tsv"))], "finite"),
    "bench-not-tsv": (lambda t: ["--eval", eval_json(t / "e.json", 25, 0.8, 0.1), "--stage",
                                 "train=" + ((t / "b.tsv").write_text("a,b\n1,2\n") and str(t / "b.tsv"))], "header"),
    "stage-twice": (lambda t: ["--eval", eval_json(t / "e.json", 25, 0.8, 0.1), "--stage", f"train={bench(t / 'b.tsv', 1)}",
                               "--stage", f"train={bench(t / 'b.tsv', 1)}"], "given twice"),
    "model-not-ply": (lambda t: ["--eval", eval_json(t / "e.json", 25, 0.8, 0.1), "--model", (t / "m.ply").write_text("hello") and str(t / "m.ply")], "not a PLY"),
    "label-no-scene": (lambda t: ["--eval", eval_json(t / "e.json", 25, 0.8, 0.1), "--label", "scene"], "KEY=VALUE"),
    "label-bad-kind": (lambda t: ["--eval", eval_json(t / "e.json", 25, 0.8, 0.1), "--label", "kind=other"], "kind must be one of"),
    "label-bad-seed": (lambda t: ["--eval", eval_json(t / "e.json", 25, 0.8, 0.1), "--label", "seed=one"], "seed must be a non-negative integer"),
    "eval-and-skip": (lambda t: ["--eval", eval_json(t / "e.json", 25, 0.8, 0.1), "--skip-reason", "x"], "--skip-reason"),
}


@pytest.mark.parametrize("case", sorted(RECORD_CASES))
def test_record_bad_input(tmp_path, capsys, case):
    make, words = RECORD_CASES[case]
    extra = make(tmp_path)
    labels = [] if case == "label-no-scene" else ["--label", "scene=s1", "--label", "method=full", "--label", "segmenter=g"]
    code, _, err = cli(capsys, "table", "record", str(tmp_path / "out" / "r.json"), *labels, *extra)
    lines = err.strip().splitlines()
    assert code == 2 and len(lines) == 1 and lines[0].startswith("inpaint360gs table: error: "), err
    assert words in lines[0], lines[0]
    assert not (tmp_path / "out").exists()


def test_usage_errors_are_one_line(capsys, tmp_path):
    code, _, err = cli(capsys, "table", "paper", str(tmp_path / "r.json"))
    assert code == 2 and err.strip() == "inpaint360gs table: error: paper: the following arguments are required: --out-dir (see --help)"


def test_reconstruction_table_still_works(tmp_path, capsys):
    row = {"psnr": 30.0, "ssim": 0.9, "num_gaussians": 10, "iterations": 5, "train_seconds": 1.0, "eval_seconds": 1.0, "peak_rss_mb": 100.0}
    for scene, psnr in (("a", 30.0), ("b", 32.0)):
        (tmp_path / f"{scene}.json").write_text(json.dumps({**row, "scene": scene, "psnr": psnr}))
    code, _, err = cli(capsys, "table", "reconstruction", str(tmp_path / "a.json"), str(tmp_path / "b.json"), "--csv", str(tmp_path / "t.csv"))
    assert code == 0, err
    assert pd.read_csv(tmp_path / "t.csv").set_index("scene").loc["average", "PSNR (dB)"] == 31.0


def test_records_and_evaluations_from_before_the_unseen_share_read_their_amcr_as_it(tmp_path, capsys):
    """A format-1 record, or an evaluation without unseen_share: their 'amcr' was the unseen masks'
    coverage. It is read as unseen_share, and AMCR (removal masks) is null with that reason."""
    ev = json.loads(Path(eval_json(tmp_path / "e.json", 25, 0.8, 0.1)).read_text())
    ev["scene_metrics"] = {"fid": None, "fd_vgg16": 10.0, "kid_vgg16": 0.01, "amcr": 4.0}
    (tmp_path / "old_eval.json").write_text(json.dumps(ev))
    new = record(capsys, tmp_path / "a.json", {"scene": "s1", "method": "full", "segmenter": "g"}, "--eval", str(tmp_path / "old_eval.json"))
    rec = json.loads(Path(new).read_text())
    assert rec["format"] == "inpaint360gs-table-record/3" and rec["metrics"]["unseen_share"] == 4.0 and rec["metrics"]["amcr"] is None
    assert "from before AMCR was computed on the removal masks" in rec["null_reasons"]["amcr"]
    old = dict(rec, format="inpaint360gs-table-record/1")
    old["metrics"] = {k: v for k, v in rec["metrics"].items() if k != "unseen_share"} | {"amcr": 3.0, "psnr": 20.0}
    old["labels"] = dict(rec["labels"], method="base", kind="baseline")
    (tmp_path / "b.json").write_text(json.dumps(old))
    code, err = _paper(capsys, tmp_path, [new, str(tmp_path / "b.json")])
    assert code == 0, err
    ps = _read(tmp_path / "tables" / "per_scene.csv").set_index("method")
    assert ps.loc["base", "unseen_share"] == 3.0 and math.isnan(ps.loc["base", "amcr"]) and ps.loc["full", "unseen_share"] == 4.0
    md = (tmp_path / "tables" / "per_scene.md").read_text()
    assert "AMCR (%) is null in 1 run(s) (not recorded: this record is from before" in md
    assert "AMCR (%) is null in 1 run(s) (not recorded: this evaluation is from before" in md


def test_tables_do_not_depend_on_the_hash_seed(records, tmp_path):
    """The same records give the same table bytes under two Python hash seeds (set orders differ,
    so every sum over runs must follow a fixed order)."""
    import os
    import subprocess
    import sys

    got = []
    for seed in ("1", "2"):
        out = tmp_path / f"h{seed}"
        code = "import sys; from inpaint360gs.cli import main; sys.exit(main(sys.argv[1:]))"
        env = {**os.environ, "PYTHONHASHSEED": seed}
        subprocess.run([sys.executable, "-c", code, "table", "paper", *records, "--out-dir", str(out)], env=env, check=True, capture_output=True)
        got.append({p.name: p.read_bytes() for p in sorted(out.glob("*.csv"))})
    assert got[0] == got[1] and "table3_ablation.csv" in got[0]


def test_records_and_evaluations_from_before_amcr_over_the_training_views_read_their_amcr_as_the_silhouette(tmp_path, capsys):
    """A format-2 record, or an evaluation without silhouette_test: their 'amcr' was the removed
    silhouette at the test cameras. It is read as silhouette_test; AMCR (training views) and the
    removal scores are null with the reason."""
    ev = json.loads(Path(eval_json(tmp_path / "e.json", 25, 0.8, 0.1)).read_text())
    del ev["scene_metrics"]["silhouette_test"]
    (tmp_path / "old_eval.json").write_text(json.dumps(ev))
    new = record(capsys, tmp_path / "a.json", {"scene": "s1", "method": "full", "segmenter": "g"}, "--eval", str(tmp_path / "old_eval.json"))
    rec = json.loads(Path(new).read_text())
    assert rec["metrics"]["silhouette_test"] == 6.0 and rec["metrics"]["amcr"] is None and rec["metrics"]["residual"] is None
    assert "its 'amcr' was the removed silhouette at the test cameras" in rec["null_reasons"]["amcr"]
    assert "score-removal" in rec["null_reasons"]["residual"]
    old = dict(rec, format="inpaint360gs-table-record/2")
    old["metrics"] = {k: v for k, v in rec["metrics"].items() if k not in ("silhouette_test", "residual", "collateral", "gt_footprint_share")}
    old["metrics"] |= {"amcr": 12.0, "psnr": 20.0}
    old["labels"] = dict(rec["labels"], method="base", kind="baseline")
    (tmp_path / "b.json").write_text(json.dumps(old))
    code, err = _paper(capsys, tmp_path, [new, str(tmp_path / "b.json")])
    assert code == 0, err
    ps = _read(tmp_path / "tables" / "per_scene.csv").set_index("method")
    assert ps.loc["base", "silhouette_test"] == 12.0 and math.isnan(ps.loc["base", "amcr"]) and math.isnan(ps.loc["base", "residual"])
    md = (tmp_path / "tables" / "table1_average.md").read_text()
    assert "2 run(s) lack a removal score" in md


def test_removal_scores_of_another_scene_or_removal_are_refused(tmp_path, capsys):
    ev = eval_json(tmp_path / "e.json", 25, 0.8, 0.1)
    labels = ["--label", "scene=s1", "--label", "method=full", "--label", "segmenter=g"]
    other = scores_json(tmp_path / "s.json", amcr=7.0)  # the evaluation's removal has AMCR 6 %
    code, _, err = cli(capsys, "table", "record", str(tmp_path / "r.json"), *labels, "--eval", ev, "--removal-scores", other)
    assert code == 2 and "scores of another removal" in err and len(err.strip().splitlines()) == 1 and not (tmp_path / "r.json").exists()
    data = json.loads(Path(scores_json(tmp_path / "t.json")).read_text())
    data["provenance"] = {"stage": "score-removal", "identity": "x", "scene": {"name": "s9", "content_sha256": "y", "resize": 1}, "inputs": {}}
    (tmp_path / "t.json").write_text(json.dumps(data))
    code, _, err = cli(capsys, "table", "record", str(tmp_path / "r.json"), *labels, "--eval", ev, "--removal-scores", str(tmp_path / "t.json"))
    assert code == 2 and "removal scores of scene 's9'" in err
    (tmp_path / "u.json").write_text('{"scores": {"amcr": 6.0}}')
    code, _, err = cli(capsys, "table", "record", str(tmp_path / "r.json"), *labels, "--eval", ev, "--removal-scores", str(tmp_path / "u.json"))
    assert code == 2 and "has no 'residual'" in err


def _check_tables(results: Path, n_runs: int) -> subprocess.CompletedProcess:
    """The CI's table check (.ci/check_tables.py) on ``results``."""
    script = Path(__file__).resolve().parents[2] / ".ci" / "check_tables.py"
    return subprocess.run([sys.executable, str(script), str(results), str(n_runs)], capture_output=True, text=True)


def test_a_table_whose_ablation_has_fewer_than_three_scenes_and_no_seed_noise_mark_is_refused(tmp_path, capsys, records):
    """The tables as written pass the CI's check and the report's own (inpaint360gs.report.checks);
    the same tables with ablation b) (two scenes) given a verdict, or a first place, fail both, and so
    do tables that do not name a run above a removal limit or do not say that the intervals resample scenes."""
    from inpaint360gs.report.checks import compared_table_problems

    out = tmp_path / "tables"
    cfg = tmp_path / "config.yaml"
    cfg.write_text(f"results_dir: {out}\n")
    code, err = _paper(capsys, tmp_path, records[:-1], "--config", str(cfg))  # s4 (no ground truth) has empty cells by design
    assert code == 0, err
    ok = _check_tables(out, 38)
    assert ok.returncode == 0, ok.stdout + ok.stderr
    t3 = pd.read_csv(out / "table3_ablation.csv")
    assert compared_table_problems("table3_ablation", t3) == []

    b = t3.index[t3["row"] == "Δ b) − Ours"][0]
    assert t3.loc[b, "n_scenes"] == 2 and t3.loc[b, "psnr_mark"] == "seed noise only"
    forged = t3.copy()
    forged.loc[b, "psnr_mark"] = "worse"  # a verdict from two scenes
    assert any("compares 2 scene(s)" in p and "psnr" in p for p in compared_table_problems("table3_ablation", forged))
    forged.to_csv(out / "table3_ablation.csv", index=False)
    bad = _check_tables(out, 38)
    assert bad.returncode == 1 and "compares 2 scene(s) (fewer than 3) but is marked 'worse', not 'seed noise only'" in bad.stdout
    forged = t3.copy()
    ours = forged.index[(forged["block"] == 2) & (forged["row_type"] == "mean")][0]
    forged.loc[ours, "psnr_mark"] = "best"  # a first place from two scenes
    assert any("a mean over 2 scene(s) is marked best or tied in psnr" in p for p in compared_table_problems("table3_ablation", forged))
    forged = t3.drop(columns=["n_scenes"])  # a table that cannot tell scenes from runs
    assert any("no n_scenes column" in p for p in compared_table_problems("table3_ablation", forged))
    t3.to_csv(out / "table3_ablation.csv", index=False)

    md = (out / "table1_average.md").read_text()
    (out / "table1_average.md").write_text(md.replace("ABOVE LIMIT: s2 (seed 1)", "s2 (seed 1)"))
    bad = _check_tables(out, 38)
    assert bad.returncode == 1 and "does not name s2 (seed 1) full above its residual limit (3.50)" in bad.stdout
    (out / "table1_average.md").write_text(md)
    prov = json.loads((out / "provenance.json").read_text())
    prov["bootstrap"].pop("resampling_unit")
    (out / "provenance.json").write_text(json.dumps(prov))
    bad = _check_tables(out, 38)
    assert bad.returncode == 1 and "resample scenes" in bad.stdout


def test_keep_failed_copies_the_renders_and_removal_masks_of_the_runs_above_a_limit(tmp_path, capsys, records):
    for run in ("full/s2/1", "gaug/s1/0"):  # the two runs above a limit (ABOVE)
        d = tmp_path / "runs" / run
        (d / "renders").mkdir(parents=True)
        (d / "renders" / "test_0000.png").write_bytes(b"png of " + run.encode())
        (d / "removed" / "masks").mkdir(parents=True)
        (d / "removed" / "masks" / "IMG_000.png").write_bytes(b"mask of " + run.encode())
    kept = tmp_path / "failed"
    code, err = _paper(capsys, tmp_path, records, "--keep-failed", str(kept))
    assert code == 0, err
    listing = json.loads((kept / "failed.json").read_text())["runs"]
    assert [(r["scene"], r["seed"], r["method"], [a["limit"] for a in r["above"]]) for r in listing] == [
        ("s1", "0", "gaug", ["amcr_ratio"]), ("s2", "1", "full", ["residual"])]
    assert (kept / "s2" / "seed1" / "geometric" / "full" / "renders" / "test_0000.png").read_bytes() == b"png of full/s2/1"
    assert (kept / "s1" / "seed0" / "none" / "gaug" / "removal_masks" / "IMG_000.png").read_bytes() == b"mask of gaug/s1/0"
    assert listing[1]["copied_from"]["renders"] == str(tmp_path / "runs" / "full" / "s2" / "1" / "renders")
    assert sorted(p.name for p in kept.iterdir()) == ["failed.json", "s1", "s2"]
    # the folder is replaced as a whole: a rerun without failures leaves only the empty listing
    code, err = _paper(capsys, tmp_path, [r for r in records if "/full/" in r and "/s2/" not in r], "--keep-failed", str(kept))
    assert code == 0, err
    assert sorted(p.name for p in kept.iterdir()) == ["failed.json"] and json.loads((kept / "failed.json").read_text()) == {"runs": []}
