"""The statistics of the paper's tables (:mod:`inpaint360gs.report.stats`): the percentile bootstrap
against closed forms, pairing by (scene, seed), the seed spread against hand computation, and the
first-place rule (best only with an interval that excludes zero, else tied)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.stats import binom

from scipy.stats import norm, t

from inpaint360gs.report.stats import HIGHER, LOWER, NONE, Interval, bootstrap_mean, expanded_level, first_place, paired_difference, seed_spread


@pytest.mark.parametrize("seed", [0, 1, 7])
def test_percentile_interval_of_a_two_valued_sample_is_the_binomial_quantiles(seed):
    """A sample of 6 ones and 14 zeros: a resample's mean is Binomial(20, 0.3) / 20, so the percentile
    interval is its 2.5 % and 97.5 % quantiles (both far from a step of the CDF: no resampling luck)."""
    x = [1.0] * 6 + [0.0] * 14
    lo, hi = bootstrap_mean(x, seed=seed, expand=False)
    assert (lo, hi) == (binom.ppf(0.025, 20, 0.3) / 20, binom.ppf(0.975, 20, 0.3) / 20) == (0.1, 0.5)
    lo90, hi90 = bootstrap_mean(x, confidence=0.9, seed=seed, expand=False)
    assert (lo90, hi90) == (binom.ppf(0.05, 20, 0.3) / 20, binom.ppf(0.95, 20, 0.3) / 20) == (0.15, 0.45)
    # expanded (the default): the same quantiles at the wider level; 6 of 12 at 97.85 %: [2/12, 10/12]
    y = [1.0] * 6 + [0.0] * 6
    a = (1 - expanded_level(0.95, 12)) / 2
    assert bootstrap_mean(y, seed=seed) == (binom.ppf(a, 12, 0.5) / 12, binom.ppf(1 - a, 12, 0.5) / 12) == (2 / 12, 10 / 12)


def test_expanded_level_gives_normal_data_the_t_intervals_width():
    """z of the expanded level = sqrt(n / (n - 1)) t_{n-1}: the percentile interval of n normal draws,
    whose half-width is z s_n / sqrt(n) (s_n with ddof 0), is then t_{n-1} s / sqrt(n) (ddof 1)."""
    for n in (3, 6, 27):
        z = norm.isf((1 - expanded_level(0.95, n)) / 2)
        assert z * math.sqrt((n - 1) / n) == pytest.approx(t.ppf(0.975, n - 1))
    assert expanded_level(0.95, 27) == pytest.approx(0.9638, abs=1e-4) and expanded_level(0.95, 10_000) == pytest.approx(0.95, abs=1e-4)
    x = np.random.default_rng(5).normal(2.0, 3.0, 400)
    lo, hi = bootstrap_mean(x)
    half = t.ppf(0.975, 399) * x.std(ddof=1) / math.sqrt(400)
    assert lo == pytest.approx(x.mean() - half, abs=0.05 * half) and hi == pytest.approx(x.mean() + half, abs=0.05 * half)


def test_degenerate_samples():
    assert bootstrap_mean([0.25, 0.25, 0.25]) == (0.25, 0.25)
    assert bootstrap_mean([1.0, 2.0]) == (None, None)  # two values: resamples only span them, no interval
    assert bootstrap_mean([1.0]) == (None, None) and bootstrap_mean([]) == (None, None)


def test_differences_are_paired_by_scene_and_seed_whatever_the_order():
    """a = b + 0.5 on every run while b varies by 20 between scenes: paired, the interval is [0.5, 0.5];
    runs that only one side has do not count; the dicts' order changes nothing."""
    rng = np.random.default_rng(0)
    runs = [(f"s{i}", str(k)) for i in range(5) for k in range(3)]
    b = {r: float(rng.uniform(0, 20)) for r in runs}
    a = {r: b[r] + 0.5 for r in reversed(runs)}
    a[("extra", "0")] = 100.0
    b[("other", "0")] = -100.0
    iv = paired_difference(a, b)
    assert iv == Interval(pytest.approx(0.5), pytest.approx(0.5), pytest.approx(0.5), 15)
    assert iv.excludes_zero() and iv.verdict(HIGHER) == "better" and iv.verdict(LOWER) == "worse"


def test_paired_interval_is_the_bootstrap_of_the_differences_and_deterministic():
    runs = [(f"s{i}", str(k)) for i in range(4) for k in range(3)]
    rng = np.random.default_rng(3)
    a = {r: float(rng.normal()) for r in runs}
    b = {r: float(rng.normal()) for r in runs}
    iv = paired_difference(a, b)
    d = [a[r] - b[r] for r in sorted(runs)]
    assert iv.mean == pytest.approx(np.mean(d)) and (iv.low, iv.high) == bootstrap_mean(d) and iv.n == 12
    assert paired_difference(dict(reversed(list(a.items()))), b) == iv
    assert paired_difference(a, b, seed=1) != iv  # the generator's seed is what makes it repeat
    assert not iv.excludes_zero() and iv.verdict(HIGHER) == "tied"
    assert paired_difference(a, {("x", "0"): 1.0}) is None
    one = paired_difference({("s", "0"): 2.0}, {("s", "0"): 1.0})
    assert one == Interval(1.0, None, None, 1) and one.verdict(HIGHER) == "tied"
    assert paired_difference(a, {**b, runs[0]: None}).n == 11  # a null value leaves its run out


def test_seed_spread_is_the_std_over_seeds_of_the_scene_average():
    vals = {("a", "0"): 10.0, ("b", "0"): 20.0, ("a", "1"): 11.0, ("b", "1"): 23.0, ("a", "2"): 9.0, ("b", "2"): 22.0}
    means = [15.0, 17.0, 15.5]
    assert seed_spread(vals) == pytest.approx(np.std(means, ddof=1))
    assert seed_spread({("a", "0"): 1.0, ("b", "0"): 2.0}) is None  # one seed
    assert seed_spread({**vals, ("a", "0"): None}) is None
    with pytest.raises(ValueError, match="same scenes"):
        seed_spread({("a", "0"): 1.0, ("b", "1"): 2.0})


def test_first_place_needs_an_interval_that_excludes_zero():
    runs = [(f"s{i}", str(k)) for i in range(3) for k in range(3)]
    rng = np.random.default_rng(1)
    base = {r: float(rng.uniform(20, 30)) for r in runs}
    clear = {r: v + 1.0 + 0.1 * rng.normal() for r, v in base.items()}
    noisy = {r: v + 0.05 + rng.normal() for r, v in base.items()}  # the best mean by a hair, within its own noise
    assert first_place({"base": base, "clear": clear}, HIGHER).best == "clear"
    assert first_place({"base": base, "clear": clear}, LOWER).best == "base"
    place = first_place({"base": base, "noisy": noisy}, HIGHER)
    assert place.best is None and set(place.tied) == {"base", "noisy"}
    place = first_place({"base": base, "clear": clear, "noisy": noisy, "low": {r: v - 5 for r, v in base.items()}}, HIGHER)
    assert place.best == "clear"
    # tied: the top mean and the rows its interval cannot separate from it, not the clearly worse one
    place = first_place({"a": clear, "b": {r: v + rng.normal() for r, v in clear.items()}, "low": base}, HIGHER)
    assert place.best is None and place.tied[0] in ("a", "b") and set(place.tied) == {"a", "b"}
    assert first_place({"a": base, "b": clear}, NONE) is None and first_place({"a": base}, HIGHER) is None
