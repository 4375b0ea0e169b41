"""Inputs are never written or deleted, also through links, and a run's clean-up removes only what it
created (docs/architecture.md, "Reliability"): a scene file linked into an earlier run's output, a
stage input holding a link into the output it replaces, a stage folder of OUT that is a link or a
folder the run did not write, and a mistyped option into a finished run are refused before anything
is removed, with one line naming the path (the harness hashes every tree before and after)."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest

from cli_harness import Case, check, ids_unique, restore_threads, run_cli  # noqa: F401
from reliability.chains import DISTILL, INPAINT, QUIET

T = "inpaint360gs"
RUN_FLAGS = ["--id", "1", "--distill-iterations", DISTILL[1], *INPAINT, "--no-progress", "--accept", *QUIET]  # --accept: a tiny budget fails the check


@pytest.fixture(scope="module")
def finished(chains, tmp_path_factory) -> tuple[Path, Path, Path]:
    """(scene, model, OUT) of a finished ``inpaint360gs run`` of the cone chain's scene (its own copy)."""
    from inpaint360gs.cli import main

    base = tmp_path_factory.mktemp("finished")
    ch = chains["cone"]
    scene = shutil.copytree(ch.scene, base / "data" / "cone")
    model = shutil.copytree(ch.model.parent, base / "model")
    out = base / "runs" / "cone"
    assert main(["run", str(scene), str(out), "--model", str(model / "point_cloud.ply"), *RUN_FLAGS]) == 0
    return scene, model / "point_cloud.ply", out


def finished_copy(c) -> tuple[Path, Path, Path]:
    """A private copy of the finished run, its scene and model (run.json's manifest holds inodes of
    the copied folders: they are rewritten for the copy, as the run itself would have written them)."""
    scene, model, out = c.request.getfixturevalue("finished")
    s = shutil.copytree(scene, c.tmp / "data" / "cone")
    m = shutil.copytree(model.parent, c.tmp / "model") / model.name
    o = shutil.copytree(out, c.tmp / "runs" / "cone", symlinks=True)
    rec = json.loads((o / "run.json").read_text())
    if "created" in rec:
        rec["created"] = {k: [os.stat(o / d).st_dev, os.stat(o / d).st_ino] for k, d in FOLDERS.items() if k in rec["created"]}
    (o / "run.json").write_text(json.dumps(rec, indent=1) + "\n")
    return s, m, o


FOLDERS = {"segment": "segment", "associate": "associate", "distill": "distill", "remove": "removed", "inpaint": "inpainted"}


def rerun(*changed: str, spoil=None, named=None):
    """``run`` into a copy of the finished run with ``changed`` options; ``spoil(scene, out)`` first
    (returns what the error must name, unless ``named(scene, out)`` says)."""

    def make(c):
        scene, model, out = finished_copy(c)
        got = spoil(scene, out) if spoil else None
        argv = ["run", str(scene), str(out), "--model", str(model), *RUN_FLAGS, *changed]
        return argv, str(named(scene, out) if named else got)

    return make


def image_into_out(scene: Path, out: Path) -> Path:
    """The scene's photo replaced by a link to a file of the earlier run's OUT (a stale stage's folder)."""
    target = out / "segment" / "IMG_003.png.orig"
    shutil.copy2(scene / "images" / "IMG_003.png", target)
    (scene / "images" / "IMG_003.png").unlink()
    (scene / "images" / "IMG_003.png").symlink_to(target)
    return scene / "images" / "IMG_003.png"


def stage_folder_link(stage: str):
    def spoil(scene: Path, out: Path) -> Path:
        """The stage's folder replaced by a link to a folder of the user's (which must survive)."""
        mine = out.parent / f"mine_{stage}"
        shutil.move(out / FOLDERS[stage], mine)
        (out / FOLDERS[stage]).symlink_to(mine, target_is_directory=True)
        return out / FOLDERS[stage]

    return spoil


def stage_folder_replaced(stage: str):
    def spoil(scene: Path, out: Path) -> Path:
        """The stage's folder replaced by another folder (another inode) after the run wrote it."""
        shutil.copytree(out / FOLDERS[stage], out / f"{FOLDERS[stage]}.copy")
        shutil.rmtree(out / FOLDERS[stage])
        (out / f"{FOLDERS[stage]}.copy").rename(out / FOLDERS[stage])
        return out / FOLDERS[stage]

    return spoil


def stage_folder_unlisted(stage: str):
    def spoil(scene: Path, out: Path) -> Path:
        """run.json's manifest no longer lists the stage's folder."""
        rec = json.loads((out / "run.json").read_text())
        rec["created"].pop(stage)
        (out / "run.json").write_text(json.dumps(rec))
        return out / FOLDERS[stage]

    return spoil


def lost_record(scene: Path, out: Path) -> Path:
    (out / "run.json").write_text("{not json")
    return out / "segment"


# the options that make every stage from segmentation on stale (a change in segmentation)
STALE_ALL = ("--seed", "1")
CASES = [
    # issue: a photo linked into the earlier run's output, taken away with its stale folder
    Case("run-scene-image-linked-into-out", T, rerun(*STALE_ALL, spoil=image_into_out)),
    # issue: a mistyped --id into a finished run deleted removed/ and inpainted/ before refusing
    Case("run-mistyped-id-into-finished-run", T, rerun("--id", "99", named=lambda s, o: "99")),
    Case("run-mistyped-id-out-of-range", T, rerun("--id", "300", named=lambda s, o: "300")),
    Case("run-mistyped-click-view", T, rerun("--click", "IMG_999.png:3,3", named=lambda s, o: "IMG_999.png")),
    Case("run-mistyped-click-outside-image", T, rerun("--click", "IMG_003.png:3,3000", named=lambda s, o: "3000")),
    Case("run-oracle-without-ground-truth", T, rerun("--segmenter", "oracle", named=lambda s, o: "gt")),
    Case("run-record-unreadable", T, rerun(*STALE_ALL, spoil=lost_record)),
    *(Case(f"run-{stage}-folder-is-a-link", T, rerun(*STALE_ALL, spoil=stage_folder_link(stage))) for stage in FOLDERS),
    *(Case(f"run-{stage}-folder-replaced", T, rerun(*STALE_ALL, spoil=stage_folder_replaced(stage))) for stage in FOLDERS),
    *(Case(f"run-{stage}-folder-not-in-manifest", T, rerun(*STALE_ALL, spoil=stage_folder_unlisted(stage))) for stage in FOLDERS),
]


# --- stage CLIs: an input folder holding a link into the output the stage replaces ------------------


def chain_copy(c) -> dict[str, Path]:
    ch = c.request.getfixturevalue("chains")["cone"]
    base = c.tmp / "in"
    scene = shutil.copytree(ch.scene, base / "data" / "cone")
    run = shutil.copytree(ch.run, base / "runs" / "cone")
    return {"SCENE": scene, "MODEL": run / "3dgs" / "point_cloud.ply", "SEGMENTS": run / "segment", "ASSOC": run / "associate",
            "DISTILL": run / "distill", "REMOVED": run / "removed", "INPAINTED": run / "inpainted"}  # fmt: skip


STAGE_ARGV = {  # stage -> (argv from inputs and OUT, the input folder that holds the link)
    "segment": (lambda i, o: ["segment", i["SCENE"], i["MODEL"], o, "--overwrite", "--no-progress", *QUIET], "SCENE"),
    "associate": (lambda i, o: ["associate", i["SCENE"], i["MODEL"], i["SEGMENTS"], o, "--overwrite"], "SEGMENTS"),
    "distill": (lambda i, o: ["distill", i["SCENE"], i["MODEL"], i["ASSOC"], o, "--iterations", "2", "--overwrite", "--no-progress", *QUIET], "ASSOC"),
    "remove": (lambda i, o: ["remove", i["SCENE"], i["DISTILL"], o, "--id", "1", "--overwrite", *QUIET], "DISTILL"),
    "inpaint": (lambda i, o: ["inpaint", i["SCENE"], i["DISTILL"], i["REMOVED"], o, *INPAINT, "--overwrite", "--no-progress", *QUIET], "REMOVED"),
    "render": (lambda i, o: ["render", i["MODEL"], i["SCENE"], o, "--overwrite", "--no-progress", *QUIET], "SCENE"),
}


def link_in_input(stage: str):
    argv_of, holder = STAGE_ARGV[stage]

    def make(c):
        ins = chain_copy(c)
        out = c.tmp / "out"
        (out / "keep").mkdir(parents=True)
        (out / "keep" / "precious.txt").write_text("an earlier output")
        link = ins[holder] / "notes_link.txt"
        link.symlink_to(out / "keep" / "precious.txt")
        return [str(a) for a in argv_of({k: str(v) for k, v in ins.items()}, str(out))], (str(link), "a link into output OUT")

    return make


CASES += [Case(f"{stage}-input-holds-a-link-into-out", T, link_in_input(stage)) for stage in STAGE_ARGV]


@pytest.mark.parametrize("case", ids_unique(CASES))
def test_refused_before_anything_is_removed(case, tmp_path, request, capsys):
    check(case, tmp_path, request, capsys)


def test_a_changed_setting_still_cleans_up_what_the_run_wrote(finished, tmp_path, capsys):
    """The refusals above are not over-eager: with its own folders, a changed setting removes the stale
    ones and reruns (``--until segment`` leaves nothing stale behind)."""
    scene, model, out = finished
    mine = shutil.copytree(out.parent, tmp_path / "runs") / out.name
    rec = json.loads((mine / "run.json").read_text())
    rec["created"] = {k: [os.stat(mine / d).st_dev, os.stat(mine / d).st_ino] for k, d in FOLDERS.items()}
    (mine / "run.json").write_text(json.dumps(rec))
    code, stdout, err = run_cli(T, ["run", str(scene), str(mine), "--model", str(model), *RUN_FLAGS, "--seed", "1", "--until", "segment"], capsys)
    assert code == 0, err
    assert sorted(p.name for p in mine.iterdir()) == ["run.json", "segment"]
