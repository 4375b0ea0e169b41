"""Find and check the raw captures of a scene: object-inclusive photos and object-free photos.

Two ways to lay out CAPTURES (paper supp. Sec. A: the scene is captured twice, with the objects and
after physically removing them):

* two folders, ``CAPTURES/with_objects/`` and ``CAPTURES/without_objects/`` (names configurable);
* one folder holding all photos, where the object-free ones are named ``test_*`` (the prefix of the
  Inpaint360GS layout; configurable) and every other photo is object-inclusive.

The object-free photos are optional: someone who wants an object gone from their own photos has
only photos with it. Without ``without_objects/`` (or, in one folder, without ``test_*`` photos) the
scene is built with no ground truth (no ``test_`` views, no unseen masks). An EMPTY
``without_objects/`` is still an error: it looks like photos that were meant to be there.

Every photo is decoded once here, so a corrupt or truncated file, a second resolution, two photos
that would end up under the same name and two files holding the same picture (a copy, or a
ground-truth photo among the training photos) are reported before any SfM work starts.
"""

from __future__ import annotations

import hashlib
from collections import Counter
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

from PIL import Image

from inpaint360gs.core.errors import InputError
from inpaint360gs.core.layout import IMAGE_SUFFIXES, TEST_PREFIX, is_image_name, is_test_name


@dataclass(frozen=True)
class Capture:
    """One photo: where it is, whether the objects are in it, and its name in the built scene."""

    source: Path
    object_free: bool
    out_name: str  # file name under OUT/images/ (object-free ones start with ``test_``)


@dataclass
class CaptureSet:
    """All usable photos of one scene plus what was skipped and why."""

    captures: list[Capture]
    width: int
    height: int
    layout: str  # "two-folders" or "one-folder"
    skipped: dict[str, str] = field(default_factory=dict)  # source path -> reason

    @property
    def object_inclusive(self) -> list[Capture]:
        return [c for c in self.captures if not c.object_free]

    @property
    def object_free(self) -> list[Capture]:
        return [c for c in self.captures if c.object_free]

    @property
    def has_ground_truth(self) -> bool:
        """Whether object-free (ground-truth) photos were given."""
        return any(c.object_free for c in self.captures)


@dataclass
class CaptureConfig:
    """How CAPTURES is laid out."""

    with_dir: str = "with_objects"  # two-folder layout: object-inclusive photos
    without_dir: str = "without_objects"  # two-folder layout: object-free photos
    test_prefix: str = TEST_PREFIX  # one-folder layout: object-free photos start with this
    skip_unreadable: bool = False  # corrupt/truncated photos: error (default) or a reported skip


def _list_images(folder: Path, skipped: dict[str, str]) -> list[Path]:
    files = []
    for p in sorted(folder.iterdir()):
        if p.name.startswith("."):
            continue
        if p.is_dir():
            skipped[str(p)] = "sub-folder ignored"
        elif is_image_name(p.name):
            files.append(p)
        else:
            skipped[str(p)] = f"not an image ({', '.join(IMAGE_SUFFIXES)})"
    return files


def decode_image(path: Path) -> tuple[tuple[int, int], str]:
    """Decode the whole file (not just the header); return (width, height) and a digest of the pixels.

    Raises InputError for anything PIL cannot fully decode, e.g. a truncated JPEG. Equal digests mean
    the same picture, whatever the file names or encodings.
    """
    try:
        with Image.open(path) as im:
            im.load()
            digest = hashlib.sha256(f"{im.mode} {im.size}".encode() + im.tobytes()).hexdigest()
            return im.size, digest
    except (OSError, SyntaxError, ValueError, Image.DecompressionBombError) as e:
        raise InputError(f"cannot decode image ({e})", path) from None


def read_image_size(path: Path) -> tuple[int, int]:
    """(width, height) of a fully decoded image (see :func:`decode_image`)."""
    return decode_image(path)[0]


def refuse_duplicates(photos: Iterable[tuple[Path, str, bool]]) -> None:
    """Raise InputError naming both files when two photos hold the same picture; ``photos`` are
    (path, digest from :func:`decode_image`, object-free?). The same picture in the object-free and the
    object-inclusive set puts ground truth into training (docs/architecture.md, "Scene format"); twice
    in one set, it is a copy that weighs one view double."""
    seen: dict[str, tuple[Path, bool]] = {}
    for path, digest, free in photos:
        if digest in seen:
            other, other_free = seen[digest]
            if free != other_free:
                a, b = (path, other) if free else (other, path)
                raise InputError(
                    f"the same picture as object-inclusive {b}: a ground-truth (object-free) photo must "
                    "not also be a training photo; remove one of them", a)
            raise InputError(f"the same picture as {other} (a duplicate photo); remove one of them", path)
        seen[digest] = (path, free)


def collect_captures(root: str | Path, config: CaptureConfig | None = None) -> CaptureSet:
    """Find the photos under ``root`` and check them; see the module docstring for the layouts."""
    cfg = config or CaptureConfig()
    root = Path(root)
    if not root.is_dir():
        raise InputError("captures folder does not exist", root)
    skipped: dict[str, str] = {}
    with_dir, without_dir = root / cfg.with_dir, root / cfg.without_dir
    pairs: list[tuple[Path, bool]] = []
    if with_dir.is_dir() or without_dir.is_dir():
        layout = "two-folders"
        if not with_dir.is_dir():
            raise InputError("missing folder of object-inclusive photos (the two-folder layout needs it)", with_dir)
        for folder, free in ((with_dir, False), (without_dir, True)):
            if not folder.is_dir():  # only without_dir/ can be missing: no ground truth
                continue
            for p in _list_images(folder, skipped):
                if not free and is_test_name(p.name, cfg.test_prefix):
                    raise InputError(
                        f"object-inclusive photo starts with '{cfg.test_prefix}', the prefix reserved for "
                        "object-free views; rename it",
                        p,
                    )
                pairs.append((p, free))
        for p in sorted(root.iterdir()):
            if p not in (with_dir, without_dir) and not p.name.startswith("."):
                skipped[str(p)] = f"not in {cfg.with_dir}/ or {cfg.without_dir}/"
    else:
        layout = "one-folder"
        pairs = [(p, is_test_name(p.name, cfg.test_prefix)) for p in _list_images(root, skipped)]

    captures: list[Capture] = []
    sizes: dict[Path, tuple[int, int]] = {}
    digests: dict[Path, str] = {}
    for path, free in pairs:
        try:
            sizes[path], digests[path] = decode_image(path)
        except InputError as e:
            if not cfg.skip_unreadable:
                raise
            skipped[str(path)] = f"unreadable: {e}"
            continue
        name = path.name if (not free or is_test_name(path.name, cfg.test_prefix)) else cfg.test_prefix + path.name
        captures.append(Capture(source=path, object_free=free, out_name=name))
    refuse_duplicates((c.source, digests[c.source], c.object_free) for c in captures)

    # Duplicate names: masks and splits are keyed by the file stem, case-insensitively on some systems.
    seen: dict[str, Capture] = {}
    for c in captures:
        key = Path(c.out_name).stem.lower()
        if key in seen:
            raise InputError(
                f"duplicate name: becomes '{c.out_name}', like {seen[key].source} ('{seen[key].out_name}')", c.source
            )
        seen[key] = c

    n_free = sum(c.object_free for c in captures)
    if n_free == 0 and layout == "two-folders" and without_dir.is_dir():
        raise InputError(
            f"no object-free photos in {cfg.without_dir}/: add them, or remove the empty folder to build a "
            "scene without ground truth (no test_ views)", without_dir
        )
    if len(captures) - n_free < 2:
        where = with_dir if layout == "two-folders" else root
        raise InputError("fewer than 2 object-inclusive photos found", where)

    # One shared camera (paper supp. Sec. A) needs one resolution.
    (width, height), count = Counter(sizes[c.source] for c in captures).most_common(1)[0]
    for c in captures:
        if sizes[c.source] != (width, height):
            w, h = sizes[c.source]
            raise InputError(
                f"resolution {w}x{h} differs from {width}x{height} of {count} other photos "
                "(all photos share one camera, so they need one resolution)",
                c.source,
            )
    return CaptureSet(captures=captures, width=width, height=height, layout=layout, skipped=skipped)
