"""Seed spread, scene-level (cluster) bootstrap intervals and first places for the paper's tables
(docs/guide.md, "Tables of the paper").

A *run* is one (scene, seed) of a method. The seeds of one scene share its 3DGS model (trained once
per scene) and its layout, so they move together: a scene's runs are not independent samples, the
scenes are. Two rows of a table are compared on the runs both have:

- the mean difference over those runs and its *cluster* bootstrap interval: the difference is
  formed per run, and the resampling unit is the scene — scenes are drawn with replacement, each
  with all its runs, and a resample's statistic is the mean over the runs it holds
  (``scipy.stats.bootstrap``, percentile method, :data:`RESAMPLES` resamples from a generator
  seeded with :data:`BOOTSTRAP_SEED`: the same records always give the same tables). With the same
  number of runs per scene this is the ordinary bootstrap of the scene means, so its effective
  sample size is the number of scenes G. A plain percentile interval of a mean is too narrow for
  small G (about 0.7 of Student's t interval at 6), so the percentiles are taken at the *expanded*
  level of Hesterberg (2015, "What teachers should know about the bootstrap") for G: the level whose
  normal quantile is sqrt(G / (G - 1)) times Student's t quantile with G - 1 degrees of freedom,
  which gives normal scene means the t interval's width (a 95 % interval is taken at 98.6 % with
  9 scenes, at 99.8 % with 5: there it spans nearly the scene means' range);
- a *verdict* (better / worse / tied) needs at least :data:`MIN_SCENES` scenes. With fewer, the
  interval resamples the runs instead (at least :data:`MIN_PAIRS` of them) and says how far the
  difference stands out of the seeds' noise on those scenes only: its verdict is
  :data:`SEED_NOISE`, never better or worse, and no row is first from it;
- the *seed spread* of a row: the standard deviation (ddof 1) over seeds of the row's average over
  scenes, i.e. how much the table's number moves when only the seeds change; undefined with one seed;
- the *first place* of a column: the row with the best mean is first only when its scene-level
  interval against every other row excludes zero on its side; otherwise every row whose interval
  against it includes zero is tied with it. Below :data:`MIN_SCENES` scenes no row is first or tied.
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
MIN_PAIRS = 3  # resampling units below which there is no interval: resamples of two values only span them
MIN_SCENES = 3  # scenes a verdict needs (module docstring)
SEED_NOISE = "seed noise only"  # the verdict of a difference over fewer than MIN_SCENES scenes

Run = tuple[str, str]  # (scene, seed); seed "" for a record without a seed label


@dataclass(frozen=True)
class Interval:
    """Mean of ``a - b`` over ``n`` paired runs of ``scenes`` scenes and its bootstrap interval: over
    scenes (cluster bootstrap) from :data:`MIN_SCENES` scenes on, else over runs (seed noise only);
    None below :data:`MIN_PAIRS` resampling units."""

    mean: float
    low: float | None
    high: float | None
    n: int
    scenes: int

    @property
    def scene_level(self) -> bool:
        """Whether the interval resamples scenes (enough of them for a verdict)."""
        return self.scenes >= MIN_SCENES

    def excludes_zero(self) -> bool:
        """Whether both bounds exist and lie on the same side of zero."""
        return self.low is not None and self.high is not None and (self.low > 0 or self.high < 0)

    def verdict(self, direction: int) -> str:
        """``better`` / ``worse`` for the first row of the difference when the scene-level interval
        excludes zero (with the metric's ``direction``), :data:`SEED_NOISE` over fewer than
        :data:`MIN_SCENES` scenes, else ``tied``."""
        if direction == NONE:
            return "tied"
        if not self.scene_level:
            return SEED_NOISE
        if not self.excludes_zero():
            return "tied"
        return "better" if (self.low > 0) == (direction == HIGHER) else "worse"


def _rng_keyword() -> str:
    """scipy >= 1.15 calls the generator argument ``rng``, older versions ``random_state``."""
    return "rng" if "rng" in inspect.signature(scipy.stats.bootstrap).parameters else "random_state"


def expanded_level(confidence: float, n: int) -> float:
    """The level at which the expanded percentile interval of ``n`` resampling units takes its
    percentiles (module docstring)."""
    z = math.sqrt(n / (n - 1)) * scipy.stats.t.ppf(0.5 + confidence / 2, n - 1)
    return float(1.0 - 2.0 * scipy.stats.norm.sf(z))


def _ratio_of_sums(sums, counts, axis=-1):
    """Mean over the runs of a resample of clusters: their summed values over their summed run counts."""
    return np.sum(sums, axis=axis) / np.sum(counts, axis=axis)


def bootstrap_mean(values: Sequence[float], *, clusters: Sequence | None = None, confidence: float = CONFIDENCE,
                   resamples: int = RESAMPLES, seed: int = BOOTSTRAP_SEED, expand: bool = True) -> tuple[float | None, float | None]:
    """Percentile bootstrap interval of the mean of ``values`` at ``confidence`` (``expand``: at
    :func:`expanded_level` for the number of resampling units).

    ``clusters``: one key per value (a run's scene); values with the same key are resampled
    together, and a resample's statistic is the mean over the values it holds. None: every value is
    its own unit. (None, None) for fewer than :data:`MIN_PAIRS` units."""
    x = np.asarray(values, dtype=np.float64)
    keys = list(range(x.size)) if clusters is None else list(clusters)
    if len(keys) != x.size:
        raise ValueError(f"{len(keys)} cluster keys for {x.size} values")
    order = sorted(set(keys), key=lambda k: (str(type(k)), k))  # fixed order: the resamples do not depend on the input order
    where = {k: i for i, k in enumerate(order)}
    idx = np.array([where[k] for k in keys], dtype=np.int64)
    sums = np.bincount(idx, weights=x, minlength=len(order))
    counts = np.bincount(idx, minlength=len(order)).astype(np.float64)
    if len(order) < MIN_PAIRS:
        return None, None
    if np.all(x == x[0]):  # every resample has this mean
        return float(x[0]), float(x[0])
    level = expanded_level(confidence, len(order)) if expand else confidence
    kw = dict(n_resamples=resamples, confidence_level=level, method="percentile", vectorized=True,
              **{_rng_keyword(): np.random.default_rng(seed)})
    if np.all(counts == counts[0]):  # balanced: the bootstrap of the cluster means
        res = scipy.stats.bootstrap((sums / counts,), np.mean, **kw)
    else:
        res = scipy.stats.bootstrap((sums, counts), _ratio_of_sums, paired=True, **kw)
    ci = res.confidence_interval
    return float(ci.low), float(ci.high)


def paired_difference(a: Mapping[Run, float | None], b: Mapping[Run, float | None], **kw) -> Interval | None:
    """``a - b`` over the runs where both have a value, formed per run; the interval resamples the
    scenes with all their runs (from :data:`MIN_SCENES` scenes on), else the runs (seed noise only).
    None when they share no run. ``kw``: :func:`bootstrap_mean`'s options."""
    runs = sorted(r for r in set(a) & set(b) if a[r] is not None and b[r] is not None)
    if not runs:
        return None
    d = np.array([a[r] - b[r] for r in runs], dtype=np.float64)
    scenes = len({r[0] for r in runs})
    low, high = bootstrap_mean(d, clusters=[r[0] for r in runs] if scenes >= MIN_SCENES else None, **kw)
    return Interval(float(d.mean()), low, high, len(runs), scenes)


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
    rows with values, fewer than :data:`MIN_SCENES` scenes). The row with the best mean is ``best`` when its paired interval against every
    other row excludes zero on its side; else the rows whose interval against it includes zero are
    ``tied`` with it."""
    means = {k: float(np.mean(list(v.values()))) for k, v in rows.items() if v and all(x is not None for x in v.values())}
    if direction == NONE or len(means) < 2:
        return None
    if min(len({r[0] for r in rows[k]}) for k in means) < MIN_SCENES:  # seed noise only: no row is first
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
