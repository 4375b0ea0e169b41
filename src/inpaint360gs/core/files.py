"""File helpers every floor uses."""

from __future__ import annotations

import errno
import functools
import hashlib
import os
import stat
from pathlib import Path


@functools.lru_cache(maxsize=256)
def _sha256(path: str, _key: tuple) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def sha256_file(path: str | Path) -> str:
    """Hex SHA-256 of a file's bytes, read in 1 MiB blocks (stage records identify inputs by it).

    Hashed once per process and file version: the result is kept for the file's (device, inode,
    size, modification time), so the stages of one ``inpaint360gs run`` hash a large model once."""
    st = os.stat(path)
    return _sha256(os.path.realpath(path), (st.st_dev, st.st_ino, st.st_size, st.st_mtime_ns))


_KINDS = ((stat.S_ISFIFO, "a named pipe (FIFO)"), (stat.S_ISSOCK, "a socket"), (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"))


def path_problem(path: str | Path, *, folder: bool = False) -> str | None:
    """Why ``path`` cannot be read as a regular file (or, with ``folder``, as a folder); None when it
    can. The reason is the actual one: not found, a broken symbolic link, a symbolic link loop, a
    named pipe, a folder where a file is expected, a name too long, ... (never a traceback)."""
    kind = "folder" if folder else "file"
    try:
        st = os.stat(path)
    except FileNotFoundError:
        if os.path.islink(path):
            return f"broken symbolic link (its target {os.readlink(path)} does not exist)"
        return f"{kind} not found"
    except NotADirectoryError:
        return f"{kind} not found (a component of the path is a file, not a folder)"
    except OSError as e:
        if e.errno == errno.ELOOP:
            return "symbolic link loop (the link points back at itself)"
        return e.strerror or str(e)
    if folder:
        return None if stat.S_ISDIR(st.st_mode) else "not a folder"
    if stat.S_ISDIR(st.st_mode):
        return "is a folder, expected a file"
    if not stat.S_ISREG(st.st_mode):
        what = next((name for test, name in _KINDS if test(st.st_mode)), "a special file")
        return f"is {what}, not a regular file"
    return None


def check_readable(path: str | Path, what: str = "a file", missing: str | None = None) -> None:
    """:class:`~inpaint360gs.core.errors.InputError` naming ``path`` unless it is a regular file (not
    a folder, a named pipe that would block the reader, a link loop, ...); ``missing``: the message
    when it does not exist (default: file not found, expected ``what``)."""
    from inpaint360gs.core.errors import InputError

    problem = path_problem(path)
    if problem is None:
        return
    if problem == "file not found" and missing:
        raise InputError(missing, path)
    if problem.startswith("is a folder"):
        raise InputError(f"is a folder, expected {what}", path)
    raise InputError(f"{problem} (expected {what})", path)


def parse_json(path: str | Path):
    """The JSON value in the file ``path``: one-line :class:`InputError` naming it for a file that is
    not readable, not valid JSON (bytes or text), or nested too deeply for the parser."""
    import json

    from inpaint360gs.core.errors import InputError

    path = Path(path)
    check_readable(path, "a JSON file")
    try:
        return json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise InputError(f"not valid JSON ({e})", path) from None
    except RecursionError:
        raise InputError("JSON nested too deeply to read", path) from None


def read_json_object(path: str | Path) -> dict:
    """A JSON file that must hold an object (a stage record, scene.json); one-line errors otherwise."""
    from inpaint360gs.core.errors import InputError

    data = parse_json(path)
    if not isinstance(data, dict):
        raise InputError(f"{Path(path).name} must hold a JSON object", path)
    return data


# --- containment: what a stage reads lies inside what it was given (docs/architecture.md, "Reliability")


def resolved(p: str | Path) -> Path:
    """``p`` absolute with every link and ``..`` resolved (as far as it exists); a link loop leaves
    it absolute but unresolved."""
    try:
        return Path(p).resolve()
    except (OSError, RuntimeError):  # a symbolic link loop on older Pythons
        return Path(os.path.abspath(p))


def same_path(a: Path, b: Path) -> bool:
    """The same file or folder: equal once resolved, or the same inode (a bind mount, a hard link)."""
    if a == b:
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False


def lies_within(inner: Path, outer: Path) -> bool:
    """``inner`` lies inside the folder ``outer`` (both resolved)."""
    # a loop, not any(<generator>): a generator left suspended is closed when collected, and a
    # signal arriving in that close is lost ("Exception ignored in") instead of stopping the command
    for p in inner.parents:
        if same_path(p, outer):
            return True
    return False


def inside(root: str | Path, rel: str | Path, what: str = "the scene") -> Path:
    """``root / rel``, after checking that it lies inside ``root`` once every symbolic link is
    followed: ``rel`` is relative, has no ``..`` and no link on the way leads out of ``root``.
    Every file a stage reads from a scene, a model's folder or a run goes through here, and so
    does ``validate``; nothing outside is opened. Raises :class:`InputError` naming the path and
    where it leads (``what`` names ``root`` in the message)."""
    from inpaint360gs.core.errors import InputError

    root, rel_path = Path(root), Path(rel)
    parts = str(rel).split("/")  # as given: "images/" + an absolute name holds an empty part
    if rel_path.is_absolute() or ".." in parts or "" in parts or not str(rel).strip():
        raise InputError(f"names {str(rel)!r}, outside {what}: a stage reads only files inside {what} ({root})", root)
    path = root / rel_path
    real, top = resolved(path), resolved(root)
    if os.path.islink(path) and not os.path.exists(path):  # a broken link or a loop: say so first
        raise InputError(str(path_problem(path)), path)
    if real != top and not lies_within(real, top):
        raise InputError(f"leads to {real}, outside {what} ({top}): a stage reads only files inside {what}, links included", path)
    return path


def _links_into(folder: Path, target: Path) -> Path | None:
    """The first entry under ``folder`` (not followed into linked folders) that is a symbolic link
    resolving to ``target`` or inside it; None when there is none."""
    for top, dirs, files in os.walk(folder):
        for name in dirs + files:
            p = Path(top) / name
            if p.is_symlink():
                real = resolved(p)
                if same_path(real, target) or lies_within(real, target):
                    return p
    return None


def check_apart(outputs: dict[str, str | Path | None], inputs: dict[str, str | Path | None], *, replaced: bool = True) -> None:
    """Raise :class:`InputError` when writing an output would destroy an input or another output
    (docs/architecture.md, "Reliability": inputs are never written, also through links).

    ``outputs`` and ``inputs`` map an argument's name to its path (None: not given). Paths are
    compared resolved (symbolic links, ``..``, relative paths) and by inode (the same folder under two
    names). An output may not be an input, nor lie inside an input folder (a scene folder, a stage's
    output; with or without ``--overwrite``), nor (when the stage ``replaced`` its output folder as a
    whole, as the atomic folder writers do) be a folder that holds an input or that a link in an
    input folder leads into; two outputs may not be the same path. A command that writes into a
    scene (``unseen-masks``) does not list the scene.
    """
    from inpaint360gs.core.errors import InputError

    outs = [(k, resolved(v)) for k, v in outputs.items() if v is not None]
    ins = [(k, resolved(v)) for k, v in inputs.items() if v is not None]
    for i, (name, out) in enumerate(outs):
        for other, path in ins:
            if same_path(out, path):
                raise InputError(f"output {name} is the input {other} ({path}); choose another output", outputs[name])
            if os.path.isdir(path) and lies_within(out, path):
                raise InputError(f"output {name} lies inside the input {other} ({path}), which this stage reads; choose an output outside it", outputs[name])
            if replaced and lies_within(path, out):
                raise InputError(f"output {name} holds the input {other} ({path}); choose another output", outputs[name])
            link = _links_into(path, out) if replaced and os.path.isdir(path) and os.path.exists(out) else None
            if link is not None:
                raise InputError(f"{link} in the input {other} is a link into output {name} ({out}), which this stage replaces; choose another output", outputs[name])
        for other, path in outs[:i]:
            if same_path(out, path):
                raise InputError(f"{other} and {name} are the same path; one output would overwrite the other", outputs[name])
