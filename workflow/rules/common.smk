# Shared helpers: scenes, seeds, methods and paths derived from the config.

import fnmatch
import os
import re
import shlex

import yaml


def shell_words(value, where):
    """A config string of extra command-line arguments as shell words, each quoted (`--a 'b c'`
    stays two arguments; `$(...)`, `;`, `>` reach the command as text, never the shell): every
    config value reaches the shell quoted (docs/architecture.md, "Reliability")."""
    try:
        return shlex.join(shlex.split(value))
    except ValueError as e:
        config_error(f"{where} {value!r} is not a list of arguments ({e})")


def click_args(clicks):
    """`--click VIEW:X,Y` per click, each quoted."""
    return " ".join(f"--click {shlex.quote(c)}" for c in clicks)


EXTRA = {k: shell_words(config.get(k, {}).get("extra_args", ""), f"{k}.extra_args") for k in ("train", "segment", "remove", "inpaint")}
DATA = config["data_dir"]
OUT = config["out_dir"]
RESULTS = config["results_dir"]
THREADS = config["threads"]
BACKEND = config["backend"]
# 3DGS settings: the library's preset (defined once, inpaint360gs/pipeline/presets.py), each value
# replaced by the one `train:` gives
from inpaint360gs.pipeline.presets import PRESETS, get_preset
from inpaint360gs.segment.base import SEGMENTERS as _KNOWN_SEGMENTERS

for _where, _preset in [("train.preset", config["train"].get("preset", "cpu"))] + [
        (f"captures.{n}.preset", c["preset"]) for n, c in config.get("captures", {}).items() if "preset" in c]:  # fmt: skip
    if _preset not in PRESETS:
        config_error(f"{_where} {_preset!r} is no preset; known: {sorted(PRESETS)}")
_PRESET = get_preset(config["train"].get("preset", "cpu"))
_BUDGET = {"iterations": _PRESET.train.iterations, "max_gaussians": _PRESET.train.densify.max_gaussians, "backend": _PRESET.backend}
TRAIN = {k: config["train"][k] if config["train"].get(k) is not None else v for k, v in _BUDGET.items()}

# Distillation and inpainting settings: the library's defaults (their config dataclasses), each
# replaced by the value `distill:` / `inpaint:` gives
from inpaint360gs.distill.config import DistillConfig
from inpaint360gs.views.config import VirtualViewsConfig


def _given(section, key, default):
    value = config.get(section, {}).get(key)
    return default if value is None else value


DISTILL_ITERATIONS = _given("distill", "iterations", DistillConfig().iterations)
VIRTUAL_VIEWS = _given("inpaint", "virtual_views", VirtualViewsConfig().num_views)
# None: the refinement variant's own number of steps (inpaint360gs/inpaint/refine.py)
INPAINT_ITERATIONS = config.get("inpaint", {}).get("iterations")


def _synthetic_names():
    from dataset_tools.synth import SCENES as names

    return sorted(names)


def _is_folder(entry):
    return "/" in entry or entry.startswith(".")


def _expand(entries):
    """`all`: the ten classic scenes (docs/guide.md, "The synthetic benchmark"); `dev` / `test`: every scene
    of that suite (docs/architecture.md, "Development and test scenes"); other entries are catalogue
    names or scene folders. Keywords may be mixed with names (`[test, cone]`); repeats are dropped."""
    from dataset_tools.synth.catalogue import BENCHMARK_SCENES, suite_scenes

    out = []
    for entry in entries:
        out += list(BENCHMARK_SCENES) if entry == "all" else suite_scenes(entry) if entry in ("dev", "test") else [entry]
    return list(dict.fromkeys(out))


def _synthetic_poses(name):
    """Where a catalogue scene's poses come from by default (the realistic family: pycolmap)."""
    from dataset_tools.synth import scene_spec

    return scene_spec(name).poses


# `scenes:` entries are synthetic scene names (generated under data_dir) or scene folders (the
# released Inpaint360GS layout, a scene built from one's own photos, an imported scene): a folder's
# scene name is its last path component.
SCENE_DIRS = {}
if config.get("suite"):  # every scene of a suite instead of `scenes:` (docs/architecture.md, "Development and test scenes")
    from dataset_tools.synth.catalogue import suite_scenes

    _entries = suite_scenes(config["suite"])
else:
    _entries = _expand(config["scenes"])
for _entry in _entries:
    _name = os.path.basename(os.path.normpath(_entry)) if _is_folder(_entry) else _entry
    if _name in SCENE_DIRS:
        config_error(f"two scenes are named {_name!r}")
    SCENE_DIRS[_name] = os.path.normpath(_entry) if _is_folder(_entry) else None
SCENES = list(SCENE_DIRS)
SYNTHETIC = [s for s, d in SCENE_DIRS.items() if d is None]
# `scenes`: the benchmark's own scenes (their 3DGS is trained anyway: the table costs nothing more)
TRAIN_SCENES = list(dict.fromkeys(s for e in config["train_scenes"] for s in (SCENES if e == "scenes" else _expand([e]))))

unknown = sorted(set(SYNTHETIC + [s for s in TRAIN_SCENES if s not in SCENE_DIRS]) - set(_synthetic_names()))
if unknown:
    config_error(f"unknown scene name(s) {unknown} (synthetic: {_synthetic_names()}; a scene folder is given by its path, e.g. ./my_scene)")
missing = sorted(d for d in SCENE_DIRS.values() if d is not None and not os.path.isfile(f"{d}/scene.json"))
if missing:
    config_error(f"scene folder(s) without scene.json: {missing}")

# The method and its comparisons (paper Tab. 1 and Tab. 3). `inpaint`: the arguments of
# `inpaint360gs inpaint` (None: the scene after removal is rendered as it is).
METHODS = {
    "full": dict(kind="method", name="Inpaint360GS", association="kom", inpaint=""),
    "removal_only": dict(kind="baseline", name="removal only (no inpainting)", association="kom", inpaint=None),
    # the weak baseline: recolours the support around the hole, adds no Gaussian
    "per_view_2d": dict(
        kind="baseline",
        name="per-view 2D inpainting + 3D fine-tuning (weak)",
        association="kom",
        inpaint="--views training --masks footprint --no-condition --init none",
    ),
    # the strong baseline, Gaussian Grouping's object inpainting on the same removal: every training
    # view's footprint filled on its own, new Gaussians from those views' filled depth, densification,
    # LPIPS inside the mask and L1 outside it, the method's 2000 steps (docs/guide.md, "Tables of the paper")
    "gg_style": dict(
        kind="baseline",
        name="Gaussian-Grouping-style (strong)",
        association="kom",
        inpaint="--views training --masks footprint --no-condition --init depth --densify --supervision lpips",
    ),
    "abl_a": dict(kind="ablation", labels=dict(ablation="a"), name="w/o object association", association="tracker", inpaint=""),
    "abl_b": dict(kind="ablation", labels=dict(ablation="b"), name="w/o depth-guided initialisation", association="kom", inpaint="--init naive"),
    "abl_c": dict(kind="ablation", labels=dict(ablation="c"), name="w/o virtual views", association="kom", inpaint="--views training"),
    "abl_d": dict(kind="ablation", labels=dict(ablation="d"), name="w/o recursive conditioning", association="kom", inpaint="--no-condition"),
    "abl_e": dict(kind="ablation", labels=dict(ablation="e"), name="w/o hybrid supervision", association="kom", inpaint="--supervision mask"),
}
METHODS["full"]["labels"] = dict(virtual_views=VIRTUAL_VIEWS)
# the supplementary's study of the number of virtual views L: the full method at each L of `views_sweep`
SWEEP = [f"full_L{n}" for n in config["views_sweep"] if n != VIRTUAL_VIEWS]
for n in config["views_sweep"]:
    if n != VIRTUAL_VIEWS:
        METHODS[f"full_L{n}"] = dict(kind="sweep", name=f"Inpaint360GS, L = {n}", association="kom", inpaint=f"--virtual-views {n}",
                                     labels=dict(virtual_views=n))
unknown = sorted(set(config["methods"]) - set(METHODS))
if unknown:
    config_error(f"unknown method(s) {unknown}; known: {sorted(METHODS)}")
SEGMENTERS = list(config["segmenters"])
if set(SEGMENTERS) - set(_KNOWN_SEGMENTERS):
    config_error(f"unknown segmenter(s) {sorted(set(SEGMENTERS) - set(_KNOWN_SEGMENTERS))}; known: {sorted(_KNOWN_SEGMENTERS)}")

# Seeds of every stage after 3DGS (segment, distill and inpaint take --seed; associate and remove are
# deterministic functions of what they read): one run per scene and seed, 3DGS once per scene at `seed`.
SEEDS = list(config["seeds"])
if len(set(SEEDS)) != len(SEEDS):
    config_error(f"seeds {SEEDS} repeat a seed")
if config["ablation_seeds"] > len(SEEDS):
    config_error(f"ablation_seeds {config['ablation_seeds']} exceeds the number of seeds ({len(SEEDS)})")
# The seeds the ablations (and the L sweep) run at: their verdicts rest on their scenes (the intervals
# resample scenes), so one seed on more scenes says more than three on fewer (docs/guide.md, "Tables of the paper").
ABLATION_SEEDS = SEEDS[: config["ablation_seeds"]] if config["ablation_seeds"] else SEEDS


def _ablation_scenes():
    """Ablation -> the scenes it runs on: `ablation_scenes` is one list for every ablation (and the
    L sweep) or a mapping per ablation; entries are scene names, shell-style patterns over the
    benchmark's scenes (`teapot-*1`) or [all]; an ablation left out of a mapping runs nowhere."""
    spec = config["ablation_scenes"]
    known = [m for m, d in METHODS.items() if d["kind"] == "ablation"] + ["sweep"]
    lists = dict.fromkeys(known, spec) if isinstance(spec, list) else spec
    unknown = sorted(set(lists) - set(known))
    if unknown:
        config_error(f"ablation_scenes names {unknown}, not ablations (abl_a .. abl_e, or sweep)")
    return {m: [s for s in SCENES if any(e == "all" or fnmatch.fnmatchcase(s, e) for e in entries)] for m, entries in lists.items()}


ABLATION_SCENES = _ablation_scenes()

wildcard_constraints:
    scene="|".join(re.escape(s) for s in sorted(set(SCENES + TRAIN_SCENES))),  # a folder's name is text, not a pattern
    seed=r"\d+",
    segmenter="geometric|oracle|sam",
    association="kom|tracker",
    method="|".join(METHODS),


def synth_flags():
    flags = f"--seed {config['seed']}"
    if config["reduced"]:
        flags += " --reduced"
    return flags


def scene_dir(scene):
    """Scene folder the method stages read: a given folder, the generator's scene, or its COLMAP
    rebuild (config `poses`)."""
    if SCENE_DIRS.get(scene) is not None:
        return SCENE_DIRS[scene]
    if config["poses"] == "colmap" and _synthetic_poses(scene) != "colmap":  # else `synth` already ran pycolmap
        return f"{DATA}_colmap/{scene}"
    return f"{DATA}/{scene}"


def _overlap(a, b):
    """Whether folder ``a`` is ``b`` or lies inside it (paths resolved: links, ``..``)."""
    a, b = os.path.realpath(a), os.path.realpath(b)
    return a == b or a.startswith(b.rstrip(os.sep) + os.sep)


# Outputs never inside inputs (docs/architecture.md, "Reliability"): a scene's stage outputs, the
# tables, and the scene folders the stages read must not overlap, or a rerun would write into a scene.
for _name in sorted(set(SCENES + TRAIN_SCENES)):
    _scene = scene_dir(_name)
    for _key, _out in (("out_dir", f"{OUT}/{_name}"), ("results_dir", RESULTS)):
        if _overlap(_out, _scene) or (_key == "out_dir" and _overlap(_scene, _out)):
            config_error(f"{_key} {config[_key]!r} overlaps the scene folder {_scene!r} of scene {_name!r}: "
                         "outputs must lie outside every scene folder")


def runs():
    """(scene, seed, segmenter, method) of every run; the oracle segmenter reads the generator's
    ground truth, so it runs on synthetic scenes only; each ablation runs on its `ablation_scenes`,
    the L sweep on those of `sweep` (or, without that key, every scene some ablation runs on), both
    at `ablation_seeds`."""
    methods = list(config["methods"]) + (SWEEP if "full" in config["methods"] else [])

    def where(m):
        kind = METHODS[m]["kind"]
        if kind == "ablation":
            return ABLATION_SCENES.get(m, [])
        if kind == "sweep":
            return ABLATION_SCENES.get("sweep", sorted({s for k, v in ABLATION_SCENES.items() for s in v}))
        return SCENES

    def seeds(m):
        return ABLATION_SEEDS if METHODS[m]["kind"] in ("ablation", "sweep") else SEEDS

    return [
        (s, k, g, m)
        for s in SCENES
        for k in SEEDS
        for g in SEGMENTERS
        for m in methods
        if (g != "oracle" or s in SYNTHETIC) and s in where(m) and k in seeds(m)
    ]


# Outputs of a run: OUT/<scene>/seed<k>/<segmenter>/... (3DGS, shared by the seeds: OUT/<scene>/3dgs)
RUN = "{scene}/seed{seed}/{segmenter}"


def run_dir(wc):
    return f"{OUT}/{wc.scene}/seed{wc.seed}/{wc.segmenter}"


def removal_dir(wc, association):
    return f"{run_dir(wc)}/{association}/removed"


def method_renders(wc):
    """The test_ renders a method is evaluated on, and the stage output that holds them."""
    m = METHODS[wc.method]
    if m["inpaint"] is None:
        return f"{run_dir(wc)}/{m['association']}/removed_renders/render.json", "color"
    return f"{run_dir(wc)}/methods/{wc.method}/inpaint.json", "renders/test"


def stage_benchmarks(wc):
    """Snakemake benchmark files of every stage a method's result depends on (runtime table)."""
    m = METHODS[wc.method]
    a = m["association"]
    b = f"{OUT}/benchmarks/{wc.scene}/seed{wc.seed}/{wc.segmenter}"
    stages = {
        "train": f"{OUT}/benchmarks/{wc.scene}/train_3dgs.tsv",
        "segment": f"{b}/segment.tsv",
        "associate": f"{b}/{a}/associate.tsv",
        "distill": f"{b}/{a}/distill.tsv",
        "remove": f"{b}/{a}/remove.tsv",
    }
    if m["inpaint"] is None:
        stages["render"] = f"{b}/{a}/render_removed.tsv"
    else:
        stages["inpaint"] = f"{b}/methods/{wc.method}/inpaint.tsv"
    stages["evaluate"] = f"{b}/methods/{wc.method}/evaluate.tsv"
    return stages


def method_model(wc):
    """The PLY a method produces (its storage in the runtime table)."""
    m = METHODS[wc.method]
    if m["inpaint"] is None:
        return f"{removal_dir(wc, m['association'])}/removal.json"
    return f"{run_dir(wc)}/methods/{wc.method}/inpaint.json"


def all_targets():
    targets = [f"{scene_dir(s)}/scene.json" for s in SCENES]
    if TRAIN_SCENES:
        targets.append(f"{RESULTS}/3dgs_reconstruction.md")
    if config["methods"] and SCENES:
        targets.append(f"{RESULTS}/table1_average.md")
    targets += [f"{RESULTS}/captures/{c}_scores.json" for c in config.get("captures", {})]
    return targets
