"""One writer per output folder (docs/architecture.md, "Reliability"): ``inpaint360gs run`` and
:func:`inpaint360gs.remove_object` hold ``OUT/.lock`` while they work.

The lock is an advisory ``flock`` on that file, which holds the holder's pid, host and start time.
The kernel drops the lock when its holder ends in any way (SIGKILL included), so a lock left by a
killed run is stale by construction: the next run takes it over; no pid is guessed alive or dead.
A second run while the first holds it is refused at once with one line naming the holder.
"""

from __future__ import annotations

import contextlib
import fcntl
import json
import os
import socket
import time
from collections.abc import Iterator
from pathlib import Path

from inpaint360gs.core.errors import InputError

LOCK_NAME = ".lock"


def _holder(path: Path) -> str:
    for _ in range(20):  # the holder writes who it is right after it took the lock
        try:
            info = json.loads(path.read_text())
            return f"pid {info['pid']} on {info['host']} since {info['since']}"
        except (OSError, ValueError, KeyError, TypeError):
            time.sleep(0.05)
    return "another process"


def _remove_empty(folders: list[Path]) -> None:
    """Remove ``folders`` (innermost first) while they are empty."""
    for p in folders:
        try:
            p.rmdir()
        except OSError:
            return


@contextlib.contextmanager
def folder_lock(folder: str | Path) -> Iterator[Path]:
    """Hold the lock of the output folder ``folder`` (created when absent, and removed again when it
    is left empty) for the block; yields the lock file. Raises :class:`InputError` naming the
    folder and the holder when another process holds it."""
    folder = Path(folder)
    made = [p for p in (folder, *folder.parents) if not p.exists()]  # what the lock creates, innermost first
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / LOCK_NAME
    while True:
        fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            os.close(fd)
            _remove_empty(made)
            raise InputError(f"another run is writing this folder ({_holder(path)}); wait for it to end, or choose another output", folder) from None
        try:  # the file may have been removed by the holder that just left: lock the one on disk
            same = os.fstat(fd).st_ino == os.stat(path).st_ino
        except FileNotFoundError:
            same = False
        if same:
            break
        os.close(fd)
    try:
        os.ftruncate(fd, 0)
        os.write(fd, json.dumps({"pid": os.getpid(), "host": socket.gethostname(), "since": time.strftime("%Y-%m-%d %H:%M:%S")}).encode())
        yield path
    finally:
        with contextlib.suppress(OSError):
            path.unlink()
        os.close(fd)
        _remove_empty(made)  # only when empty: nothing was written
