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


def read_json_object(path: str | Path) -> dict:
    """A JSON file that must hold an object (a stage record, scene.json); one-line errors otherwise."""
    import json

    from inpaint360gs.core.errors import InputError

    path = Path(path)
    check_readable(path, "a JSON file")
    try:
        data = json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as e:
        raise InputError(f"not valid JSON ({e})", path) from None
    if not isinstance(data, dict):
        raise InputError(f"{path.name} must hold a JSON object", path)
    return data
