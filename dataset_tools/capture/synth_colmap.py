"""A synthetic benchmark scene whose poses and sparse points come from COLMAP instead of the generator.

The workflow's ``poses: colmap`` switch: the generated scene is exported as plain photos,
``build`` reconstructs it (joint SfM, one shared camera, leak removal), and the generator's exact
unseen masks, object list and ``gt/`` are carried over. The camera model is SIMPLE_PINHOLE: the
generator renders an ideal pinhole with square pixels, so there is nothing to undistort and every
per-view ground-truth file keeps its size. ``gt/`` stays in the generator's frame and units;
``gt/colmap_frame.json`` holds the similarity that maps the COLMAP frame onto it.

An object-free photo is a test view: it is scored, never trained on. When SfM cannot place one (an
object-free view of a plain backdrop has few features to match) the scene can be built without it
(``min_test_registered``): every object-inclusive photo must still register, the unplaced test views
are named in ``gt/colmap_frame.json`` (``unplaced_test_views``) and the evaluation scores the rest.
"""

from __future__ import annotations

import json
import shutil
import tempfile
from dataclasses import replace
from pathlib import Path

import numpy as np

from dataset_tools.capture.captures import read_image_size
from dataset_tools.capture.layout import write_json
from dataset_tools.capture.pipeline import BuildConfig, BuildReport, build_dataset
from dataset_tools.capture.posecheck import pose_accuracy, reconstruction_poses, similarity_to_true
from dataset_tools.capture.synth_export import export_raw_captures, orbit_radius, true_poses
from dataset_tools.synth.scene import load_scene as load_synth_scene
from inpaint360gs.core.errors import InputError
from inpaint360gs.io.atomic import atomic_dir
from inpaint360gs.core.layout import is_image_name, is_test_name
from inpaint360gs.io.colmap import read_model
from inpaint360gs.io.images import read_mask


def check_inputs(truth: Path) -> None:
    """Everything the rebuild reads from ``truth``, checked before any SfM work: the generator's
    metadata, every image (decoded) and an unseen mask for every test view."""
    views = load_synth_scene(truth).views
    listed = {v.name for v in views}
    stray = sorted(p.name for p in (truth / "images").iterdir() if is_image_name(p.name) and p.name not in listed)
    if stray:
        raise InputError(f"{len(stray)} image(s) not in gt/cameras.json (first: {stray[0]}); not a scene as generated", truth / "images")
    for v in views:
        image = truth / "images" / v.name
        if not image.is_file():
            raise InputError("image listed in gt/cameras.json is missing", image)
        read_image_size(image)
        if v.object_free:
            read_mask(truth / "unseen_mask" / f"{Path(v.name).stem}.png")


def _check_test_views_placed(report: BuildReport, min_test_registered: float, truth: Path) -> list[str]:
    """The test views SfM could not place, after checking every object-inclusive photo registered and
    at least ``min_test_registered`` of the object-free ones did (else one line naming them)."""
    unplaced = sorted(report.registration["unregistered"])
    training = [n for n in unplaced if not is_test_name(n)]
    if training:
        raise InputError(f"{len(training)} object-inclusive photo(s) could not be placed by SfM (first: {training[0]}); "
                         "every training view must register", truth)
    n_free = report.captures["object_free"]
    needed = int(np.ceil(min_test_registered * n_free - 1e-9))
    if n_free - len(unplaced) < needed:
        raise InputError(f"only {n_free - len(unplaced)} of {n_free} object-free photos registered (needs {needed}); "
                         f"could not place {', '.join(unplaced)}", truth)
    return unplaced


def build_synthetic_with_colmap(
    truth: str | Path, out: str | Path, config: BuildConfig | None = None, overwrite: bool = False,
    min_test_registered: float | None = None,
) -> BuildReport:
    """Rebuild generated scene ``truth`` through COLMAP into ``out`` (atomically); returns the build report.

    ``min_test_registered``: None applies ``config.min_registered`` to all photos; a share in [0, 1]
    instead requires every object-inclusive photo and at least that share of the object-free ones
    (the test views), and leaves the unplaced test views out of the scene, named in
    ``gt/colmap_frame.json``.
    """
    truth, out = Path(truth), Path(out)
    if min_test_registered is not None and not 0.0 <= min_test_registered <= 1.0:
        raise InputError(f"must be a fraction in [0, 1], got {min_test_registered}", "min_test_registered")
    if not (truth / "gt" / "cameras.json").is_file():
        raise InputError("not a generated synthetic scene (gt/cameras.json missing)", truth / "gt" / "cameras.json")
    check_inputs(truth)
    cfg = config or BuildConfig()
    cfg = replace(cfg, sfm=replace(cfg.sfm, camera_model="SIMPLE_PINHOLE"), overwrite=True, scene_name=truth.name)
    if min_test_registered is not None:
        cfg = replace(cfg, min_registered=0.0)  # checked below: all training views, a share of the test views
    with atomic_dir(out, overwrite=overwrite) as tmp, tempfile.TemporaryDirectory(dir=tmp.parent) as work:
        cap = export_raw_captures(truth, Path(work) / "captures", unseen_masks=True)
        masks = shutil.move(str(cap / "unseen_masks"), Path(work) / "unseen_masks")  # not a capture folder
        built = Path(work) / "scene"
        try:
            report = build_dataset(cap, built, replace(cfg, unseen_masks=Path(masks)))
        except InputError as e:  # it names the exported copies, a temporary folder the user never sees
            raise InputError(e.message if e.path is None else f"{e.path.name}: {e.message}", truth) from None
        unplaced = _check_test_views_placed(report, min_test_registered, truth) if min_test_registered is not None else []
        for item in built.iterdir():
            shutil.move(str(item), tmp / item.name)
        shutil.copytree(truth / "gt", tmp / "gt", copy_function=shutil.copyfile)
        rec = read_model(tmp / "sparse" / "0")
        est, gt = reconstruction_poses(rec), true_poses(truth)
        M = similarity_to_true(est, gt)
        acc = pose_accuracy(est, gt, orbit_radius(truth))
        write_json(tmp / "gt" / "colmap_frame.json", {
            "true_from_colmap": {"scale": float(np.linalg.norm(M[:, 0])), "matrix_3x4": M.tolist()},
            "note": "gt/ stays in the generator's frame and units; x_true = matrix_3x4 @ [x_colmap, 1]",
            "pose_accuracy": acc.to_dict(),
            "unplaced_test_views": unplaced,  # object-free photos SfM could not place: not in the scene, not scored
        })
        meta = json.loads((truth / "scene.json").read_text())
        built_meta = json.loads((tmp / "scene.json").read_text())
        meta["provenance"] = {**meta.get("provenance", {}), "poses": "colmap", "build": built_meta["provenance"]}
        write_json(tmp / "scene.json", meta)
    return report
