"""One tqdm bar per stage, fed by ``(stage, done, total)`` callbacks: long work shows progress."""

from __future__ import annotations

import sys

from tqdm import tqdm


class StageProgress:
    """Callable ``(stage, done, total)``; opens a new bar when the stage changes."""

    def __init__(self, enabled: bool = True):
        self.enabled = enabled
        self._bar: tqdm | None = None
        self._stage: str | None = None

    def __call__(self, stage: str, done: int, total: int) -> None:
        if not self.enabled:
            return
        if stage != self._stage:
            self.close()
            self._stage = stage
            self._bar = tqdm(total=total, desc=f"{stage:>10}", file=sys.stderr, leave=True, dynamic_ncols=True)
        assert self._bar is not None
        if total != self._bar.total:
            self._bar.total = total
        self._bar.update(max(0, done - self._bar.n))

    def close(self) -> None:
        if self._bar is not None:
            self._bar.close()
            self._bar = None
            self._stage = None

    def __enter__(self) -> "StageProgress":
        return self

    def __exit__(self, *exc) -> None:
        self.close()
