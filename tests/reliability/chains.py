"""Two small scenes for the reliability suite, ``cone`` and ``toys`` (the same cameras and
image size, other objects), each with the outputs of every method stage made by the CLIs, as
``inpaint360gs run`` lays them out, plus an evaluation and a record (docs/architecture.md,
"Provenance chain"). Built once per test process (a few seconds); the tests never write into them
(the harness hashes them before and after every case)."""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import torch

import scene_builder as sb

W, H = 32, 24
VIEWS, TEST_VIEWS = 10, 2
CENTRES = {"cone": ((0.45, 0.0, 0.25), (-0.45, 0.15, 0.22)), "toys": ((0.0, 0.5, 0.25), (0.1, -0.5, 0.2))}
DISTILL = ["--iterations", "40"]
INPAINT = ["--virtual-views", "3", "--inpaint-iterations", "2"]
QUIET = ["--threads", "2"]


@dataclass(frozen=True)
class Chain:
    """One scene and its stage outputs."""

    name: str
    scene: Path
    run: Path

    @property
    def model(self) -> Path:  # "3dgs/point_cloud.ply", with the train stage's metrics.json beside it
        return self.run / "3dgs" / "point_cloud.ply"

    def __getattr__(self, stage: str) -> Path:  # segment, associate, distill, removed, inpainted, removed_renders
        if stage.startswith("_"):
            raise AttributeError(stage)
        return self.run / stage

    @property
    def eval(self) -> Path:
        return self.run / "eval.json"

    @property
    def record(self) -> Path:
        return self.run / "record.json"


def stage_commands(ch: Chain, run: Path | None = None) -> dict[str, list[str]]:
    """The command line of every stage of ``ch`` writing under ``run`` (default: the chain's own)."""
    run = ch.run if run is None else run
    S, M = str(ch.scene), str(ch.model)
    seg, assoc, dist, rem, inp = (str(run / n) for n in ("segment", "associate", "distill", "removed", "inpainted"))
    return {
        "segment": ["segment", S, M, seg, "--no-progress", *QUIET],
        "associate": ["associate", S, M, seg, assoc],
        "distill": ["distill", S, M, assoc, dist, *DISTILL, "--no-progress", *QUIET],
        "remove": ["remove", S, dist, rem, "--id", "1", *QUIET],
        "inpaint": ["inpaint", S, dist, rem, inp, *INPAINT, "--no-progress", *QUIET],
        "render": ["render", str(run / "removed" / "point_cloud.ply"), S, str(run / "removed_renders"), "--no-progress", *QUIET],
        "evaluate": ["evaluate", str(run / "inpainted" / "renders" / "test"), S, str(run / "eval.json"), "--nets", "vgg", *QUIET],
        "record": ["table", "record", str(run / "record.json"), "--label", f"scene={ch.name}", "--label", "method=full", "--label", "segmenter=geometric",
                   "--eval", str(run / "eval.json"), "--model", str(run / "inpainted" / "point_cloud.ply")],
    }  # fmt: skip


def _model(root: Path, run: Path, model) -> None:
    """The exact model of the scene, as the train stage leaves it (``metrics.json`` with its record)."""
    from inpaint360gs.io import provenance
    from inpaint360gs.io.ply import write_ply
    from inpaint360gs.io.scene import load_scene

    gs = run / "3dgs"
    write_ply(gs / "point_cloud.ply", model)
    metrics = {"scene": root.name, provenance.KEY: provenance.make("train", load_scene(root), {}, {"fixture": "the exact model"})}
    provenance.add_outputs(metrics, gs, "point_cloud.ply")
    (gs / "metrics.json").write_text(json.dumps(metrics, indent=1) + "\n")


def _unseen_masks(root: Path, model, labels) -> None:
    """unseen_mask/ of the test views: the footprint of object 1 (which the test views lack)."""
    from inpaint360gs.io.scene import load_scene
    from inpaint360gs.render.api import render

    obj = model.subset(labels == 1)
    with torch.no_grad():
        for v in load_scene(root).test_views:
            sb.write_mask(root / "unseen_mask" / f"{v.stem}.png", (render(obj, v.camera).alpha > 0.5).numpy())


def build_chain(base: Path, name: str) -> Chain:
    from inpaint360gs.cli import main

    root, model, labels = sb.blobs_scene(base / "data" / name, n_views=VIEWS, n_test=TEST_VIEWS, width=W, height=H, f=27.5, centres=CENTRES[name])
    _unseen_masks(root, model, labels)
    ch = Chain(name, root, base / "runs" / name)
    _model(root, ch.run, model)
    for stage, argv in stage_commands(ch).items():
        assert main(argv) == 0, (stage, argv)
    return ch
