"""Errors that the CLI turns into one line and a non-zero exit (DESIGN.md §7)."""

from __future__ import annotations

from pathlib import Path


class InputError(Exception):
    """Bad user input: a missing or corrupt file, a wrong size, an unknown id, an empty selection.

    The message must name the offending file (or argument) and the problem in one line.
    """

    def __init__(self, message: str, path: str | Path | None = None):
        self.path = None if path is None else Path(path)
        super().__init__(f"{path}: {message}" if path is not None else message)


class TrainingDivergedError(RuntimeError):
    """Optimisation produced NaN/Inf or diverged; the message says at which step and in which quantity."""
