"""One validated front door (docs/architecture.md, "Reliability"; ``io/arguments.py``,
``core/settings.py``): :func:`inpaint360gs.remove_object`, the run's settings (:class:`RunConfig`, a
preset changed with ``dataclasses.replace``), :func:`inpaint360gs.load_scene` and every stage
function check their arguments' types and ranges before any work, and a wrong one is an
:class:`InputError` naming it (``.setting``), never a ``TypeError``, ``OverflowError`` or a failure
minutes later inside a stage. No stage runs and nothing is written."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import pytest

import inpaint360gs
from inpaint360gs.core.errors import InputError
from inpaint360gs.pipeline import run as run_module

P = inpaint360gs.get_preset


@pytest.fixture
def no_stage(monkeypatch):
    """Any stage starting fails the test: a refusal must come first."""

    def ran(self, *a, **k):
        raise AssertionError("a stage ran")

    for stage in run_module.STAGES:
        monkeypatch.setattr(run_module.Runner, f"_{stage}", ran)


def _named(e: InputError, name: str) -> bool:
    return name in (e.setting or "") or name in str(e)


# remove_object(**kwargs) -> the argument the error must name; each case fails on its own argument
API = {  # issue: seed=-1 OverflowError after 55 s of stages, seed='1' RuntimeError in distill, out=None / scene=123 a bare TypeError, ids=['abc'] after 65 s
    "seed-negative": (dict(seed=-1), "seed"),
    "seed-string": (dict(seed="1"), "seed"),
    "seed-too-large": (dict(seed=2**40), "seed"),
    "seed-float": (dict(seed=1.5), "seed"),
    "seed-bool": (dict(seed=True), "seed"),
    "out-none": (dict(out=None), "out"),
    "out-number": (dict(out=123), "out"),
    "out-empty": (dict(out=""), "out"),
    "out-list": (dict(out=["o"]), "out"),
    "scene-number": (dict(scene=123), "scene"),
    "scene-none": (dict(scene=None), "scene"),
    "scene-empty": (dict(scene=""), "scene"),
    "scene-dict": (dict(scene={"root": "x"}), "scene"),
    "ids-strings": (dict(ids=["abc"]), "ids"),
    "ids-bool": (dict(ids=[True]), "ids"),
    "ids-zero": (dict(ids=[0]), "ids"),
    "ids-negative": (dict(ids=[-1]), "ids"),
    "ids-too-large": (dict(ids=[256]), "ids"),
    "ids-float": (dict(ids=[1.0]), "ids"),
    "ids-one-number": (dict(ids=1), "ids"),
    "ids-string": (dict(ids="1"), "ids"),
    "ids-huge": (dict(ids=[10**30]), "ids"),
    "clicks-string": (dict(clicks="IMG_003.png:3,3"), "clicks"),
    "clicks-infinite": (dict(clicks=[("IMG_003.png", math.inf, 3)]), "clicks"),
    "clicks-huge": (dict(clicks=[("IMG_003.png", 1e400, 3)]), "clicks"),
    "clicks-nan": (dict(clicks=[("IMG_003.png", math.nan, 3)]), "clicks"),
    "clicks-fraction": (dict(clicks=[("IMG_003.png", 3.5, 3)]), "clicks"),
    "clicks-string-pixel": (dict(clicks=[("IMG_003.png", "3", 3)]), "clicks"),
    "clicks-two-values": (dict(clicks=[("IMG_003.png", 3)]), "clicks"),
    "clicks-not-a-click": (dict(clicks=[object()]), "clicks"),
    "clicks-no-view": (dict(clicks=[("", 3, 3)]), "clicks"),
    "clicks-view-number": (dict(clicks=[(3, 3, 3)]), "clicks"),
    "clicks-bad-text": (dict(clicks=["IMG_003.png:x,y"]), "clicks"),
    "clicks-unknown-view": (dict(clicks=[("IMG_999.png", 3, 3)]), "clicks"),
    "clicks-outside-image": (dict(clicks=[("IMG_003.png", 3, 999)]), "clicks"),
    "clicks-test-view": (dict(clicks=[("test_000.png", 3, 3)]), "clicks"),
    "preset-unknown": (dict(preset="fast"), "preset"),
    "preset-number": (dict(preset=3), "preset"),
    "preset-none": (dict(preset=None), "preset"),
    "preset-class": (dict(preset=dict), "preset"),
    "until-unknown": (dict(until="paint"), "until"),
    "until-number": (dict(until=3), "until"),
    "model-number": (dict(model=7), "model"),
    "model-missing": (dict(model="/nonexistent/model.ply"), "model"),
    "progress-string": (dict(progress="yes"), "progress"),
    "progress-number": (dict(progress=1), "progress"),
}


@pytest.mark.parametrize("name", list(API))
def test_remove_object_refuses_a_bad_argument_before_any_stage(name, chains, tmp_path, no_stage):
    kwargs, named = API[name]
    args = {"scene": chains["cone"].scene, "out": tmp_path / "out", "ids": [1], "model": chains["cone"].model, **kwargs}
    with pytest.raises(InputError) as e:
        inpaint360gs.remove_object(**args)
    assert _named(e.value, named), (e.value.setting, str(e.value))
    assert not (tmp_path / "out").exists()


# the run's settings: a preset changed with dataclasses.replace -> the setting the error must name
def _replace(**kw):
    return lambda: dataclasses.replace(P("cpu"), **kw)


def _stage(field: str, **kw):
    return lambda: dataclasses.replace(P("cpu"), **{field: dataclasses.replace(getattr(P("cpu"), field), **kw)})


CONFIGS = {
    "run-seed-negative": (_replace(seed=-1), "RunConfig.seed"),
    "run-seed-string": (_replace(seed="0"), "RunConfig.seed"),
    "run-backend-unknown": (_replace(backend="opengl"), "RunConfig.backend"),
    "run-train-not-a-config": (_replace(train={"iterations": 5}), "RunConfig.train"),
    "run-segmenter-unknown": (_replace(segmenter="magic"), "RunConfig.segmenter"),
    "run-segmenter-options-unknown": (_replace(segmenter_options={"bogus": 1}), "segmenter_options"),
    "run-segmenter-options-not-a-dict": (_replace(segmenter_options=[1]), "RunConfig.segmenter_options"),
    "train-iterations-string": (_stage("train", iterations="10"), "TrainConfig.iterations"),
    "train-iterations-zero": (_stage("train", iterations=0), "TrainConfig.iterations"),
    "train-ssim-lambda-nan": (_stage("train", ssim_lambda=math.nan), "TrainConfig.ssim_lambda"),
    "train-background-short": (_stage("train", background=(0.0, 0.0)), "TrainConfig.background"),
    "train-sh-degree-high": (_stage("train", sh_degree=5), "TrainConfig.sh_degree"),
    "distill-iterations-zero": (_stage("distill", iterations=0), "DistillConfig.iterations"),
    "distill-lr-infinite": (_stage("distill", features_lr=math.inf), "DistillConfig.features_lr"),
    "association-sigma-above-one": (_stage("association", sigma=2.0), "AssociationConfig.sigma"),
    "association-method-unknown": (_stage("association", method="magic"), "AssociationConfig.method"),
    "removal-threshold-above-one": (_stage("removal", threshold=1.5), "RemovalConfig.threshold"),
    "removal-hull-not-bool": (_stage("removal", hull="no"), "RemovalConfig.hull"),
    "removal-outlier-k-zero": (_stage("removal", outlier_k=0), "RemovalConfig.outlier_k"),
    "inpaint-views-unknown": (_stage("inpaint", views="all"), "InpaintConfig.views"),
    "inpaint-inpainter-unknown": (_stage("inpaint", rgb_inpainter="magic"), "InpaintConfig.rgb_inpainter"),
    "inpaint-margin-negative": (_stage("inpaint", footprint_margin=-1.0), "InpaintConfig.footprint_margin"),
    "inpaint-virtual-views-zero": (lambda: dataclasses.replace(P("cpu"), inpaint=dataclasses.replace(P("cpu").inpaint, virtual=dataclasses.replace(P("cpu").inpaint.virtual, num_views=0))),
                                   "VirtualViewsConfig.num_views"),
    "inpaint-refine-variant-unknown": (lambda: dataclasses.replace(P("cpu"), inpaint=dataclasses.replace(P("cpu").inpaint, refine=dataclasses.replace(P("cpu").inpaint.refine, variant="fast"))),
                                       "RefineConfig.variant"),
}


@pytest.mark.parametrize("name", list(CONFIGS))
def test_a_bad_setting_is_refused_naming_it(name, chains, tmp_path, no_stage):
    make, setting = CONFIGS[name]
    with pytest.raises(InputError) as e:
        cfg = make()  # a wrong type is refused already here (RunConfig's construction) ...
        inpaint360gs.remove_object(chains["cone"].scene, tmp_path / "out", ids=[1], model=chains["cone"].model, preset=cfg)  # ... a range here
    assert setting in (e.value.setting or ""), (e.value.setting, str(e.value))
    assert not (tmp_path / "out").exists()


LOAD = {
    "resize-zero": (dict(resize=0), "resize"),
    "resize-fraction": (dict(resize=1.5), "resize"),
    "resize-infinite": (dict(resize=math.inf), "resize"),
    "resize-string": (dict(resize="2"), "resize"),
    "llffhold-string": (dict(llffhold="8"), "llffhold"),
    "path-number": (dict(path=5), "scene"),
    "path-none": (dict(path=None), "scene"),
}


@pytest.mark.parametrize("name", list(LOAD))
def test_load_scene_checks_its_arguments(name, chains):
    kwargs, named = LOAD[name]
    with pytest.raises(InputError) as e:
        inpaint360gs.load_scene(**{"path": chains["cone"].scene, **kwargs})
    assert named in (e.value.setting or ""), (e.value.setting, str(e.value))


# --- every stage function: (scene, inputs..., out, cfg=None, *, overwrite, progress) ---------------


def _stage_calls(scene, model, run: Path, out: Path) -> dict:
    """stage -> (function, positional args before ``out``, cfg type's bad example)."""
    from inpaint360gs.associate.stage import associate_stage
    from inpaint360gs.distill.field import IdentityField
    from inpaint360gs.distill.stage import distill_stage
    from inpaint360gs.gs.trainer import train_stage
    from inpaint360gs.inpaint.stage import inpaint_stage
    from inpaint360gs.io.ply import read_ply
    from inpaint360gs.remove.stage import remove_stage
    from inpaint360gs.render.stage import render_stage
    from inpaint360gs.segment.stage import segment_stage

    field = IdentityField.load(run / "distill")
    return {
        "train_stage": (train_stage, ()),
        "segment_stage": (segment_stage, (model,)),
        "associate_stage": (associate_stage, (model, run / "segment")),
        "distill_stage": (distill_stage, (model, run / "associate" / "object_mask", run / "associate" / "objects.json")),
        "remove_stage": (remove_stage, (field,)),
        "inpaint_stage": (inpaint_stage, (field, run / "removed")),
        "render_stage": (render_stage, (read_ply(model), scene.train_views)),
    }


BAD_CALLS = {  # what to spoil -> the argument named
    "scene-is-a-path": "scene",
    "out-is-none": "out",
    "out-is-a-number": "out",
    "cfg-of-another-stage": "cfg",
    "overwrite-is-a-string": "overwrite",
    "progress-is-a-number": "progress",
}
STAGE_NAMES = ["train_stage", "segment_stage", "associate_stage", "distill_stage", "remove_stage", "inpaint_stage", "render_stage"]


@pytest.mark.parametrize("stage", STAGE_NAMES)
@pytest.mark.parametrize("bad", list(BAD_CALLS))
def test_every_stage_function_checks_its_call(stage, bad, chains, tmp_path):
    from inpaint360gs.io.scene import load_scene

    if stage == "render_stage" and bad == "cfg-of-another-stage":
        pytest.skip("render_stage has keyword settings, no settings object")
    if stage == "distill_stage" and bad == "out-is-none":
        pytest.skip("distill_stage(out=None) distils without writing: a documented use")
    ch = chains["cone"]
    scene = load_scene(ch.scene, load_masks=False)
    fn, inputs = _stage_calls(scene, ch.model, ch.run, tmp_path / "out")[stage]
    first = ch.scene if bad == "scene-is-a-path" else scene
    out = {"out-is-none": None, "out-is-a-number": 42}.get(bad, tmp_path / "out")
    kw = {"overwrite": "yes"} if bad == "overwrite-is-a-string" else {"progress": 1} if bad == "progress-is-a-number" else {}
    args = [first, *inputs, out]
    if bad == "cfg-of-another-stage":
        args.append(dataclasses.replace(P("cpu").removal) if stage != "remove_stage" else P("cpu").train)
    with pytest.raises(InputError) as e:
        fn(*args, **kw)
    assert f"{stage}.{BAD_CALLS[bad]}" == e.value.setting, (e.value.setting, str(e.value))
    assert not (tmp_path / "out").exists()


def test_a_click_and_a_selection_are_checked_where_they_are_made():
    from inpaint360gs.remove.select import Click, check_selection

    for view, x, y in (("v", 1.5, 2), ("", 1, 2), ("v", True, 2), ("v", "1", 2), (None, 1, 2)):
        with pytest.raises(InputError):
            Click(view, x, y)
    for bad in (dict(clicks="v:1,2"), dict(ids=[0]), dict(ids=(1, "2")), dict(clicks=[("v", 1, 2)])):
        with pytest.raises(InputError):
            check_selection(bad.get("clicks"), bad.get("ids"))
    assert Click.make("v", 3.0, 4) == Click("v", 3, 4)
