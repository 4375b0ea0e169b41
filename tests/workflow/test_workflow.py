"""The Snakemake workflow parses, validates its config (including values given with --config) and
plans the expected jobs (dry run: nothing is executed)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


def _dry_run(tmp_path, *config: str) -> subprocess.CompletedProcess:
    cmd = [sys.executable, "-m", "snakemake", "-n", "-p", "--cores", "1", "--directory", str(ROOT), "--snakefile", str(ROOT / "Snakefile"),
           "--config", f"data_dir={tmp_path}/data", f"out_dir={tmp_path}/out", f"results_dir={tmp_path}/results", *config]
    return subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, timeout=120)


def _count(out: str, rule: str) -> int:
    return next((int(line.split()[1]) for line in out.splitlines() if line.split()[:1] == [rule] and len(line.split()) == 2), 0)


def test_dry_run_with_typed_command_line_values(tmp_path):
    p = _dry_run(tmp_path, "reduced=true", "poses=colmap", "scenes=[cone,toys]", "train_scenes=[cone]", "seeds=[3,5]", "ablation_scenes=[all]", "ablation_seeds=0",
                 "train={iterations: 1000, schedule_scale: auto, max_gaussians: 0, backend: auto, extra_args: ''}")
    assert p.returncode == 0, p.stderr[-2000:]
    out = p.stdout + p.stderr
    # two generated scenes and their COLMAP rebuilds, 3DGS on each (once, for both seeds), the
    # reconstruction table; per scene and seed one segmentation, two associations (KOM, and the
    # tracker of ablation a) each with its own distillation, removal and removal scores, eight inpaintings
    # (every method but removal only), one render of the removal, nine evaluations and records; one set of tables
    counts = [("synth_scene", 2), ("colmap_scene", 2), ("train_3dgs", 2), ("table_3dgs", 1), ("segment", 4), ("associate", 8),
              ("distill", 8), ("remove", 8), ("score_removal", 8), ("render_removed", 4), ("inpaint", 32), ("evaluate", 36), ("record", 36),
              ("paper_tables", 1)]
    for rule, n in counts:
        assert _count(out, rule) == n, (rule, out[-3000:])
    # the seed reaches every seeded stage after 3DGS, and names the run's folder; 3DGS keeps `seed`
    for stage in ("segment", "distill", "inpaint"):
        assert any(f"inpaint360gs {stage} " in line and "--seed 5" in line and "/seed5/" in line for line in out.splitlines()), stage
    assert all("--seed 0" in line for line in out.splitlines() if "inpaint360gs train " in line)
    assert "--label seed=5" in out and "--seeds 3 5" in out
    # every record takes its removal's scores, the tables keep the runs above a limit
    assert all("--removal-scores " in line and "/removal_scores.json" in line for line in out.splitlines() if "inpaint360gs table record " in line)
    assert "--keep-failed " in out and f"{tmp_path}/results/failed" in out


def test_scene_folders_and_method_subsets(tmp_path):
    folder = tmp_path / "captures" / "myscene"
    folder.mkdir(parents=True)
    (folder / "scene.json").write_text("{}")
    p = _dry_run(tmp_path, f"scenes=[cone,{folder}]", "train_scenes=[]", "methods=[full,removal_only]", "segmenters=[geometric,oracle]", "seeds=[0]")
    assert p.returncode == 0, p.stderr[-2000:]
    out = p.stdout + p.stderr
    # the folder is used as it is (no synth job for it); oracle runs on the synthetic scene only
    for rule, n in [("synth_scene", 1), ("train_3dgs", 2), ("segment", 3), ("inpaint", 3), ("evaluate", 6), ("record", 6)]:
        assert any(line.split()[:2] == [rule, str(n)] for line in out.splitlines()), (rule, out[-3000:])
    assert f"{folder}/scene.json" in out or "myscene" in out


@pytest.mark.parametrize(
    "bad,named",
    [("reduced=maybe", "reduced"), ("poses=guess", "poses"), ("train_scenes=[nosuchscene]", "nosuchscene"), ("methods=[magic]", "magic"),
     ("scenes=[./no/such/folder]", "no/such/folder"), ("segmenters=[]", "segmenters"), ("suite=train", "suite"), ("seeds=[]", "seeds"),
     ("seeds=[1,1]", "repeat"), ("seeds=[-1]", "seeds"), ("ablation_scenes={abl_z: [cone]}", "abl_z"), ("ablation_seeds=-1", "ablation_seeds"),
     ("keep_failed=maybe", "keep_failed"),
     ("segmenters=[magic]", "unknown segmenter"), ("train={preset: fast, schedule_scale: auto}", "is no preset"),
     ("captures={k: {photos: p, clicks: ['a.png:1,2'], preset: fast}}", "captures.k.preset")],
)  # fmt: skip
def test_bad_config_values_are_refused(tmp_path, bad, named):
    p = _dry_run(tmp_path, bad)
    assert p.returncode != 0
    assert named in (p.stderr + p.stdout)


@pytest.mark.slow
def test_slurm_profile_plans_the_jobs(tmp_path):
    """The cluster profile parses and plans every job (dry run); needs the SLURM executor plugin."""
    pytest.importorskip("snakemake_executor_plugin_slurm")
    cmd = [sys.executable, "-m", "snakemake", "-n", "--profile", str(ROOT / "workflow/profiles/slurm"), "--directory", str(ROOT),
           "--snakefile", str(ROOT / "Snakefile"), "--config", f"data_dir={tmp_path}/data", f"out_dir={tmp_path}/out",
           f"results_dir={tmp_path}/results", "scenes=[cone]"]  # fmt: skip
    p = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, timeout=300)
    assert p.returncode == 0, p.stderr[-2000:]
    assert "paper_tables" in p.stdout + p.stderr


def _workflow(tmp_path: Path, root: Path, *extra: str) -> list[str]:
    return [sys.executable, "-m", "snakemake", "--cores", "2", "--profile", str(ROOT / "workflow/profiles/local"), "--directory", str(ROOT),
            "--snakefile", str(ROOT / "Snakefile"), "--config", f"data_dir={tmp_path}/data", f"out_dir={root}/out", f"results_dir={root}/results",
            "scenes=[cone]", "train_scenes=[cone]", "reduced=true", "methods=[]",
            "train={iterations: 200, schedule_scale: auto, max_gaussians: 20000, backend: auto, extra_args: '--checkpoint-every 10'}", *extra]  # fmt: skip


@pytest.mark.slow
def test_killed_workflow_resumes_training_to_the_uninterrupted_bytes(tmp_path):
    """SIGTERM to the workflow while 3DGS trains, then the same command again: the rule resumes from
    the checkpoint (`--resume --overwrite`) and the model is byte-identical to an uninterrupted run."""
    import os
    import signal
    import time

    env = {**os.environ, "PATH": f"{Path(sys.executable).parent}:{os.environ.get('PATH', '')}"}
    a, b = tmp_path / "a", tmp_path / "b"
    p = subprocess.run(_workflow(tmp_path, a), capture_output=True, text=True, cwd=ROOT, env=env, timeout=900)
    assert p.returncode == 0, p.stderr[-2000:]
    proc = subprocess.Popen(_workflow(tmp_path, b), stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, cwd=ROOT, env=env, start_new_session=True)
    ckpt = b / "out" / "cone" / "3dgs" / "checkpoint.pt"
    deadline = time.monotonic() + 600
    while not ckpt.exists() and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.2)
    assert proc.poll() is None, "the workflow finished before it could be interrupted"
    os.killpg(proc.pid, signal.SIGTERM)
    proc.wait(timeout=120)
    assert not (b / "out" / "cone" / "3dgs" / "metrics.json").exists()
    p = subprocess.run(_workflow(tmp_path, b), capture_output=True, text=True, cwd=ROOT, env=env, timeout=900)
    assert p.returncode == 0, p.stderr[-2000:]
    ply = "out/cone/3dgs/point_cloud.ply"
    assert (a / ply).read_bytes() == (b / ply).read_bytes()
    import json

    resumed = json.loads((b / "out" / "cone" / "3dgs" / "metrics.json").read_text())["resumed_from_step"]
    assert resumed is not None and 0 < resumed < 200
    assert json.loads((a / "out" / "cone" / "3dgs" / "metrics.json").read_text())["resumed_from_step"] is None


def test_ablations_run_on_their_scene_subset(tmp_path):
    p = _dry_run(tmp_path, "scenes=[cone,bag]", "train_scenes=[]", "methods=[full,abl_d,abl_a]", "ablation_scenes=[cone]", "seeds=[0]")
    assert p.returncode == 0, p.stderr[-2000:]
    out = p.stdout + p.stderr
    # full on both scenes, abl_d and abl_a on cone only (abl_a: its own association on cone)
    for rule, n in [("inpaint", 4), ("evaluate", 4), ("associate", 3), ("distill", 3)]:
        assert any(line.split()[:2] == [rule, str(n)] for line in out.splitlines()), (rule, out[-3000:])


def test_suites_and_the_realistic_familys_own_poses(tmp_path):
    """`all` is the ten classic scenes; `suite:` picks a suite; the realistic family's scenes come
    out of `synth` with poses from pycolmap, so `poses: colmap` rebuilds only the classic ones."""
    from dataset_tools.synth import suite_scenes

    def count(out, rule):
        return next((int(line.split()[1]) for line in out.splitlines() if line.split()[:1] == [rule]), 0)

    p = _dry_run(tmp_path, "scenes=[all]", "methods=[full]", "train_scenes=[]", "seeds=[0]")
    assert p.returncode == 0, p.stderr[-2000:]
    assert count(p.stdout + p.stderr, "synth_scene") == 10
    dev = suite_scenes("dev")
    p = _dry_run(tmp_path, "suite=dev", "poses=colmap", "methods=[full]", "train_scenes=[]", "seeds=[0]")
    assert p.returncode == 0, p.stderr[-2000:]
    out = p.stdout + p.stderr
    assert count(out, "synth_scene") == len(dev) and count(out, "colmap_scene") == 10 and count(out, "inpaint") == len(dev)
    p = _dry_run(tmp_path, "suite=test", "methods=[full]", "train_scenes=[]", "seeds=[0]")
    assert p.returncode == 0, p.stderr[-2000:]
    out = p.stdout + p.stderr
    assert count(out, "synth_scene") == len(suite_scenes("test")) and count(out, "colmap_scene") == 0
    assert "dozer-test3" in out and "dozer-dev1" not in out and "dozer-test1" not in out  # the looked-at test layouts are dev scenes


def test_the_method_list_is_the_one_of_common_smk():
    """The methods are defined once, in workflow/rules/common.smk (METHODS): the config schema names
    none (common.smk refuses unknown ones), and the default config's list names them in that order."""
    import ast

    import yaml

    text = (ROOT / "workflow" / "rules" / "common.smk").read_text()
    start = text.index("METHODS = {")
    block = ast.parse(text[start : text.index("\n}\n", start) + 3]).body[0].value
    defined = [k.value for k in block.keys]
    schema = yaml.safe_load((ROOT / "workflow" / "config" / "config.schema.yaml").read_text())
    assert "enum" not in schema["properties"]["methods"]["items"]
    assert yaml.safe_load((ROOT / "workflow" / "config" / "config.yaml").read_text())["methods"] == defined


def test_default_benchmark_is_the_sealed_test_suite_with_ablations_on_six_scenes_each(tmp_path):
    """`make benchmark`'s plan: every test scene, 3DGS once per scene, every later stage at seeds 0
    and 1, the method and the three baselines everywhere, each ablation on the six scenes that have what it
    is about, at seed 0 (the same layouts in the dev suite), the 3DGS table over the benchmark's own
    scenes, one removal score per removal."""
    from dataset_tools.synth import suite_scenes

    test = suite_scenes("test")
    p = _dry_run(tmp_path)
    assert p.returncode == 0, p.stderr[-2000:]
    out = p.stdout + p.stderr
    n, runs, abl = len(test), 2 * len(test), 6
    counts = {"synth_scene": n, "colmap_scene": 0, "train_3dgs": n, "table_3dgs": 1, "segment": runs, "associate": runs + abl, "distill": runs + abl,
              "remove": runs + abl, "score_removal": runs + abl, "render_removed": runs, "inpaint": 3 * runs + 5 * abl,
              "evaluate": 4 * runs + 5 * abl, "record": 4 * runs + 5 * abl, "paper_tables": 1}
    assert {rule: _count(out, rule) for rule in counts} == counts
    lines = [line for line in out.splitlines() if "inpaint360gs inpaint " in line]
    where = {m: {line.split("/methods/")[0].split("/out/")[1].split("/")[0] for line in lines if f"/methods/{m} " in line}
             for m in ("abl_a", "abl_b", "abl_c", "abl_d", "abl_e", "full")}
    teapots = {"teapot-test3", "teapot-test4", "teapot-test3-sparse", "teapot-test4-sparse"}
    assert where == {"abl_a": teapots | {"dozer-test3", "dozer-test4"}, "abl_b": teapots | {"dozer-test3", "dozer-test4"},
                     "abl_c": {f"{x}-test{k}-sparse" for x in ("dozer", "duck", "teapot") for k in (3, 4)},
                     "abl_d": {"dozer-test3", "dozer-test4", "dozer-test3-sparse", "dozer-test4-sparse", "duck-test3", "duck-test4"},
                     "abl_e": {"duck-test3", "duck-test4", "duck-test3-sparse", "duck-test4-sparse", "dozer-test3", "dozer-test4"}, "full": set(test)}
    assert all("/seed0/" in line for line in lines if "/methods/abl_" in line)
    assert {line.split("/out/")[1].split("/")[1] for line in lines if "/methods/full " in line} == {"seed0", "seed1"}
    assert not any("dev" in line or "-test1" in line or "-test2" in line for line in out.splitlines() if "inpaint360gs" in line)
    # the same plan on the dev suite puts the ablations on the dev scenes of the same layouts
    p = _dry_run(tmp_path, "scenes=[dev]", "methods=[full,abl_a,abl_c]", "seeds=[0]", "train_scenes=[]")
    assert p.returncode == 0, p.stderr[-2000:]
    lines = [line for line in (p.stdout + p.stderr).splitlines() if "inpaint360gs inpaint " in line]
    assert {line.split("/methods/")[1].split()[0] for line in lines if "/teapot-dev2/" in line} == {"full", "abl_a"}
    assert {line.split("/methods/")[1].split()[0] for line in lines if "/duck-dev1-sparse/" in line} == {"full", "abl_c"}
    assert sum("/methods/abl_a " in line for line in lines) == 10 and sum("/methods/abl_c " in line for line in lines) == 6


def test_strong_baseline_is_planned_as_a_baseline_with_gaussian_groupings_switches(tmp_path):
    """`gg_style` (the strong baseline) inpaints on the method's KOM removal with the per-view fills of
    the training views, depth-guided new Gaussians, density control and LPIPS inside the mask, and its
    record is labelled a baseline (so Tab. 1 compares the method with it); `per_view_2d` stays the
    weak one (no new Gaussians, no density control)."""
    p = _dry_run(tmp_path, "scenes=[cone]", "train_scenes=[]", "methods=[full,per_view_2d,gg_style]", "seeds=[0]")
    assert p.returncode == 0, p.stderr[-2000:]
    out = p.stdout + p.stderr
    lines = {m: [line for line in out.splitlines() if "inpaint360gs inpaint " in line and f"/methods/{m} " in line] for m in ("gg_style", "per_view_2d")}
    assert len(lines["gg_style"]) == 1 and len(lines["per_view_2d"]) == 1
    gg = lines["gg_style"][0].split()
    assert "/seed0/geometric/kom/removed" in lines["gg_style"][0]
    for switch in (["--views", "training"], ["--masks", "footprint"], ["--init", "depth"], ["--supervision", "lpips"], ["--densify"], ["--no-condition"]):
        assert any(gg[i : i + len(switch)] == switch for i in range(len(gg))), switch
    weak = lines["per_view_2d"][0].split()
    assert "--densify" not in weak and any(weak[i : i + 2] == ["--init", "none"] for i in range(len(weak)))
    records = [line for line in out.splitlines() if "inpaint360gs table record" in line and "method=gg_style" in line]
    assert len(records) == 1 and "kind=baseline" in records[0], records


def test_the_kitchen_config_builds_runs_and_scores_a_capture(tmp_path):
    """workflow/config/kitchen.yaml plans the real-capture path alone: the photos to a scene folder
    at the SfM working size, `inpaint360gs run` at the click and resize, the no-ground-truth scores
    and figure; no synthetic scene and no table."""
    cmd = [sys.executable, "-m", "snakemake", "-n", "-p", "--cores", "1", "--directory", str(ROOT), "--snakefile", str(ROOT / "Snakefile"),
           "--configfile", str(ROOT / "workflow" / "config" / "kitchen.yaml"), "--config", f"out_dir={tmp_path}/out", f"results_dir={tmp_path}/results"]
    p = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert p.returncode == 0, p.stderr[-2000:]
    out = p.stdout + p.stderr
    assert {r: _count(out, r) for r in ("build_capture", "run_capture", "capture_scores", "synth_scene", "train_3dgs", "paper_tables")} == {
        "build_capture": 1, "run_capture": 1, "capture_scores": 1, "synth_scene": 0, "train_3dgs": 0, "paper_tables": 0}
    assert "--sfm-max-size 800 --downscale 4" in out
    assert "--click IMG_12.png:856,360 --resize 4 --preset cpu" in out
    assert f"{tmp_path}/results/captures/kitchen_removal.jpg" in out
    assert "--no-progress --accept" in out  # a result failing its check is kept and reported, not deleted with the job
    assert f"{tmp_path}/results/captures/kitchen_check.json" in out


def test_stage_defaults_come_from_the_library(tmp_path):
    """config.yaml repeats none of the distillation / inpainting defaults: the planned commands get
    the library's (DistillConfig, VirtualViewsConfig; the refinement variant's steps, so no flag),
    and a value given in the config replaces it."""
    import yaml

    from inpaint360gs.distill.config import DistillConfig
    from inpaint360gs.views.config import VirtualViewsConfig

    cfg = yaml.safe_load((ROOT / "workflow" / "config" / "config.yaml").read_text())
    assert not {"iterations"} & set(cfg["distill"] or {}) and not {"iterations", "virtual_views"} & set(cfg["inpaint"])

    def planned(*extra):
        """The planned distill and inpaint command lines (one dry run)."""
        p = _dry_run(tmp_path, "scenes=[cone]", "seeds=[0]", "methods=[full]", "train_scenes=[]", *extra)
        assert p.returncode == 0, p.stderr[-2000:]
        lines = p.stdout.splitlines()
        return [next(line for line in lines if f"inpaint360gs {stage} " in line) for stage in ("distill", "inpaint")]

    distill, inpaint = planned()
    assert f"--iterations {DistillConfig().iterations} " in distill
    assert f"--virtual-views {VirtualViewsConfig().num_views} " in inpaint and "--inpaint-iterations" not in inpaint
    distill, inpaint = planned("distill={iterations: 70}", "inpaint={iterations: 90, virtual_views: 7, extra_args: ''}")
    assert "--iterations 70 " in distill and "--inpaint-iterations 90 --virtual-views 7 " in inpaint
