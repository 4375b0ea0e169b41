"""``validate``: check a scene folder against the Inpaint360GS layout (docs/architecture.md, "Scene format")
and say what is wrong.

Reads the folder with pycolmap directly (no dependency on the method's scene loader). Every check
yields PASS, WARN or FAIL with a one-line reason; the scene is valid when nothing FAILs.

A scene without object-free ground truth (built from object-inclusive photos only) is valid when
``scene.json`` says so (``"ground_truth": false``): it then has no ``test_`` views and no unseen
masks, and every other check applies as usual. Without that statement a scene needs ``test_`` views.
"""

from __future__ import annotations

import os
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np

from dataset_tools.capture.captures import decode_image, refuse_duplicates
from dataset_tools.capture.layout import scaled_size
from dataset_tools.capture.leaks import leaked_point_ids
from inpaint360gs.core.errors import InputError
from inpaint360gs.core.files import inside, parse_json
from inpaint360gs.core.layout import GROUND_TRUTH_KEY, LLFFHOLD, MASK_SUFFIXES, SCENE_JSON, assign_splits, image_files, is_image_name, same_stem
from inpaint360gs.io.colmap import PINHOLE_MODELS, read_model
from inpaint360gs.io.images import find_mask, read_mask
from inpaint360gs.remove.select import click_problem, clicks_from_json


@dataclass
class Check:
    name: str
    status: str  # "pass" | "warn" | "fail"
    detail: str


@dataclass
class ValidationReport:
    scene: str
    checks: list[Check] = field(default_factory=list)

    @property
    def ok(self) -> bool:
        return not any(c.status == "fail" for c in self.checks)

    def add(self, name: str, status: str, detail: str) -> None:
        self.checks.append(Check(name, status, detail))

    def failed(self) -> list[Check]:
        return [c for c in self.checks if c.status == "fail"]

    def format(self) -> str:
        lines = [f"validate {self.scene}"]
        lines += [f"  [{c.status.upper():4}] {c.name}: {c.detail}" for c in self.checks]
        n_fail = len(self.failed())
        lines.append(f"  => {'PASS' if self.ok else 'FAIL'} ({n_fail} failed, "
                     f"{sum(c.status == 'warn' for c in self.checks)} warnings, {len(self.checks)} checks)")
        return "\n".join(lines)

    def to_dict(self) -> dict:
        return {"scene": self.scene, "ok": self.ok, "checks": [asdict(c) for c in self.checks]}


def _few(items, n: int = 3) -> str:
    items = sorted(items)
    return ", ".join(items[:n]) + (f" (+{len(items) - n} more)" if len(items) > n else "")


def _check_masks(report: ValidationReport, name: str, folder: Path, stems: dict[str, tuple[int, int]],
                 required: bool, views: set[str], kind: str) -> None:
    """Each image stem needs a mask ``folder/<stem>.png`` (or another mask suffix) of the given (w, h);
    ``required`` turns missing into FAIL. A mask whose stem is none of ``views`` (the stems of the
    images it may belong to, ``kind`` says which) FAILs: a mask of a view that does not exist (or of
    a training view, for unseen masks) is a naming mistake that would otherwise go unnoticed."""
    if not folder.is_dir():
        report.add(name, "fail" if required else "pass",
                   f"{folder.name}/ missing" if required else f"{folder.name}/ absent (optional)")
        return
    stray = sorted(p.name for p in folder.iterdir()
                   if p.is_file() and not p.name.startswith(".") and (is_image_name(p.name) or p.suffix in MASK_SUFFIXES)
                   and p.stem not in views)
    missing, wrong, nonbinary = [], [], []
    for stem, (w, h) in stems.items():
        path = find_mask(folder, [f"{stem}.png"])
        if path is None:
            missing.append(stem)
            continue
        try:
            img = read_mask(path)
        except InputError:
            wrong.append(f"{path.name} unreadable")
            continue
        if img.shape[:2] != (h, w):
            wrong.append(f"{path.name} is {img.shape[1]}x{img.shape[0]}, image is {w}x{h}")
        elif name == "unseen masks" and not np.isin(np.unique(img), (0, 255)).all():
            nonbinary.append(path.name)
    problems = []
    if missing:
        problems.append(f"{len(missing)} missing: {_few(missing)}")
    if wrong:
        problems.append(f"{len(wrong)} wrong: {_few(wrong)}")
    if stray:
        problems.append(f"{len(stray)} for no {kind}image: {_few(stray)}")
    if missing and not required and not wrong and not stray:
        report.add(name, "warn", "; ".join(problems))
    elif problems:
        report.add(name, "fail", "; ".join(problems))
    elif nonbinary:
        report.add(name, "warn", f"{len(stems)} present and sized right; {len(nonbinary)} not 0/255: {_few(nonbinary)}")
    else:
        report.add(name, "pass", f"{len(stems)} present, sized right")


def _read_scene_json(path: Path) -> tuple[dict | None, str | None]:
    """(the parsed object or None, why it is unusable or None); a missing file is (None, None)."""
    if not path.is_file():
        return None, None
    try:
        data = parse_json(path)
    except InputError as e:
        return None, e.message
    if not isinstance(data, dict):
        return None, "is not a JSON object"
    if GROUND_TRUTH_KEY in data and not isinstance(data[GROUND_TRUTH_KEY], bool):
        return data, f"{GROUND_TRUTH_KEY!r} must be true or false, got {data[GROUND_TRUTH_KEY]!r}"
    return data, None


def validate_scene(scene: str | Path, require_unseen_masks: bool = True, decode_images: bool = True) -> ValidationReport:
    """Check ``scene``; see the module docstring. Never raises for a bad folder, it reports it."""
    scene = Path(scene)
    report = ValidationReport(str(scene))
    if not scene.is_dir():
        report.add("scene folder", "fail", "does not exist")
        return report

    info, info_problem = _read_scene_json(scene / SCENE_JSON)
    no_ground_truth = info is not None and info.get(GROUND_TRUTH_KEY) is False

    # --- images (sub-folders too, as the method's loader reads them)
    img_dir = scene / "images"
    files = sorted(image_files(img_dir)) if img_dir.is_dir() else []
    if not files:
        report.add("images", "fail", "images/ missing or holds no image files")
    split = assign_splits(files)
    test_files = [f for f in files if split[f] == "test"]
    other = [f for f in files if split[f] != "test"]
    n_train, n_held = sum(s == "train" for s in split.values()), sum(s == "holdout" for s in split.values())
    if files:
        counts = f"{n_train} training + {n_held} held-out (llffhold={LLFFHOLD}) + {len(test_files)} test_ views"
        if n_train == 0:
            report.add("split", "fail", counts + " (need >= 1 training view)")
        elif no_ground_truth and test_files:
            report.add("split", "fail", counts + f" (scene.json says {GROUND_TRUTH_KEY}: false, yet test_ views exist)")
        elif no_ground_truth:
            report.add("split", "pass", counts + f" (scene.json: {GROUND_TRUTH_KEY} false, nothing to evaluate against)")
        elif not test_files:
            report.add("split", "fail", counts + f" (need >= 1 test_ view, or {GROUND_TRUTH_KEY}: false in scene.json "
                                                 "for a scene without object-free photos)")
        else:
            report.add("split", "pass", counts)

    # --- sparse model
    sparse = scene / "sparse" / "0"
    try:
        rec = read_model(sparse)
    except InputError as e:
        report.add("sparse/0", "fail", str(e))
        return report
    report.add("sparse/0", "pass",
               f"{rec.num_reg_images()} images, {rec.num_cameras()} camera(s), {rec.num_points3D()} points")

    # --- cameras
    models = {c.model_name for c in rec.cameras.values()}
    bad = models - set(PINHOLE_MODELS)
    report.add("camera model", "fail" if bad else "pass",
               f"{', '.join(sorted(models))}" + (" has distortion: undistort to PINHOLE first" if bad else ""))
    if rec.num_cameras() > 1:
        report.add("shared camera", "warn", f"{rec.num_cameras()} cameras; the protocol shares one")

    # --- containment: every file a stage reads lies inside the scene, links included (the loader's rule)
    outside = []
    names = sorted({im.name for im in rec.images.values()} | set(files))
    rels = [f"images/{n}" for n in names] + [SCENE_JSON, *(f"sparse/0/{p.name}" for p in sorted(sparse.iterdir()))]
    rels += [f"{d.name}/{n}" for d in sorted(scene.glob("images_*")) for n in names if os.path.lexists(d / n)]
    rels += [f"{k}/{p.name}" for k in ("unseen_mask", "object_mask") if (scene / k).is_dir() for p in sorted((scene / k).iterdir())]
    for rel in rels:
        if rel == SCENE_JSON and not os.path.lexists(scene / rel):
            continue
        try:
            inside(scene, rel)
        except InputError as e:
            outside.append(f"{rel} ({e.message.split(':')[0]})")
    report.add("inside the scene", "fail" if outside else "pass",
               f"{len(outside)} outside: {_few(outside, 2)}" if outside else "every file a stage reads resolves inside the scene")
    twins = same_stem({im.name for im in rec.images.values()})
    report.add("distinct stems", "fail" if twins else "pass",
               f"{twins[0]} and {twins[1]} share the stem {Path(twins[0]).stem!r}, which names every per-view output" if twins
               else "every view has a stem of its own")
    if outside or twins:
        return report

    # --- registration: every file registered, every registered image has a file, sizes match
    by_name = {im.name: im for im in rec.images.values() if im.has_pose}
    unregistered = [f for f in files if f not in by_name]
    no_file = [n for n in by_name if n not in set(files)]
    status = "fail" if unregistered or no_file else "pass"
    detail = f"all {len(files)} images registered"
    if status == "fail":
        detail = "; ".join(
            x for x in (f"{len(unregistered)} not in sparse/0: {_few(unregistered)}" if unregistered else "",
                        f"{len(no_file)} registered without a file: {_few(no_file)}" if no_file else "") if x
        )
    report.add("registration", status, detail)

    sizes: dict[str, tuple[int, int]] = {}
    wrong_size, unreadable = [], []
    digests: list[tuple[Path, str, bool]] = []
    for f in files:
        try:
            if decode_images:
                (w, h), digest = decode_image(img_dir / f)
                digests.append((Path(f), digest, split[f] == "test"))
            else:
                from PIL import Image

                with Image.open(img_dir / f) as im:
                    w, h = im.size
        except (InputError, OSError):
            unreadable.append(f)
            continue
        sizes[Path(f).stem] = (w, h)
        if f in by_name:
            cam = rec.camera(by_name[f].camera_id)
            if (cam.width, cam.height) != (w, h):
                wrong_size.append(f"{f} is {w}x{h}, camera {cam.width}x{cam.height}")
    if unreadable or wrong_size:
        report.add("image files", "fail", "; ".join(
            x for x in (f"unreadable: {_few(unreadable)}" if unreadable else "",
                        f"size mismatch: {_few(wrong_size)}" if wrong_size else "") if x))
    else:
        report.add("image files", "pass", f"{len(sizes)} decode, sizes match their camera")
    if decode_images:
        try:
            refuse_duplicates(digests)
            report.add("distinct images", "pass", f"no two of the {len(digests)} decoded images are the same picture")
        except InputError as e:
            report.add("distinct images", "fail", str(e))

    # --- downscaled copies
    for d in sorted(scene.glob("images_*")):
        try:
            factor = int(d.name.split("_", 1)[1])
        except ValueError:
            continue
        problems = []
        checked = [f for f in files if f in by_name]
        for f in checked:
            p = d / f
            if not p.is_file():
                problems.append(f"{f} missing")
                continue
            from PIL import Image

            with Image.open(p) as im:
                got = im.size
            cam = rec.camera(by_name[f].camera_id)
            want = scaled_size(cam.width, cam.height, factor)
            if got != want:
                problems.append(f"{f} is {got[0]}x{got[1]}, expected {want[0]}x{want[1]}")
        report.add(f"{d.name}/", "fail" if problems else "pass",
                   _few(problems) if problems else f"{len(checked)} registered images at 1/{factor}")

    # --- masks
    _check_masks(report, "unseen masks", scene / "unseen_mask",
                 {Path(f).stem: sizes[Path(f).stem] for f in test_files if Path(f).stem in sizes},
                 required=require_unseen_masks and bool(test_files), views={Path(f).stem for f in test_files}, kind="test_ ")
    if (scene / "object_mask").is_dir():
        _check_masks(report, "object masks", scene / "object_mask",
                     {Path(f).stem: sizes[Path(f).stem] for f in other if Path(f).stem in sizes}, required=False,
                     views={Path(f).stem for f in files}, kind="")

    # --- point leaks (docs/architecture.md, "Scene format": no point that only a test view sees)
    if rec.num_points3D() == 0:
        report.add("sparse points", "fail", "no 3D points (3DGS is initialised from them)")
    leaked = leaked_point_ids(rec)
    report.add("point leaks", "fail" if leaked else "pass",
               f"{len(leaked)} of {rec.num_points3D()} points observed only by test_ views" if leaked
               else f"every one of {rec.num_points3D()} points has an object-inclusive observation")

    # --- scene.json
    if info_problem is not None:
        report.add("scene.json", "fail", info_problem)
    elif info is None:
        report.add("scene.json", "warn", "missing (objects, removal targets and provenance unknown)")
    else:
        report.add("scene.json", "pass", "parses" + (f"; {GROUND_TRUTH_KEY}: false" if no_ground_truth else ""))
    if info is not None and "clicks" in info:  # what `inpaint360gs run` would take without --click (the same rule)
        views = {n: (rec.camera(im.camera_id).width, rec.camera(im.camera_id).height, split.get(n) == "test") for n, im in by_name.items()}
        try:
            problems = [p for p in (click_problem(c, views) for c in clicks_from_json(info["clicks"], scene / SCENE_JSON)) if p]
        except InputError as e:
            problems = [e.message]
        report.add("scene.json clicks", "fail" if problems else "pass", "; ".join(problems[:2]) if problems else f"{len(info['clicks'])} click(s) on training views, inside their images")
    return report
