"""Each default once: every option of every ``inpaint360gs`` subcommand that sets a stage's setting
defaults to that setting's config field (or library function parameter). An option left None takes
the config's own (resolved) value or the preset's; options that are no setting are listed apart."""

from __future__ import annotations

import argparse
import dataclasses
import importlib
import inspect

import pytest

from inpaint360gs.associate.config import AssociationConfig
from inpaint360gs.cli import STAGES
from inpaint360gs.distill.config import DistillConfig
from inpaint360gs.evaluate.removal import score_removal_stage, silhouette_share
from inpaint360gs.evaluate.stage import evaluate_stage
from inpaint360gs.gs.config import DensifyConfig, TrainConfig
from inpaint360gs.inpaint.refine import RefineConfig
from inpaint360gs.inpaint.stage import InpaintConfig
from inpaint360gs.io.scene import load_scene
from inpaint360gs.pipeline.run import STAGES as RUN_STAGES
from inpaint360gs.pipeline.run import RunConfig
from inpaint360gs.remove.config import RemovalConfig
from inpaint360gs.remove.stage import remove_stage
from inpaint360gs.report.geometry import depth_off
from inpaint360gs.render.api import render
from inpaint360gs.segment.cluster3d import ClusterConfig
from inpaint360gs.segment.geometric import GeometricConfig
from inpaint360gs.segment.oracle import OracleConfig
from inpaint360gs.segment.sam import SamConfig
from inpaint360gs.viewer.api import view
from inpaint360gs.views.config import VirtualViewsConfig

# where each subcommand's settings live, searched in this order (nested dataclasses after their owner)
SOURCES = {
    "train": [TrainConfig],
    "segment": [GeometricConfig, ClusterConfig, OracleConfig, SamConfig, RunConfig],
    "render": [render],
    "associate": [AssociationConfig],
    "remove": [RemovalConfig, remove_stage],
    "inpaint": [InpaintConfig],
    "run": [RunConfig, InpaintConfig],
    "evaluate": [evaluate_stage, silhouette_share, depth_off],
    "score-removal": [score_removal_stage],
    "distill": [DistillConfig],
    "capture-scores": [],
    "table": [],
    "view": [view, RunConfig],
}
# option -> (where, field) when the names differ
RENAMED = {
    "densify_grad_threshold": (DensifyConfig, "grad_threshold"),
    "densify_gradient": (DensifyConfig, "gradient"),
    "max_gaussians": (DensifyConfig, "max_gaussians"),
    "distill_iterations": (DistillConfig, "iterations"),
    "association": (AssociationConfig, "method"),
    "virtual_views": (VirtualViewsConfig, "num_views"),
    "refine_variant": (RefineConfig, "variant"),
    "inpaint_iterations": (RefineConfig, "iterations"),
    "supervision": (RefineConfig, "supervision"),
    # the 3D inpainting's density control (the strong baseline), not 3DGS training's of RunConfig.train
    "densify": (RefineConfig, "densify"),
    "densify_until": (RefineConfig, "densify_until"),
    "densify_grad": (RefineConfig, "densify_grad"),
    "sam_stability_thresh": (SamConfig, "stability_score_thresh"),
    "sam_min_region_area": (SamConfig, "min_mask_region_area"),
    "nets": (evaluate_stage, "nets"),
}
# options that are no stage setting (what to read, where to write, how to run, what to show)
NOT_SETTINGS = {
    "overwrite", "no_progress", "threads", "resume", "removal", "allow_unregistered", "click", "id", "model", "until", "preset", "split",
    "white_background", "inception_weights", "inpainted", "figure", "views_capture", "sam_encoder", "sam_decoder",
    "no_protect_support",  # a switch: protect_support 0
    "accept",  # keep a result that fails the run's check: what to do with a result, not a setting of it
}  # fmt: skip


def _defaults(source) -> dict[str, object]:
    """Field (or parameter) -> default of a dataclass (nested ones after it) or a function."""
    if not dataclasses.is_dataclass(source):
        return {k: p.default for k, p in inspect.signature(source).parameters.items() if p.default is not inspect.Parameter.empty}
    out, nested = {}, []
    for f in dataclasses.fields(source):
        value = f.default if f.default is not dataclasses.MISSING else f.default_factory() if f.default_factory is not dataclasses.MISSING else None
        out[f.name] = value
        if dataclasses.is_dataclass(value):
            nested.append(type(value))
    for cls in nested:
        out = {**_defaults(cls), **out}
    return out


def _expected(stage: str, dest: str):
    """(found, the default the option must have)."""
    if dest in ("resize", "llffhold"):
        return True, _defaults(load_scene)[dest]
    if dest in RENAMED:
        where, name = RENAMED[dest]
        return True, _defaults(where)[name]
    name, flip = (dest[3:], True) if dest.startswith("no_") else (dest.removeprefix("sam_"), False)
    for source in SOURCES[stage]:
        d = _defaults(source)
        if name in d:
            return True, (not d[name]) if flip else d[name]
    return False, None


def _options(stage: str) -> list[argparse.Action]:
    parser = argparse.ArgumentParser()
    importlib.import_module(STAGES[stage][0]).add_arguments(parser)
    return [a for a in parser._actions if a.option_strings and a.dest != "help"]


@pytest.mark.parametrize("stage", list(STAGES))
def test_every_option_defaults_to_its_setting(stage):
    bad = []
    for a in _options(stage):
        dest = "views_capture" if (stage, a.dest) == ("capture-scores", "views") else a.dest
        if dest in NOT_SETTINGS:
            continue
        found, want = _expected(stage, dest)
        if not found:
            bad.append(f"--{a.dest}: no config field of that name (add it to RENAMED or NOT_SETTINGS)")
        elif a.default is None:
            continue  # the config's resolved value, or the preset's
        elif isinstance(want, tuple) and isinstance(a.default, str):
            if a.default.split(",") != list(want):
                bad.append(f"--{a.dest}: default {a.default!r}, the setting's {want!r}")
        elif a.default != want:
            bad.append(f"--{a.dest}: default {a.default!r}, the setting's {want!r}")
    assert not bad, f"inpaint360gs {stage}:\n" + "\n".join(bad)


def test_the_run_stages_are_the_cli_until_choices():
    until = next(a for a in _options("run") if a.dest == "until")
    assert tuple(until.choices) == RUN_STAGES and until.default == RUN_STAGES[-1]


def test_a_bad_setting_is_named_by_its_option_on_the_command_line():
    """Library code names a bad setting by its config field (or parameter); the command line shows
    the option that sets it, in every stage that has one (renamed ones included)."""
    from inpaint360gs.cli.common import option_of

    def parser(stage):
        p = argparse.ArgumentParser()
        importlib.import_module(STAGES[stage][0]).add_arguments(p)
        return p

    assert option_of("TrainConfig.iterations", parser("train")) == "--iterations"
    assert option_of("DistillConfig.iterations", parser("distill")) == "--iterations"
    assert option_of("DistillConfig.iterations", parser("run")) == "--distill-iterations"
    assert option_of("RefineConfig.iterations", parser("run")) == "--inpaint-iterations"
    assert option_of("VirtualViewsConfig.num_views", parser("inpaint")) == "--virtual-views"
    assert option_of("DensifyConfig.grad_threshold", parser("train")) == "--densify-grad-threshold"
    assert option_of("clicks", parser("remove")) == "--click"
    assert option_of("AssociationConfig.part_share/AssociationConfig.merge_share", parser("associate")) == "--part-share/--merge-share"
    assert option_of("skip_reason", parser("table")) == "--skip-reason"  # a subcommand's option
    assert option_of("InpaintConfig.nothing_like_it", parser("inpaint")) == "InpaintConfig.nothing_like_it"


def test_library_code_names_settings_not_command_line_options():
    """No ``"--option"`` string in the library outside ``cli/``: errors name the setting and the CLI
    layer names the option (above)."""
    import re
    from pathlib import Path

    src = Path(importlib.import_module("inpaint360gs").__file__).parent
    found = [f"{p.relative_to(src)}:{i}" for p in sorted(src.rglob("*.py")) if p.parent.name != "cli"
             for i, line in enumerate(p.read_text().splitlines(), 1) if re.search(r"""["']--[a-z]""", line) and "git" not in line]
    assert not found, found


def _owner(source, name: str):
    """The dataclass among ``source`` and its nested config fields that has the field ``name``."""
    if not dataclasses.is_dataclass(source):
        return None
    fields = {f.name: f for f in dataclasses.fields(source)}
    if name in fields:
        return source
    for f in fields.values():
        if f.default_factory is not dataclasses.MISSING and dataclasses.is_dataclass(f.default_factory):
            if (hit := _owner(f.default_factory, name)) is not None:
                return hit
    return None


@pytest.mark.parametrize("stage", list(STAGES))
def test_every_config_field_with_an_option_is_named_by_that_option(stage):
    """An error about any config field that a stage's option sets names that option (cli.common.option_of):
    the same option <-> field correspondence the defaults test above checks."""
    from inpaint360gs.cli.common import option_of

    parser = argparse.ArgumentParser()
    importlib.import_module(STAGES[stage][0]).add_arguments(parser)
    bad = []
    for a in _options(stage):
        if a.dest in NOT_SETTINGS or a.dest in ("resize", "llffhold") or (stage, a.dest) == ("capture-scores", "views") or a.option_strings[-1].startswith("--no-"):
            continue  # not a setting, a scene argument, or a switch (no bad value to name)
        if a.dest in RENAMED:
            owner, name = RENAMED[a.dest]
        else:
            name = a.dest.removeprefix("sam_")
            owner = next((o for s in SOURCES[stage] if (o := _owner(s, name)) is not None), None)
        if owner is None or not dataclasses.is_dataclass(owner):
            continue  # a function parameter: named as the parameter
        got = option_of(f"{owner.__name__}.{name}", parser)
        if got != max(a.option_strings, key=len):
            bad.append(f"{owner.__name__}.{name} -> {got}, not {max(a.option_strings, key=len)}")
    assert not bad, f"inpaint360gs {stage}: " + "; ".join(bad)


def test_the_cli_lists_the_backends_the_registry_has_without_importing_torch():
    """--backend's choices come from the backend files' names (the viewer's command parses its
    arguments and serves its page before torch is imported); they are the registry's."""
    import subprocess
    import sys

    from inpaint360gs.cli.common import backend_choices
    from inpaint360gs.render.backends import backend_choices as registry_choices

    assert backend_choices()[0] == "auto" and set(backend_choices()) == set(registry_choices())
    code = ("import argparse, sys; from inpaint360gs.cli import view; view.add_arguments(argparse.ArgumentParser()); "
            "print('torch' in sys.modules)")  # fmt: skip
    assert subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.strip() == "False"
