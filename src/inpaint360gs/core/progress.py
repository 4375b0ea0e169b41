"""Progress bars of the stages: tqdm's bar in the terminal, and the same counts to a listener of the
thread that made the bar (the viewer's Run shows the running stage's ``3DGS 1200/3000``).

* :func:`stage_bar`: a bar over a count of steps (``update(n)``, ``set_postfix``, ``close``; a
  context manager).
* :func:`track`: the items of an iterable, counted as they are taken (a loop over views).
* :func:`progress_listener`: ``with progress_listener(callback): ...`` calls
  ``callback(desc, done, total)`` for every bar made in this thread inside the block, when the bar
  is made and at each update; bars of other threads do not reach it.

Hand-written over tqdm rather than a tqdm subclass: tqdm (4.x) has no per-thread callback hook.
Its extension point is overriding ``display()`` (``tqdm.contrib.telegram`` etc.), which a bar made
with ``disable=True`` (the viewer runs the stages without terminal bars) never calls, and
``tqdm.__iter__`` counts items without going through ``update()``. So the wrapper counts itself and
leaves the terminal output to an unchanged tqdm bar."""

from __future__ import annotations

import threading
from collections.abc import Callable, Iterable, Iterator
from contextlib import contextmanager
from typing import TypeVar

T = TypeVar("T")

Listener = Callable[[str, int, "int | None"], None]

_local = threading.local()  # .listener: the current thread's listener, absent or None when there is none


def current_listener() -> Listener | None:
    """The listener registered for the calling thread (:func:`progress_listener`), or None."""
    return getattr(_local, "listener", None)


@contextmanager
def progress_listener(callback: Listener) -> Iterator[Listener]:
    """Register ``callback(desc, done, total)`` for the bars the calling thread makes inside the block.

    ``desc`` is the bar's label, ``done`` its count (``initial`` when it is made, then after every
    update; never decreasing), ``total`` its total (None when unknown). The callback runs in the
    thread that updates the bar, so it must be quick and must not raise. Blocks nest: the inner
    listener replaces the outer one until it ends. A bar keeps the listener it was made under."""
    previous = current_listener()
    _local.listener = callback
    try:
        yield callback
    finally:
        _local.listener = previous


class StageBar:
    """A stage's progress bar: a tqdm bar (shown when ``enabled``) whose counts also go to the
    listener of the thread that made it. Made by :func:`stage_bar`."""

    def __init__(self, total: int | None, desc: str, enabled: bool, initial: int = 0, **tqdm_kw):
        self.desc, self.total, self.done = desc, total, int(initial)
        from tqdm import tqdm  # imported when a bar is made (as the stages did)

        self._listener = current_listener()
        # a disabled tqdm bar does nothing; kept so that the terminal output is tqdm's, unchanged
        self._bar = tqdm(total=total, initial=initial, desc=desc, disable=not enabled, **tqdm_kw)
        self._tell()

    def _tell(self) -> None:
        if self._listener is not None:
            self._listener(self.desc, self.done, self.total)

    def update(self, n: int = 1) -> None:
        """Count ``n`` more steps done (``n`` >= 0)."""
        self.done += n
        self._bar.update(n)
        self._tell()

    def set_postfix(self, **kw) -> None:
        """tqdm's ``set_postfix`` (the terminal bar's trailing values; the listener does not get them)."""
        self._bar.set_postfix(**kw)

    def close(self) -> None:
        """End the terminal bar (idempotent); the listener has had the last count already."""
        self._bar.close()

    def __enter__(self) -> "StageBar":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def stage_bar(total: int | None, desc: str, enabled: bool, initial: int = 0, **tqdm_kw) -> StageBar:
    """A progress bar over ``total`` steps labelled ``desc``, starting at ``initial`` (a resumed run).

    Args: ``enabled`` show tqdm's bar in the terminal (the stages' ``progress``); ``tqdm_kw`` more
    of tqdm's keywords (``dynamic_ncols``, ...). Whether shown or not, the counts go to the calling
    thread's listener (:func:`progress_listener`) when there is one; with neither, an update costs a
    disabled tqdm's ``update`` and an attribute test.
    Returns: a :class:`StageBar` (a context manager that closes it)."""
    return StageBar(total, desc, enabled, initial, **tqdm_kw)


def track(iterable: Iterable[T], desc: str, enabled: bool, total: int | None = None, **tqdm_kw) -> Iterator[T]:
    """The items of ``iterable``, each counted as one step of a :func:`stage_bar` once the loop's body
    for it has run (as tqdm counts); the bar is closed when the loop ends or is left.

    Args: ``desc``, ``enabled`` and ``tqdm_kw`` as for :func:`stage_bar`; ``total`` the number of
    items (default ``len(iterable)`` when it has one, else unknown)."""
    if total is None and hasattr(iterable, "__len__"):
        total = len(iterable)  # type: ignore[arg-type]
    with stage_bar(total, desc, enabled, **tqdm_kw) as bar:
        for item in iterable:
            yield item
            bar.update(1)
