"""Inputs are never written, and no path makes a traceback (docs/architecture.md, "Reliability").

For every CLI with an output: the output inside an input folder (an existing sub-folder with
``--overwrite``: ``segment SCENE MODEL SCENE/images --overwrite`` once replaced the photos; a new one;
reached through a symbolic link; through a relative path with ``..``; the input itself under another
name; a folder holding the input) is refused before any work, and every input tree is hashed before
and after (the harness). Then paths the operating system refuses or that are not what they seem: a
component longer than 255 characters, a symbolic link loop, a broken link, a named pipe (which would
block a reader) - each one line naming the path and the actual reason.
"""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import numpy as np
import pytest

import scene_builder as sb
from cli_harness import Case, check, ids_unique, restore_threads, run_cli  # noqa: F401

T, D = "inpaint360gs", "inpaint360gs-dataset"
LONG = "x" * 300  # one path component: more than the 255 bytes Linux allows


def copy_chain(c) -> dict[str, Path]:
    """A private copy of the ``cone`` chain (a case that wrongly goes ahead cannot spoil the shared
    one): the scene and every stage output, by role."""
    ch = c.request.getfixturevalue("chains")["cone"]
    base = c.tmp / "in"
    scene = shutil.copytree(ch.scene, base / "data" / "cone")
    run = shutil.copytree(ch.run, base / "runs" / "cone")
    return {"SCENE": scene, "MODEL": run / "3dgs" / "point_cloud.ply", "SEGMENTS": run / "segment", "ASSOC": run / "associate",
            "DISTILL": run / "distill", "REMOVED": run / "removed", "RENDERS": run / "removed_renders", "EVAL": run / "eval.json",
            "RECORD": run / "record.json", "INPAINTED": run / "inpainted"}  # fmt: skip


# CLI -> (argv from the inputs and OUT, its folder inputs with an existing sub-folder each, replaces OUT as a whole)
FAST_RUN = ["--id", "1", "--until", "segment", "--iterations", "2", "--no-progress"]
METHOD = {
    "train": (lambda i, o: ["train", i["SCENE"], o, "--iterations", "2", "--no-progress"], {"SCENE": "images"}, False),
    "segment": (lambda i, o: ["segment", i["SCENE"], i["MODEL"], o, "--no-progress"], {"SCENE": "images"}, True),
    "associate": (lambda i, o: ["associate", i["SCENE"], i["MODEL"], i["SEGMENTS"], o], {"SCENE": "sparse", "SEGMENTS": None}, True),
    "distill": (lambda i, o: ["distill", i["SCENE"], i["MODEL"], i["ASSOC"], o, "--iterations", "2", "--no-progress"], {"SCENE": "images", "ASSOC": "object_mask"}, True),
    "remove": (lambda i, o: ["remove", i["SCENE"], i["DISTILL"], o, "--id", "1"], {"SCENE": "unseen_mask", "DISTILL": None}, True),
    "inpaint": (lambda i, o: ["inpaint", i["SCENE"], i["DISTILL"], i["REMOVED"], o, "--virtual-views", "3", "--inpaint-iterations", "2", "--no-progress"],
                {"SCENE": "images", "DISTILL": None, "REMOVED": "masks"}, True),
    "render": (lambda i, o: ["render", i["MODEL"], i["SCENE"], o, "--no-progress"], {"SCENE": "sparse"}, True),
    "run": (lambda i, o: ["run", i["SCENE"], o, *FAST_RUN, "--model", i["MODEL"]], {"SCENE": "images"}, False),
    "evaluate": (lambda i, o: ["evaluate", i["RENDERS"], i["SCENE"], o, "--nets", "vgg"], {"SCENE": "unseen_mask", "RENDERS": "color"}, False),
}  # fmt: skip
OVERWRITE = {"train", "segment", "associate", "distill", "remove", "inpaint", "render"}  # take --overwrite
FILE_OUT = {"evaluate"}


def placed(stage: str, where: str, kind: str):
    """A case: ``stage`` with OUT placed by ``kind`` relative to its input ``where``."""
    argv_of, subs, _ = METHOD[stage]

    def make(c):
        ins = copy_chain(c)
        folder = ins[where]
        leaf = "m.json" if stage in FILE_OUT else "out"
        inner = leaf if stage in FILE_OUT else (subs[where] or leaf)
        if kind == "existing":
            out = folder / subs[where]
        elif kind == "new":
            out = folder / leaf
        elif kind == "symlink":  # a link in a neutral place pointing into the input
            (c.tmp / "link").symlink_to(folder if stage in FILE_OUT else folder / subs[where], target_is_directory=True)
            out = c.tmp / "link" / (leaf if stage in FILE_OUT else "")
        elif kind == "relative":  # a relative path that reaches the input through ..
            out = Path(dotted(folder, inner))
        elif kind == "same-under-two-names":
            (c.tmp / "alias").symlink_to(folder, target_is_directory=True)
            out = c.tmp / "alias"
        else:  # "parent": OUT holds the input
            out = folder.parent
        flags = ["--overwrite"] if stage in OVERWRITE else []
        argv = [str(a) for a in argv_of({k: str(v) for k, v in ins.items()}, str(out).rstrip("/") if kind != "symlink" else str(out))] + flags
        word = {"same-under-two-names": "is the input", "parent": "holds the input"}.get(kind, "inside the input")
        return argv, (str(out).rstrip("/"), word)

    return make


def dotted(folder: Path, rel: str) -> str:
    """``folder/rel`` as a relative path through ``..`` (``../../x/data/../data/cone/images``)."""
    return f"{os.path.relpath(folder.parent)}/../{folder.parent.name}/{folder.name}/{rel}"


def method_cases() -> list[Case]:
    cases = []
    for stage, (_, subs, replaces) in METHOD.items():
        for where, sub in subs.items():
            kinds = ["new", "relative"] + (["existing", "symlink"] if sub else []) + (["same-under-two-names"] if stage not in FILE_OUT else [])
            kinds += ["parent"] if replaces else []
            if stage in FILE_OUT:
                kinds = ["new", "relative", "symlink"]
            cases += [Case(f"{stage}-out-{kind}-{where.lower()}", T, placed(stage, where, kind)) for kind in kinds]
    return cases


# --- the dataset CLIs and the table outputs ---------------------------------------------------------


def scene_copy(c) -> Path:
    return copy_chain(c)["SCENE"]


def captures(c) -> Path:
    root = c.tmp / "captures"
    shutil.copytree(scene_copy(c) / "images", root / "with_objects")
    return root


def dataset_case(name: str, build):
    """``build(c) -> (argv, out)``: OUT must be refused as lying inside (or being) an input."""

    def make(c):
        argv, out, word = build(c)
        return [str(a) for a in argv], (str(out), word)

    return Case(name, D, make)


def _alias(c, folder: Path) -> Path:
    (c.tmp / "alias").symlink_to(folder, target_is_directory=True)
    return c.tmp / "alias"


DATASET = [
    dataset_case("build-out-inside-captures", lambda c: (lambda r: (["build", r, r / "scene", "--no-progress"], r / "scene", "inside the input"))(captures(c))),
    dataset_case("build-out-existing-captures-subfolder", lambda c: (lambda r: (["build", r, r / "with_objects", "--overwrite", "--no-progress"], r / "with_objects", "inside the input"))(captures(c))),
    dataset_case("build-out-is-captures-under-two-names", lambda c: (lambda r: (["build", r, _alias(c, r), "--overwrite", "--no-progress"], c.tmp / "alias", "is the input"))(captures(c))),
    dataset_case("import-out-inside-source", lambda c: (lambda r: (["import", "360usid", r, r / "imported"], r / "imported", "inside the input"))(scene_copy(c))),
    dataset_case("import-out-existing-source-subfolder", lambda c: (lambda r: (["import", "360usid", r, r / "images", "--overwrite"], r / "images", "inside the input"))(scene_copy(c))),
    dataset_case("synth-colmap-out-inside-scene", lambda c: (lambda r: (["synth-colmap", r, r / "colmap", "--no-progress"], r / "colmap", "inside the input"))(scene_copy(c))),
    dataset_case("synth-colmap-out-relative-into-scene", lambda c: (lambda r: (["synth-colmap", r, dotted(r, "sparse"), "--overwrite"], dotted(r, "sparse"),
                                                                                "inside the input"))(scene_copy(c))),
    dataset_case("validate-json-inside-scene", lambda c: (lambda r: (["validate", r, "--json", r / "report.json"], r / "report.json", "inside the input"))(scene_copy(c))),
    dataset_case("validate-json-through-a-link-into-scene", lambda c: (lambda r: (["validate", r, "--json", _alias(c, r) / "report.json"], c.tmp / "alias" / "report.json", "inside the input"))(scene_copy(c))),
    dataset_case("unseen-masks-import-from-inside-the-output", lambda c: (lambda r: (["unseen-masks", r, "--import", r / "unseen_mask", "--overwrite"], r / "unseen_mask", "is the input"))(scene_copy(c))),
    dataset_case("unseen-masks-import-from-the-scene-itself", lambda c: (lambda r: (["unseen-masks", r, "--import", r, "--overwrite"], r / "unseen_mask", "inside the input"))(scene_copy(c))),
]  # fmt: skip

TABLES = [
    Case("table-record-out-is-the-evaluation", T, lambda c: (lambda i: (["table", "record", str(i["EVAL"]), "--label", "scene=cone", "--label", "method=full", "--label", "segmenter=g",
                                                                          "--eval", str(i["EVAL"])], (str(i["EVAL"]), "is the input")))(copy_chain(c))),
    Case("table-record-out-is-the-model-under-another-name", T, lambda c: (lambda i: (["table", "record", str(_alias(c, i["INPAINTED"]) / "point_cloud.ply"), "--label", "scene=cone",
                                                                                        "--label", "method=full", "--label", "segmenter=g", "--eval", str(i["EVAL"]), "--model",
                                                                                        str(i["INPAINTED"] / "point_cloud.ply")], ("point_cloud.ply", "is the input")))(copy_chain(c))),
    Case("table-paper-out-dir-holds-a-record-it-would-overwrite", T, lambda c: (lambda i: (["table", "paper", str(i["RECORD"].parent / "per_scene.csv"), "--out-dir", str(i["RECORD"].parent)],
                                                                                           ("per_scene.csv", "is the input")))(_csv_record(c, copy_chain(c)))),
]  # fmt: skip


def _csv_record(c, ins):
    shutil.copy(ins["RECORD"], ins["RECORD"].parent / "per_scene.csv")
    return ins


# --- paths the operating system refuses, or that are not what they seem --------------------------


def long_out(stage_argv, prog: str = T, file_out: bool = False):
    """OUT with a component longer than 255 characters: one line naming it, the OS reason."""

    def make(c):
        ins = {k: str(v) for k, v in copy_chain(c).items()}
        out = str(c.tmp / LONG / ("m.json" if file_out else "out"))
        return [str(a) for a in stage_argv(ins, out)], (out, "File name too long")

    return make


def long_in(stage_argv, role: str, prog: str = T):
    """An input with a component longer than 255 characters."""

    def make(c):
        ins = {k: str(v) for k, v in copy_chain(c).items()}
        ins[role] = str(c.tmp / LONG)
        return [str(a) for a in stage_argv(ins, c.path("out"))], (ins[role], "File name too long")

    return make


RECORD = lambda i, o: ["table", "record", o, "--label", "scene=cone", "--label", "method=full", "--label", "segmenter=g", "--eval", i["EVAL"]]  # noqa: E731
PAPER = lambda i, o: ["table", "paper", i["RECORD"], "--out-dir", o]  # noqa: E731
RECON = lambda i, o: ["table", "reconstruction", i["METRICS"] if "METRICS" in i else str(Path(i["MODEL"]).parent / "metrics.json"), "--csv", o]  # noqa: E731
SYNTH = lambda i, o: ["synth", o, "--scenes", "cone", "--reduced", "--width", "48", "--height", "36", "--quiet"]  # noqa: E731
BUILD = lambda i, o: ["build", i["CAPTURES"] if "CAPTURES" in i else i["SCENE"], o, "--no-progress"]  # noqa: E731
IMPORT = lambda i, o: ["import", "360usid", i["SCENE"], o]  # noqa: E731
SYNTH_COLMAP = lambda i, o: ["synth-colmap", i["SCENE"], o, "--no-progress"]  # noqa: E731
VALIDATE = lambda i, o: ["validate", i["SCENE"], "--json", o]  # noqa: E731
UNSEEN = lambda i, o: ["unseen-masks", i["SCENE"], "--import", i["SCENE"] + "/unseen_mask", "--overwrite"]  # noqa: E731

LONG_CASES = [
    *[Case(f"{s}-out-name-too-long", T, long_out(METHOD[s][0], file_out=s in FILE_OUT)) for s in METHOD],
    *[Case(f"{s}-scene-name-too-long", T, long_in(METHOD[s][0], "SCENE")) for s in METHOD],
    *[Case(f"{s}-model-name-too-long", T, long_in(METHOD[s][0], "MODEL")) for s in ("segment", "render", "run")],
    Case("inpaint-removal-name-too-long", T, long_in(METHOD["inpaint"][0], "REMOVED")),
    Case("evaluate-renders-name-too-long", T, long_in(METHOD["evaluate"][0], "RENDERS")),
    Case("table-record-out-name-too-long", T, long_out(RECORD, file_out=True)),
    Case("table-record-eval-name-too-long", T, long_in(RECORD, "EVAL")),
    Case("table-paper-out-dir-name-too-long", T, long_out(PAPER)),
    Case("table-paper-record-name-too-long", T, long_in(PAPER, "RECORD")),
    Case("table-reconstruction-csv-name-too-long", T, long_out(RECON, file_out=True)),
    Case("table-reconstruction-metrics-name-too-long", T, long_in(RECON, "METRICS")),
    *[Case(f"{n}-out-name-too-long", D, long_out(f, D, file_out=n == "validate")) for n, f in
      (("synth", SYNTH), ("build", BUILD), ("import", IMPORT), ("synth-colmap", SYNTH_COLMAP), ("validate", VALIDATE))],
    *[Case(f"{n}-scene-name-too-long", D, long_in(f, "SCENE", D)) for n, f in
      (("build", BUILD), ("import", IMPORT), ("synth-colmap", SYNTH_COLMAP), ("validate", VALIDATE), ("unseen-masks", UNSEEN))],
]  # fmt: skip


def odd(kind: str, c) -> Path:
    """A path that is a symbolic link loop, a broken link or a named pipe."""
    p = c.tmp / f"odd_{kind}"
    if kind == "loop":
        p.symlink_to(p)
    elif kind == "broken":
        p.symlink_to(c.tmp / "gone")
    else:
        os.mkfifo(p)
    return p


REASON = {"loop": "symbolic link loop", "broken": "broken symbolic link", "fifo": "named pipe"}


def odd_in(stage_argv, role: str, kind: str, prog: str = T):
    def make(c):
        ins = {k: str(v) for k, v in copy_chain(c).items()}
        ins[role] = str(odd(kind, c))
        return [str(a) for a in stage_argv(ins, c.path("out"))], (ins[role], REASON[kind])

    return make


def odd_in_scene(rel: str, kind: str, stage: str = "segment"):
    """A file of the scene folder replaced by an odd path (a named pipe would block the reader)."""

    def make(c):
        ins = copy_chain(c)
        target = ins["SCENE"] / rel
        target.unlink(missing_ok=True)
        if kind == "fifo":
            os.mkfifo(target)
        elif kind == "loop":
            target.symlink_to(target)
        else:
            target.symlink_to(c.tmp / "gone")
        argv = METHOD[stage][0]({k: str(v) for k, v in ins.items()}, c.path("out"))
        return [str(a) for a in argv], (str(target), REASON[kind].split()[-1] if kind != "broken" else "broken")

    return make


EVAL_INCEPTION = lambda i, o: ["evaluate", i["RENDERS"], i["SCENE"], c_out(o), "--nets", "vgg", "--inception-weights", i["WEIGHTS"]]  # noqa: E731
LAMA = lambda i, o: [*METHOD["inpaint"][0](i, o), "--rgb-inpainter", "lama", "--lama-onnx", i["WEIGHTS"]]  # noqa: E731
STAGE_TSV = lambda i, o: [*RECORD(i, o + ".json"), "--stage", f"train={i['TSV']}"]  # noqa: E731
RECORD_MODEL = lambda i, o: [*RECORD(i, o + ".json"), "--model", i["PLY"]]  # noqa: E731
PAPER_CONFIG = lambda i, o: [*PAPER(i, o), "--config", i["CONFIG"]]  # noqa: E731


def c_out(o: str) -> str:
    return o + ".json"


ODD_CASES = [
    *[Case(f"{s}-model-{k}", T, odd_in(METHOD[s][0], "MODEL", k)) for s in ("segment", "associate", "distill", "render", "run") for k in REASON],
    *[Case(f"{s}-scene-{k}", T, odd_in(METHOD[s][0], "SCENE", k)) for s in ("train", "segment", "remove") for k in ("loop", "broken")],
    Case("associate-segments-loop", T, odd_in(METHOD["associate"][0], "SEGMENTS", "loop")),
    Case("inpaint-distill-broken", T, odd_in(METHOD["inpaint"][0], "DISTILL", "broken")),
    *[Case(f"evaluate-inception-weights-{k}", T, odd_in(EVAL_INCEPTION, "WEIGHTS", k)) for k in REASON],
    *[Case(f"inpaint-lama-onnx-{k}", T, odd_in(LAMA, "WEIGHTS", k)) for k in ("fifo", "loop")],
    *[Case(f"table-record-eval-{k}", T, odd_in(RECORD, "EVAL", k)) for k in REASON],
    *[Case(f"table-record-stage-tsv-{k}", T, odd_in(STAGE_TSV, "TSV", k)) for k in ("fifo", "broken")],
    *[Case(f"table-record-model-{k}", T, odd_in(RECORD_MODEL, "PLY", k)) for k in ("fifo", "loop")],
    *[Case(f"table-paper-record-{k}", T, odd_in(PAPER, "RECORD", k)) for k in ("fifo", "loop")],
    Case("table-paper-config-fifo", T, odd_in(PAPER_CONFIG, "CONFIG", "fifo")),
    Case("table-reconstruction-metrics-fifo", T, odd_in(RECON, "METRICS", "fifo")),
    Case("evaluate-out-fifo", T, lambda c: (lambda o: (METHOD["evaluate"][0]({k: str(v) for k, v in copy_chain(c).items()}, o), (o, "named pipe")))(str(odd("fifo", c)))),
    Case("table-record-out-fifo", T, lambda c: (lambda o: (RECORD({k: str(v) for k, v in copy_chain(c).items()}, o), (o, "named pipe")))(str(odd("fifo", c)))),
    *[Case(f"scene-image-{k}", T, odd_in_scene("images/IMG_003.png", k)) for k in REASON],
    Case("scene-json-fifo", T, odd_in_scene("scene.json", "fifo")),
    Case("scene-image-fifo-render", T, odd_in_scene("images/IMG_005.png", "fifo", "render")),
    Case("scene-sparse-cameras-fifo", T, odd_in_scene("sparse/0/cameras.bin", "fifo", "render")),
    Case("scene-unseen-mask-fifo", T, odd_in_scene("unseen_mask/test_000.png", "fifo", "evaluate")),
]  # fmt: skip


CASES = [*method_cases(), *DATASET, *TABLES, *LONG_CASES, *ODD_CASES]


@pytest.mark.parametrize("case", ids_unique(CASES))
def test_path_refused(case, tmp_path, request, capsys):
    check(case, tmp_path, request, capsys)


# --- the refusals are not over-eager ---------------------------------------------------------------


def test_outputs_beside_the_inputs_and_through_links_elsewhere_are_written(chains, tmp_path, capsys):
    """A link to a neutral folder, and an output beside the scene (not inside it), are fine."""
    ch = chains["cone"]
    (tmp_path / "elsewhere").mkdir()
    (tmp_path / "link").symlink_to(tmp_path / "elsewhere", target_is_directory=True)
    code, _, err = run_cli(T, ["render", str(ch.model), str(ch.scene), str(tmp_path / "link" / "r"), "--no-progress", "--threads", "2"], capsys)
    assert code == 0, err
    assert (tmp_path / "elsewhere" / "r" / "render.json").is_file()
    scene = shutil.copytree(ch.scene, tmp_path / "data" / "cone")
    code, _, err = run_cli(T, ["render", str(ch.model), str(scene), str(tmp_path / "data" / "cone_renders"), "--no-progress", "--threads", "2"], capsys)
    assert code == 0, err


def test_unseen_masks_writes_its_own_subfolder_of_the_scene(chains, tmp_path, capsys):
    """The one command made to write into a scene writes only ``unseen_mask/`` (and refuses to
    replace it without --overwrite)."""
    from cli_harness import tree

    scene = shutil.copytree(chains["cone"].scene, tmp_path / "cone")
    masks = tmp_path / "masks"
    for p in (scene / "unseen_mask").iterdir():
        sb.write_mask(masks / p.name, np.ones((24, 32), bool))
    before = tree(scene)
    code, _, err = run_cli(D, ["unseen-masks", str(scene), "--import", str(masks)], capsys)
    assert code == 2 and "--overwrite" in err
    code, _, err = run_cli(D, ["unseen-masks", str(scene), "--import", str(masks), "--overwrite"], capsys)
    assert code == 0, err
    after = tree(scene)
    changed = {k for k in before.keys() | after.keys() if before.get(k) != after.get(k)}
    assert changed and all(k.startswith("unseen_mask") for k in changed), changed
