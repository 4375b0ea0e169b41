"""Write one synthetic scene folder in the Inpaint360GS layout plus its ground truth under gt/.

Layout (docs/architecture.md, "Scene format"; names in ``inpaint360gs.core.layout``)::

    <name>/images/IMG_%04d.png, test_%04d.png   object-inclusive orbit captures, object-free captures
    <name>/sparse/0/                            COLMAP binary model from the true poses (pycolmap)
    <name>/unseen_mask/test_%04d.png            255 = hidden by the removed objects from every object-inclusive capture
    <name>/gt/cameras.json                      intrinsics and R, t (world->camera) of every image
    <name>/gt/instance/<stem>.png               uint8 object id at each pixel centre (0 = background)
    <name>/gt/depth/<stem>.npy                  float32 z-depth of each pixel-centre ray
    <name>/gt/depth_free/<stem>.npy             the same without the removal targets, for the photos with them
                                                (what a removal should reveal; the ground-truth removal scores)
    <name>/gt/objects.json                      id, label, shape, removal target, bounding sphere
    <name>/scene.json                           objects, removal targets, up, provenance

With a scene's photo effects on (``spec.Photo``; the realistic family) the images are what its
camera writes, and two more ground-truth files record what it did::

    <name>/gt/photometric.json                  per image: exposure gain, white balance, noise, JPEG quality
    <name>/gt/clean/test_%04d.png               the object-free captures without any photo effect

A scene whose ``poses`` are ``colmap`` (the realistic family's default) gets its ``sparse/0`` from
joint pycolmap SfM on its images only (``dataset_tools.capture.synth_colmap``: one thread, so the
run is bit-reproducible; every image must register); ``gt/`` keeps the truth, plus
``gt/colmap_frame.json`` (the similarity between the two frames and the pose accuracy).

The folder is built under a temporary name and renamed at the end (io.atomic.atomic_dir).
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import cv2
import numpy as np
from PIL import Image
from tqdm import tqdm

from dataset_tools.synth.photo import develop
from dataset_tools.synth.render import centre_depth, render
from dataset_tools.synth.scene import SynthScene, build_scene
from dataset_tools.synth.sparse import sample_points, write_sparse_model
from dataset_tools.synth.visibility import unseen_mask
from inpaint360gs import __version__
from inpaint360gs.core.errors import InputError
from inpaint360gs.core.layout import assign_splits
from inpaint360gs.io.atomic import atomic_dir

GENERATOR = "inpaint360gs-dataset synth"


def _png(path: Path, arr: np.ndarray) -> None:
    Image.fromarray(arr).save(path, format="PNG", compress_level=6)


def _json(path: Path, obj) -> None:
    path.write_text(json.dumps(obj, indent=1) + "\n")


def target_clicks(scene: SynthScene, instances: dict[str, np.ndarray]) -> list[dict]:
    """A click for each removal target, as a user would give it: the training view where the target
    covers most pixels, and its pixel farthest from the target's outline (so a click lands inside
    the object even after segmentation erodes its edges). ``instances`` maps view names to gt masks."""
    splits = assign_splits(list(instances))
    clicks = []
    for oid in scene.spec.removal_targets:
        counts = {n: int((m == oid).sum()) for n, m in sorted(instances.items()) if splits[n] == "train"}
        view = max(counts, key=lambda n: (counts[n], n))
        inside = np.pad((instances[view] == oid).astype(np.uint8), 1)  # the image border counts as outline
        dist = cv2.distanceTransform(inside, cv2.DIST_L2, 5)[1:-1, 1:-1]
        y, x = np.unravel_index(int(np.argmax(dist)), dist.shape)
        clicks.append({"object": oid, "view": view, "x": int(x), "y": int(y)})
    return clicks


def scene_metadata(scene: SynthScene, clicks: list[dict]) -> dict:
    """``scene.json`` (docs/architecture.md, "Scene format"): ``clicks`` name the removal targets the
    way a user does (method stages read only these); ``removal_targets`` lists their ids for evaluation."""
    spec = scene.spec
    meta = {
        "name": spec.name,
        "description": spec.description,
        "objects": [{"id": o.id, "label": o.label} for o in spec.objects],
        "removal_targets": spec.removal_targets,
        "clicks": clicks,
        "up": [0.0, 0.0, 1.0],
        "provenance": {
            "generator": GENERATOR,
            "version": __version__,
            "seed": scene.seed,
            "width": scene.width,
            "height": scene.height,
            "reduced": scene.reduced,
        },
    }
    if spec.family != "classic":  # the classic scenes' files stay byte for byte as committed
        meta["provenance"].update({"family": spec.family, "suite": spec.suite})
    return meta


def objects_metadata(scene: SynthScene) -> list[dict]:
    """``gt/objects.json``: every object with its geometry summary and whether it is removed."""
    out = []
    for o in scene.spec.objects:
        c, r = o.bounds()
        out.append({"id": o.id, "label": o.label, "shape": o.shape, "removal_target": o.target,
                    "bounding_sphere": {"center": [round(float(x), 6) for x in c], "radius": round(r, 6)}})
    return out


def cameras_metadata(scene: SynthScene) -> dict:
    """``gt/cameras.json``: the shared PINHOLE intrinsics and every image's exact world->camera pose."""
    c0 = scene.views[0].camera
    return {
        "model": "PINHOLE", "width": c0.width, "height": c0.height,
        "fx": c0.fx, "fy": c0.fy, "cx": c0.cx, "cy": c0.cy,
        "convention": "x_cam = R x_world + t; x right, y down, z forward; pixel (i, j) centre at (j + 0.5, i + 0.5)",
        "images": [v.to_json() for v in sorted(scene.views, key=lambda v: v.name)],
    }


def write_scene(scene: SynthScene, folder: Path, progress: bool = False) -> None:
    """Render every capture, compute unseen masks and the sparse model, and write them into ``folder``."""
    for sub in ("images", "sparse/0", "unseen_mask", "gt/instance", "gt/depth"):
        (folder / sub).mkdir(parents=True, exist_ok=True)
    bar = tqdm(total=len(scene.views) + len(scene.test_views) + 1, desc=f"synth {scene.name}", unit="step", disable=not progress, leave=True)
    renders, images, developed = {}, {}, {}
    photo = scene.spec.photo
    if photo.active:
        (folder / "gt" / "clean").mkdir(parents=True, exist_ok=True)
    for v in scene.views:
        r = render(scene.world(v.object_free), v)
        renders[v.name] = r
        if photo.active:
            images[v.name], developed[v.name] = develop(r.rgb, photo, scene.seed, v.name)
            if v.object_free:
                _png(folder / "gt" / "clean" / v.name, r.rgb8())
        else:
            images[v.name] = r.rgb8()
        _png(folder / "images" / v.name, images[v.name])
        _png(folder / "gt" / "instance" / f"{v.stem}.png", r.instance)
        np.save(folder / "gt" / "depth" / f"{v.stem}.npy", r.depth.astype(np.float32))
        if not v.object_free:
            (folder / "gt" / "depth_free").mkdir(exist_ok=True)
            np.save(folder / "gt" / "depth_free" / f"{v.stem}.npy", centre_depth(scene.world(True), v).astype(np.float32))
        bar.update(1)
    for v in scene.test_views:
        mask = unseen_mask(scene, v, renders[v.name].points)
        _png(folder / "unseen_mask" / f"{v.stem}.png", mask)
        bar.update(1)
    pts = sample_points(scene, renders, scene.n_points, scene.seed, images if photo.active else None)
    write_sparse_model(folder / "sparse" / "0", scene.views, pts)
    bar.update(1)
    bar.close()
    _json(folder / "gt" / "cameras.json", cameras_metadata(scene))
    _json(folder / "gt" / "objects.json", objects_metadata(scene))
    if photo.active:
        _json(folder / "gt" / "photometric.json", {
            "note": "per image: radiance x gain x white_balance, + noise of std sqrt(noise^2 + shot_noise x value), "
                    "8-bit, then a JPEG round trip at jpeg_quality (0: none); gt/clean/ holds the object-free captures without them",
            "images": {n: developed[n].to_json() for n in sorted(developed)},
        })
    instances = {v.name: renders[v.name].instance for v in scene.views if not v.object_free}
    _json(folder / "scene.json", scene_metadata(scene, target_clicks(scene, instances)))


def generate_scene(
    name: str,
    out_dir: str | Path,
    *,
    reduced: bool = False,
    width: int | None = None,
    height: int | None = None,
    seed: int = 0,
    overwrite: bool = False,
    progress: bool = False,
    poses: str | None = None,
) -> Path:
    """Generate catalogue scene ``name`` into ``out_dir/name`` (atomically) and return that folder.

    ``poses``: ``generator`` (true poses and points) or ``colmap`` (SfM on the images); default the
    scene's own (``SceneSpec.poses``). Deterministic: the same arguments give byte-identical files.
    """
    scene = build_scene(name, reduced=reduced, width=width, height=height, seed=seed)
    poses = poses or scene.spec.poses
    if poses not in ("generator", "colmap"):
        raise InputError(f"poses must be generator or colmap, got {poses!r}", "--poses")
    target = Path(out_dir) / scene.name
    with atomic_dir(target, overwrite=overwrite) as tmp:
        if poses == "generator":
            write_scene(scene, tmp, progress=progress)
        else:
            truth, built = tmp / ".truth" / scene.name, tmp / ".built"
            truth.mkdir(parents=True)
            write_scene(scene, truth, progress=progress)
            try:
                rebuild_with_colmap(truth, built, seed, progress)
            except InputError as e:  # it names a file of the temporary truth folder
                where = "" if e.path is None or Path(e.path).name == scene.name else f"{Path(e.path).name}: "
                raise InputError(f"{scene.name}: poses from pycolmap failed: {where}{e.message} (--poses generator gives the true poses)") from None
            for item in built.iterdir():
                shutil.move(str(item), tmp / item.name)
            shutil.rmtree(tmp / ".truth")
            built.rmdir()
            _without_run_details(tmp)
    return target


def _without_run_details(folder: Path) -> None:
    """Drop from the build's records what differs between two identical runs (temporary paths, clock
    times), so that a generated scene stays byte-reproducible with its poses from pycolmap."""
    report = json.loads((folder / "build_report.json").read_text())
    report.pop("timings", None)
    report["out"] = "(this folder)"
    report["captures"]["root"] = "(the generated images)"
    (folder / "build_report.json").write_text(json.dumps(report, indent=2) + "\n")
    meta = json.loads((folder / "scene.json").read_text())
    build = meta["provenance"]["build"]
    build.pop("created_utc", None)
    build["captures"] = "(the generated images)"
    build["config"]["unseen_masks"] = "(the generator's unseen masks)"
    (folder / "scene.json").write_text(json.dumps(meta, indent=2) + "\n")


# Registration thresholds of the synthetic scenes' SfM: half of COLMAP's (30 inliers, ratio 0.25).
# At 256x192 a photo has ~400-1000 SIFT features; with COLMAP's own thresholds a 25-photo orbit
# lost the photos that see mostly one face of the teapot's bread box (9 of 41) and one object-free
# photo of the duck's floor (1 of 41); with these every image of the dense-texture scenes
# registers, its pose error recorded in gt/colmap_frame.json.
SYNTH_ABS_POSE_MIN_INLIERS = 15
SYNTH_ABS_POSE_MIN_INLIER_RATIO = 0.15
# Every training photo must register; a test (object-free) photo may stay unplaced, as one of the
# plain-sheet scene does (an object-free view of a bare sheet has little to match). The scene is
# then scored on the test views SfM placed, the others named in gt/colmap_frame.json. Below this
# share of placed test views the build stops: the evaluation would rest on too few of them.
SYNTH_MIN_TEST_REGISTERED = 0.9


def rebuild_with_colmap(truth: Path, out: Path, seed: int, progress: bool = False) -> None:
    """``truth``'s poses and points through pycolmap into ``out`` (one thread: bit-reproducible; every
    training photo and :data:`SYNTH_MIN_TEST_REGISTERED` of the test photos must register)."""
    from dataset_tools.capture.colmap import SfMConfig
    from dataset_tools.capture.pipeline import BuildConfig
    from dataset_tools.capture.synth_colmap import build_synthetic_with_colmap

    sfm = SfMConfig(num_threads=1, seed=seed, abs_pose_min_num_inliers=SYNTH_ABS_POSE_MIN_INLIERS,
                    abs_pose_min_inlier_ratio=SYNTH_ABS_POSE_MIN_INLIER_RATIO)
    cfg = BuildConfig(sfm=sfm, progress=progress)
    build_synthetic_with_colmap(truth, out, cfg, min_test_registered=SYNTH_MIN_TEST_REGISTERED)
