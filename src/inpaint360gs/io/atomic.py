"""Atomic outputs: write to a temporary name beside the target, then rename (docs/architecture.md,
"Reliability").

A crash or an error half-way never leaves a half-written file or folder under the final name, and
an exception (including ``KeyboardInterrupt`` and the CLI's SIGTERM exception) removes the
temporary. Temporaries are named ``.<target name>.<pid>.<random>.tmp[suffix]``; a process that was
killed outright (SIGKILL, power loss) cannot clean up, so every writer first removes the
temporaries of the same target whose process no longer exists. Outputs get the modes the user's
umask asks for (``tempfile`` creates them private, 0600 / 0700).
"""

from __future__ import annotations

import contextlib
import errno
import glob
import os
import re
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _publish_mode(path: Path, folder: bool) -> None:
    """Give a finished temporary the mode a plain ``open``/``mkdir`` would have given it."""
    os.chmod(path, (0o777 if folder else 0o666) & ~_umask())


def _pid_alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:  # exists, owned by someone else
        return True
    return True


def remove_stale_temporaries(target: str | Path) -> list[Path]:
    """Delete temporaries of ``target`` left by processes that no longer run; returns what was removed."""
    target = Path(target)
    folder = target.parent
    if not folder.is_dir():
        return []
    pattern = re.compile(rf"^\.{re.escape(target.name)}\.(\d+)\.[^.]+\.tmp")
    removed = []
    for p in folder.iterdir():
        m = pattern.match(p.name)
        if m and not _pid_alive(int(m.group(1))):
            shutil.rmtree(p, ignore_errors=True) if p.is_dir() and not p.is_symlink() else p.unlink(missing_ok=True)
            removed.append(p)
    old = folder / f".{target.name}.old"  # left when a replace was killed between its two renames
    if old.exists() and target.exists():
        shutil.rmtree(old, ignore_errors=True)
        removed.append(old)
    elif old.exists():  # killed after the previous output was moved aside: put it back as it was
        os.replace(old, target)
    return removed


@contextlib.contextmanager
def _signals_held() -> Iterator[None]:
    """SIGINT and SIGTERM wait until the block is done (they are delivered right after): a replace is
    never left half done by an interruption. Main thread on POSIX only; elsewhere a no-op."""
    import signal
    import threading

    if not hasattr(signal, "pthread_sigmask") or threading.current_thread() is not threading.main_thread():
        yield
        return
    held = {signal.SIGINT, signal.SIGTERM}
    before = signal.pthread_sigmask(signal.SIG_BLOCK, held)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, before)


DISK_FULL_BYTES = 1 << 20  # a write failing with less than this free on its disk failed for want of space


def _disk_full(e: BaseException, target: Path) -> OSError | None:
    """The error to raise instead of ``e`` when writing ``target`` failed because its disk is full: an
    ``OSError`` naming ``target`` (ENOSPC / EDQUOT without a file name, or any write error, such as
    torch's ``RuntimeError`` from a checkpoint, while the disk has less than :data:`DISK_FULL_BYTES`
    free); None for any other failure. The CLI shows it as one line and exit status 2."""
    if isinstance(e, OSError) and e.errno in (errno.ENOSPC, errno.EDQUOT):
        return OSError(e.errno, f"{e.strerror} (writing the output)", str(target))
    if isinstance(e, (OSError, RuntimeError)):
        try:
            free = shutil.disk_usage(target.parent).free
        except OSError:
            return None
        if free < DISK_FULL_BYTES:
            return OSError(errno.ENOSPC, f"No space left on device ({free} bytes free on its disk when the write failed)", str(target))
    return None


def _remove_own_temporaries(folder: Path, prefix: str, suffix: str) -> None:
    """Remove this process's temporaries ``<prefix><random><suffix>`` in ``folder``. By name rather
    than by the path ``tempfile`` returned: an interruption (SIGINT, the CLI's SIGTERM exception)
    can land after the temporary was created and before its path was known."""
    for p in folder.glob(glob.escape(prefix) + "*" + glob.escape(suffix)):
        if p.name[len(prefix):-len(suffix)].count(".") == 0:  # the random part only: not another target's
            shutil.rmtree(p, ignore_errors=True) if p.is_dir() and not p.is_symlink() else p.unlink(missing_ok=True)


@contextlib.contextmanager
def atomic_path(target: str | Path) -> Iterator[Path]:
    """Yield a temporary file path in the target's folder; rename it onto ``target`` on success.

    The temporary name keeps the target's suffix so that writers choosing a format by extension
    (OpenCV, PIL, numpy) still work.
    """
    target = Path(target)
    target.parent.mkdir(parents=True, exist_ok=True)
    remove_stale_temporaries(target)
    prefix, suffix = f".{target.name}.{os.getpid()}.", f".tmp{target.suffix}"
    try:
        fd, tmp = tempfile.mkstemp(prefix=prefix, suffix=suffix, dir=target.parent)
        os.close(fd)
        tmp_path = Path(tmp)
        yield tmp_path
        _publish_mode(tmp_path, folder=False)
        os.replace(tmp_path, target)
    except (OSError, RuntimeError) as e:
        full = _disk_full(e, target)
        if full is None:
            raise
        raise full from None
    finally:
        _remove_own_temporaries(target.parent, prefix, suffix)


def check_output_dir(target: str | Path, overwrite: bool = False) -> Path:
    """What :func:`atomic_dir` refuses, for a stage to check before its work: ``target`` is an
    existing file, or (without ``overwrite``) a folder that is not empty."""
    from inpaint360gs.core.errors import InputError

    target = Path(target)
    if target.exists() and not target.is_dir():
        raise InputError("output path exists and is not a folder", target)
    if target.exists() and any(target.iterdir()) and not overwrite:
        raise InputError("output folder exists and is not empty (pass --overwrite to replace it)", target)
    return target


@contextlib.contextmanager
def atomic_dir(target: str | Path, overwrite: bool = False) -> Iterator[Path]:
    """Yield a temporary folder beside ``target``; on success it replaces ``target``.

    With ``overwrite=False`` an existing non-empty target is an error (raised before any work).
    """
    target = check_output_dir(target, overwrite)
    target.parent.mkdir(parents=True, exist_ok=True)
    remove_stale_temporaries(target)
    prefix = f".{target.name}.{os.getpid()}."
    try:
        tmp = Path(tempfile.mkdtemp(prefix=prefix, suffix=".tmp", dir=target.parent))
        try:
            yield tmp
        except (OSError, RuntimeError) as e:
            full = _disk_full(e, target)
            if full is None:
                raise
            raise full from None
        _publish_mode(tmp, folder=True)  # what it holds was created with ordinary (umask) modes
        with _signals_held():
            if target.exists():
                old = target.with_name(f".{target.name}.old")
                if old.exists():
                    shutil.rmtree(old)
                os.replace(target, old)
                os.replace(tmp, target)
                shutil.rmtree(old)
            else:
                os.replace(tmp, target)
    finally:
        _remove_own_temporaries(target.parent, prefix, ".tmp")


def remove_tree(target: str | Path) -> None:
    """Delete the folder ``target``: renamed to a temporary name first, so that an interruption never
    leaves a half-deleted folder under its name (the temporary goes like any writer's)."""
    target = Path(target)
    remove_stale_temporaries(target)
    prefix = f".{target.name}.{os.getpid()}."
    try:
        tmp = Path(tempfile.mkdtemp(prefix=prefix, suffix=".tmp", dir=target.parent))
        os.replace(target, tmp / target.name)
    finally:
        _remove_own_temporaries(target.parent, prefix, ".tmp")


def write_text(target: str | Path, text: str) -> None:
    """Write ``text`` to ``target`` atomically (a temporary file renamed over it)."""
    with atomic_path(target) as tmp:
        tmp.write_text(text)
