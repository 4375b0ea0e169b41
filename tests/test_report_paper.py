"""``inpaint360gs table record`` and ``table paper``: the paper's tables (Tabs. 1-3, supp. per-scene
and detailed runtime) from hand-made evaluation JSONs and Snakemake benchmark files; the averages
against hand computation, the best / second / third marks, scene sets that differ, bad input."""

from __future__ import annotations

import json
import math
from pathlib import Path

import pandas as pd
import pytest

from inpaint360gs.cli import main
from inpaint360gs.report.records import MEAN_METRICS

HEADER = "s\th:m:s\tmax_rss\tmax_vms\tmax_uss\tmax_pss\tio_in\tio_out\tmean_load\tcpu_time"
SHA = "ab" * 32


def eval_json(path: Path, psnr: float, ssim: float, lpips: float, fid: float | None = None, fd: float = 10.0) -> str:
    """An evaluation JSON shaped like ``inpaint360gs evaluate``'s: masked_* = value + 10 (PSNR),
    roi_* = value - 1 (PSNR); SSIM/LPIPS variants the same value."""
    mean = {}
    for k in MEAN_METRICS:
        base = {"psnr": psnr, "ssim": ssim, "lpips": lpips, "lpips_alex": lpips}[k.split("_", 1)[1] if k.startswith(("masked_", "roi_")) else k]
        mean[k] = base + (10.0 if k == "masked_psnr" else -1.0 if k == "roi_psnr" else 0.0)
    data = {
        "scene": "data/x", "num_views": 3, "mean": mean,
        "scene_metrics": {"fid": fid, "fd_vgg16": fd, "kid_vgg16": 0.01, "amcr": 5.0},
        "null_reasons": {"per_view": {}, "mean": {}, "scene_metrics": {} if fid is not None else {"fid": "no Inception weights"}},
        "weights": {"lpips_vgg": {"path": "/somewhere/vgg16.ckpt", "sha256": SHA}, "inception": None},
    }
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

# (method, segmenter, kind, extra labels) -> scene -> (psnr, ssim, lpips)
RUNS = {
    ("spin", "none", "baseline", (("name", "SPIn-NeRF"),)): {"s1": (20, 0.95, 0.5), "s2": (21, 0.95, 0.4)},  # no s3
    ("gaug", "none", "baseline", (("name", "GauGroup"),)): {"s1": (24, 0.7, 0.3), "s2": (22, 0.7, 0.1), "s3": (23, 0.7, 0.2)},
    ("full", "geometric", "method", ()): {"s1": (25, 0.8, 0.1), "s2": (27, 0.9, 0.2), "s3": (26, 0.85, 0.15)},
    ("wo_depth_init", "geometric", "ablation", ()): {"s1": (24, 0.8, 0.2), "s2": (25, 0.8, 0.2), "s3": (1, 0.1, 0.9)},
    ("tracker", "geometric", "ablation", (("ablation", "a"), ("name", "2D tracker association"))): {"s1": (23, 0.7, 0.3), "s2": (24, 0.7, 0.3), "s3": (1, 0.1, 0.9)},
}
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
            d = tmp_path / "runs" / method / scene
            args = ["--eval", eval_json(d / "eval.json", psnr, ssim, lpips, fd=100 - psnr)]
            for stage, secs in STAGES.get((method, scene), {}).items():
                args += ["--stage", f"{stage}={bench(d / f'{stage}.tsv', *secs)}"]
            if method == "full":
                (d / "point_cloud.ply").write_bytes(b"ply\n" + bytes(1_999_996))
                args += ["--model", str(d / "point_cloud.ply")]
            paths.append(record(capsys, d / "record.json", {"scene": scene, "method": method, "segmenter": seg, "kind": kind, **dict(extra)}, *args))
    # a scene without ground truth: listed, never averaged
    paths.append(record(capsys, tmp_path / "runs" / "full" / "s4" / "record.json", {"scene": "s4", "method": "full", "segmenter": "geometric"},
                        "--skip-reason", "no object-free captures"))
    return paths


def _paper(capsys, tmp_path, paths, *extra) -> tuple[int, str]:
    code, _, err = cli(capsys, "table", "paper", *paths, "--out-dir", str(tmp_path / "tables"), *extra)
    return code, err


def test_paper_tables_averages_marks_and_scene_sets(tmp_path, capsys, records):
    cfg = tmp_path / "config.yaml"
    cfg.write_text("seed: 7\nscenes: [s1, s2]\n")
    code, err = _paper(capsys, tmp_path, records, "--config", str(cfg))
    assert code == 0, err
    out = tmp_path / "tables"
    names = {p.name for p in out.iterdir()}
    for t in ("per_scene", "table1_average", "table3_ablation", "table2_runtime", "table2_runtime_detail"):
        assert {f"{t}.csv", f"{t}.md", f"{t}.tex"} <= names
    assert "provenance.json" in names and not [n for n in names if n.startswith(".")]

    # Tab. 1: spin has no s3, so every method averages s1 and s2 only (s3 named as left out)
    t1 = pd.read_csv(out / "table1_average.csv").set_index("method")
    assert list(t1.index) == ["spin", "gaug", "full"]  # baselines first, the method last (paper order)
    assert t1.loc["full", "psnr"] == pytest.approx(26.0) and t1.loc["gaug", "psnr"] == pytest.approx(23.0)
    assert t1.loc["spin", "psnr"] == pytest.approx(20.5) and t1.loc["full", "masked_psnr"] == pytest.approx(36.0)
    assert t1.loc["full", "roi_psnr"] == pytest.approx(25.0) and t1.loc["full", "ssim"] == pytest.approx(0.85)
    assert t1.loc["gaug", "lpips"] == pytest.approx(0.2) and t1.loc["full", "masked_lpips"] == pytest.approx(0.15)
    assert (t1["n_scenes"] == 2).all() and set(t1["segmenter"]) == {"none", "geometric"}
    assert "fid" not in t1.columns and t1.loc["full", "fd_vgg16"] == pytest.approx(74.0)  # FID null -> labelled substitute
    md = (out / "table1_average.md").read_text()
    assert "FID substitute" in md and "no Inception weights" in md
    assert "Scene s3 is left out of every average: gaug/none, full/geometric have metrics there, spin/none not" in md
    assert "Averaged over 2 scene(s): s1, s2." in md
    assert "Scene s4 of full/geometric has no metrics (no object-free captures)" in md
    # marks: PSNR full > gaug > spin (higher better); SSIM spin > full > gaug; LPIPS full < gaug < spin (lower better)
    rows = {line.split("|")[1].strip(): [c.strip() for c in line.split("|")[1:-1]] for line in md.splitlines() if line.startswith("| ") and "---" not in line}
    assert rows["full"][4] == "**26.00**"
    assert rows["GauGroup"][4] == "<ins>23.00</ins>" and rows["SPIn-NeRF"][4] == "_20.50_"
    assert rows["SPIn-NeRF"][7] == "**0.9500**" and rows["full"][7] == "<ins>0.8500</ins>" and rows["GauGroup"][7] == "_0.7000_"
    assert rows["full"][10] == "**0.1500**" and rows["GauGroup"][10] == "<ins>0.2000</ins>" and rows["SPIn-NeRF"][10] == "_0.4500_"
    tex = (out / "table1_average.tex").read_text()
    assert r"\toprule" in tex and r"\bottomrule" in tex and r"PSNR $\uparrow$" in tex and r"LPIPS $\downarrow$" in tex
    full_line = next(line for line in tex.splitlines() if line.startswith("full &"))
    assert r"\textbf{26.00}" in full_line and r"\underline{0.8500}" in full_line and r"\textbf{0.1500}" in full_line
    spin_line = next(line for line in tex.splitlines() if line.startswith("SPIn-NeRF &"))
    assert r"\textit{20.50}" in spin_line and r"\textbf{0.9500}" in spin_line and r"\textit{0.4500}" in spin_line

    # per scene: every run, s4 with its reason; marks among methods and baselines of one scene
    ps = pd.read_csv(out / "per_scene.csv", keep_default_na=False)
    assert len(ps) == 15
    s4 = ps[ps["scene"] == "s4"].iloc[0]
    assert s4["note"] == "no object-free captures" and s4["psnr"] == ""
    ps_tex = (out / "per_scene.tex").read_text()
    s3_gaug = next(line for line in ps_tex.splitlines() if line.startswith("s3 & GauGroup"))
    assert r"\underline{23.00}" in s3_gaug  # s3: full 26 > gaug 23 (spin absent: two rows, two marks)
    s3_ablation = next(line for line in ps_tex.splitlines() if line.startswith("s3 & wo") or line.startswith("s3 & 2D"))
    assert r"\textbf" not in s3_ablation and r"\underline" not in s3_ablation  # ablations unmarked
    ps_md = (out / "per_scene.md").read_text()
    assert "no object-free captures" in ps_md
    assert "**0.01**" not in ps_md and "**5.00**" not in ps_md  # KID and AMCR equal in every run: nothing to mark

    # Tab. 3: a) and b) by their paper letters (a from the label, b from the method id), then the full method
    t3 = pd.read_csv(out / "table3_ablation.csv")
    assert list(t3["row"]) == ["a) 2D tracker association", "b) w/o depth-guided initialisation", "Ours (full)"]
    assert list(t3["psnr"]) == pytest.approx([(23 + 24 + 1) / 3, (24 + 25 + 1) / 3, 26.0])  # all three have s1-s3
    assert list(t3["n_scenes"]) == [3, 3, 3]
    t3_md = (out / "table3_ablation.md").read_text()
    assert "**26.00**" in t3_md and "<ins>16.67</ins>" in t3_md and "_16.00_" in t3_md

    # Tab. 2: minutes per stage over the scenes both have (s1, s2); total without evaluation
    t2 = pd.read_csv(out / "table2_runtime.csv").set_index("method")
    assert list(t2.index) == ["gaug", "full"] and (t2["n_scenes"] == 2).all()
    assert t2.loc["full", "train_min"] == pytest.approx(2.5) and t2.loc["full", "inpaint_min"] == pytest.approx(1.5)
    assert t2.loc["full", "evaluate_min"] == pytest.approx(0.5) and t2.loc["full", "total_min"] == pytest.approx(4.0)
    assert t2.loc["gaug", "train_min"] == pytest.approx(6.0) and math.isnan(t2.loc["gaug", "inpaint_min"])
    assert t2.loc["gaug", "total_min"] == pytest.approx(6.0) and t2.loc["full", "storage_mb"] == pytest.approx(2.0)
    assert t2.loc["full", "peak_rss_mb"] == pytest.approx(512.5)
    t2_md = (out / "table2_runtime.md").read_text()
    assert "—" in t2_md and "total = train + inpaint" in t2_md and "spin/none has no stage benchmarks for scene(s) s1, s2; left out." in t2_md
    assert "**4.00**" in t2_md and "<ins>6.00</ins>" in t2_md  # lower is better
    det = pd.read_csv(out / "table2_runtime_detail.csv", keep_default_na=False)
    full = det[det["method"] == "full"].set_index("scene")
    assert list(full.index) == ["s1", "s2", "s3", "average"]
    assert full.loc["s3", "note"] == "not in the average" and full.loc["average", "train_min"] == pytest.approx(2.5)
    assert full.loc["s1", "total_min"] == pytest.approx(3.0)

    prov = json.loads((out / "provenance.json").read_text())
    assert prov["config"]["content"] == cfg.read_text() and prov["seeds"] == [7] and prov["seeds_source"] == "config seed"
    assert prov["weights"] == [{"name": "lpips_vgg", "file": "vgg16.ckpt", "sha256": SHA, "records": 14}]
    assert [r["path"] for r in prov["records"]] == records
    assert {"torch", "numpy", "snakemake", "pycolmap", "onnxruntime"} <= set(prov["packages"])
    assert prov["machine"]["cpu_count"] >= 1 and prov["git_commit"]
    assert "table1_average.tex" in prov["outputs"]


def test_fid_column_when_every_run_has_it_and_seeds(tmp_path, capsys):
    paths = []
    for m, fid in (("full", 30.0), ("base", 40.0)):
        ev = eval_json(tmp_path / m / "eval.json", 25, 0.8, 0.1, fid=fid)
        paths.append(record(capsys, tmp_path / m / "r.json", {"scene": "s1", "method": m, "segmenter": "g", "kind": "baseline" if m == "base" else "method"}, "--eval", ev))
    code, err = _paper(capsys, tmp_path, paths, "--seeds", "0", "1")
    assert code == 0, err
    t1 = pd.read_csv(tmp_path / "tables" / "table1_average.csv").set_index("method")
    assert t1.loc["full", "fid"] == 30.0 and "fd_vgg16" not in t1.columns
    assert r"\textbf{30.00}" in (tmp_path / "tables" / "table1_average.tex").read_text()
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
    code, err = _paper(capsys, tmp_path, [first, bad])
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
