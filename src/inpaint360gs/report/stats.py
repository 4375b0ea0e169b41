"""Seed spread, paired bootstrap intervals and first places for the paper's tables (docs/guide.md, "Tables
of the paper").

A *run* is one (scene, seed) of a method. Two rows of a table are compared on the runs both have:

- the mean difference over those runs and its paired bootstrap interval: the (scene, seed) pairs are
  resampled with replacement (``scipy.stats.bootstrap`` on the per-pair differences, percentile
  method, :data:`RESAMPLES` resamples from a generator seeded with :data:`BOOTSTRAP_SEED`: the same
  records always give the same tables). A plain percentile interval of a mean is too narrow for few
  pairs (about 0.7 of Student's t interval at 6 pairs), so the percentiles are taken at the
  *expanded* level of Hesterberg (2015, "What teachers should know about the bootstrap"): the level
  whose normal quantile is sqrt(n / (n - 1)) times Student's t quantile with n - 1 degrees of
  freedom, which gives normal data the t interval's width (at 27 pairs a 95 % interval is taken at
  96.4 %). Below :data:`MIN_PAIRS` pairs there is no interval: resamples of two values only span them;
- the *seed spread* of a row: the standard deviation (ddof 1) over seeds of the row's average over
  scenes, i.e. how much the table's number moves when only the seeds change; undefined with one seed;
- the *first place* of a column: the row with the best mean is first only when its interval against
  every other row excludes zero on its side; otherwise every row whose interval against it includes
  zero is tied with it.
"""

from __future__ import annotations

import inspect
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass

import numpy as np
import scipy.stats

HIGHER, LOWER, NONE = 1, -1, 0  # a metric's direction (higher is better / lower is better / neither)
CONFIDENCE = 0.95
RESAMPLES = 10_000
BOOTSTRAP_SEED = 0
MIN_PAIRS = 3

Run = tuple[str, str]  # (scene, seed); seed "" for a record without a seed label


@dataclass(frozen=True)
class Interval:
    """Mean of ``a - b`` over ``n`` paired runs and its bootstrap interval (None below :data:`MIN_PAIRS`)."""

    mean: float
    low: float | None
    high: float | None
    n: int

    def excludes_zero(self) -> bool:
        """Whether both bounds exist and lie on the same side of zero."""
        return self.low is not None and self.high is not None and (self.low > 0 or self.high < 0)

    def verdict(self, direction: int) -> str:
        """``better`` / ``worse`` for the first row of the difference when the interval excludes
        zero (with the metric's ``direction``), else ``tied``."""
        if direction == NONE or not self.excludes_zero():
            return "tied"
        return "better" if (self.low > 0) == (direction == HIGHER) else "worse"


def _rng_keyword() -> str:
    """scipy >= 1.15 calls the generator argument ``rng``, older versions ``random_state``."""
    return "rng" if "rng" in inspect.signature(scipy.stats.bootstrap).parameters else "random_state"


def expanded_level(confidence: float, n: int) -> float:
    """The level at which the expanded percentile interval takes its percentiles (module docstring)."""
    z = math.sqrt(n / (n - 1)) * scipy.stats.t.ppf(0.5 + confidence / 2, n - 1)
    return float(1.0 - 2.0 * scipy.stats.norm.sf(z))


def bootstrap_mean(values: Sequence[float], *, confidence: float = CONFIDENCE, resamples: int = RESAMPLES,
                   seed: int = BOOTSTRAP_SEED, expand: bool = True) -> tuple[float | None, float | None]:
    """Percentile bootstrap interval of the mean of ``values`` at ``confidence`` (``expand``: at
    :func:`expanded_level`); (None, None) for fewer than :data:`MIN_PAIRS` values."""
    x = np.asarray(values, dtype=np.float64)
    if x.size < MIN_PAIRS:
        return None, None
    if np.all(x == x[0]):  # every resample has this mean
        return float(x[0]), float(x[0])
    level = expanded_level(confidence, x.size) if expand else confidence
    res = scipy.stats.bootstrap((x,), np.mean, n_resamples=resamples, confidence_level=level, method="percentile",
                                vectorized=True, **{_rng_keyword(): np.random.default_rng(seed)})
    ci = res.confidence_interval
    return float(ci.low), float(ci.high)


def paired_difference(a: Mapping[Run, float | None], b: Mapping[Run, float | None], **kw) -> Interval | None:
    """``a - b`` over the runs where both have a value, in sorted run order (the input order never
    changes the resamples); None when they share no run. ``kw``: :func:`bootstrap_mean`'s options."""
    runs = sorted(r for r in set(a) & set(b) if a[r] is not None and b[r] is not None)
    if not runs:
        return None
    d = np.array([a[r] - b[r] for r in runs], dtype=np.float64)
    low, high = bootstrap_mean(d, **kw)
    return Interval(float(d.mean()), low, high, len(runs))


def seed_spread(values: Mapping[Run, float | None]) -> float | None:
    """Standard deviation (ddof 1) over seeds of the mean over scenes; None with fewer than two seeds
    or a null value. Every seed must hold the same scenes (the tables compare common runs only)."""
    if any(v is None for v in values.values()):
        return None
    by_seed: dict[str, dict[str, float]] = {}
    for (scene, seed), v in values.items():
        by_seed.setdefault(seed, {})[scene] = v
    if len(by_seed) < 2:
        return None
    scenes = {frozenset(s) for s in by_seed.values()}
    if len(scenes) != 1:
        raise ValueError("seed spread needs the same scenes at every seed")
    means = [float(np.mean(list(s.values()))) for s in by_seed.values()]
    return float(np.std(means, ddof=1))


@dataclass(frozen=True)
class Place:
    """A column's first place: ``best`` (a row better than every other one, or None) and ``tied``
    (the rows tied for first when there is no such row, best mean first)."""

    best: str | None
    tied: tuple[str, ...]


def first_place(rows: Mapping[str, Mapping[Run, float | None]], direction: int, **kw) -> Place | None:
    """The first place among ``rows`` (name -> values per run, compared on their common runs) for a
    metric of ``direction``; None when the column is not compared (no direction, fewer than two
    rows with values). The row with the best mean is ``best`` when its paired interval against every
    other row excludes zero on its side; else the rows whose interval against it includes zero are
    ``tied`` with it."""
    means = {k: float(np.mean(list(v.values()))) for k, v in rows.items() if v and all(x is not None for x in v.values())}
    if direction == NONE or len(means) < 2:
        return None
    top = max(means, key=lambda k: direction * means[k])  # the first of equal means, in row order
    tied = [top]
    for k in means:
        if k == top:
            continue
        iv = paired_difference(rows[top], rows[k], **kw)
        if iv is None or iv.verdict(direction) != "better":
            tied.append(k)
    return Place(top, ()) if len(tied) == 1 else Place(None, tuple(tied))
