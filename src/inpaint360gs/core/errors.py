"""Errors the CLI turns into one line and a documented exit code (docs/architecture.md, "Errors").

Every stage raises these instead of printing; ``inpaint360gs.cli`` maps them to exit codes:
0 success, 1 internal error (a bug: please report it), 2 bad input or usage, 3 training diverged,
4 the result failed the run's own check (its outputs are kept for inspection), 130 interrupted
(SIGINT), 143 terminated (SIGTERM).
"""

from __future__ import annotations

from pathlib import Path

EXIT_OK = 0
EXIT_INTERNAL = 1
EXIT_INPUT = 2
EXIT_DIVERGED = 3
EXIT_CHECK = 4
EXIT_SIGINT = 130
EXIT_SIGTERM = 143


class InputError(Exception):
    """Bad user input: a missing or corrupt file, a wrong size, an unknown id, an empty selection.

    The message must name the offending file and the problem in one line. A bad value of a setting
    names the setting instead (``setting``: a config field as ``"TrainConfig.iterations"``, or a
    parameter name as ``"clicks"``; several joined by ``/``); the CLI shows its option there.
    """

    def __init__(self, message: str, path: str | Path | None = None, *, setting: str | None = None):
        self.path = None if path is None else Path(path)
        self.setting = setting if path is None else None
        self.message = message
        where = path if path is not None else setting
        super().__init__(f"{where}: {message}" if where is not None else message)


class TrainingDivergedError(RuntimeError):
    """Optimisation produced NaN/Inf or diverged; the message says at which step and in which quantity."""


class CheckFailedError(Exception):
    """A run's result failed one of its own checks (docs/architecture.md, "A run checks itself"): the
    message names the check, its value and limit, and the picture to look at (``path``)."""

    def __init__(self, message: str, path: str | Path | None = None):
        self.path = None if path is None else Path(path)
        self.message = message
        super().__init__(f"{message} (see {path})" if path is not None else message)


class TestPixelAccessError(RuntimeError):
    """A method stage asked for the pixels of a ``test_`` view (only evaluation may read them)."""

    __test__ = False  # not a pytest test class


class Terminated(BaseException):
    """Raised in the main thread when the process receives SIGTERM, so ``finally`` blocks clean up.

    A ``BaseException`` like ``KeyboardInterrupt``: ordinary ``except Exception`` handlers let it pass.
    """
