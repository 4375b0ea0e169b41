"""The model of a paper table (:mod:`.paper`): text label columns, numeric :class:`Column` s and rows
of values with their statistics; and the settings of the bootstrap that compares rows.

A row is a dict: label values, numbers (``None`` = missing), and per statistics column
``<key>_std``, ``<key>_ci_low``, ``<key>_ci_high``, ``<key>_mark``; ``_not_run`` holds the keys of
the stages a method does not have. :mod:`.builders` fills tables, :mod:`.formats` writes them.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from inpaint360gs.report import stats
from inpaint360gs.report.stats import NONE

MISSING = "–"  # a value that is null (the notes say why)
NOT_RUN = "—"  # a stage the method does not have
SUFFIXES = ("std", "ci_low", "ci_high", "mark")  # the statistics of a value (CSV columns <metric>_<suffix>)


@dataclass(frozen=True)
class Bootstrap:
    """Settings of the paired bootstrap intervals (:func:`.stats.bootstrap_mean`)."""

    confidence: float = stats.CONFIDENCE
    resamples: int = stats.RESAMPLES
    seed: int = stats.BOOTSTRAP_SEED

    def kw(self) -> dict:
        """The settings as keyword arguments (confidence, resamples, seed)."""
        return {"confidence": self.confidence, "resamples": self.resamples, "seed": self.seed}


@dataclass
class Column:
    key: str
    title: str
    direction: int = NONE
    fmt: str = ".4g"
    stats: bool = False  # carries <key>_std, _ci_low, _ci_high, _mark


@dataclass
class Table:
    name: str
    title: str
    labels: list[tuple[str, str]]  # (key, title) of the text columns
    columns: list[Column]  # numeric columns
    rows: list[dict] = field(default_factory=list)  # label values, numbers (None = missing), statistics, "_not_run": set of keys
    notes: list[str] = field(default_factory=list)
    rule_by: str | None = None  # a rule between rows where this label changes (.tex)
    csv_only: tuple[str, ...] = ()  # label keys shown only in the CSV
    note_column: str | None = None  # a text column shown last
    compared: bool = False  # rows carry first places and Δ rows (the legend explains them)
