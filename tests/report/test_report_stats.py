"""The statistics of the paper's tables (:mod:`inpaint360gs.report.stats`): the percentile bootstrap
against closed forms, the cluster bootstrap that resamples scenes with all their seeds (its width is
the scenes', not the runs'), pairing by (scene, seed), the seed spread against hand computation,
"seed noise only" below three scenes, and the first-place rule (best only with a scene-level
interval that excludes zero, else tied)."""

from __future__ import annotations

import itertools

import math

import numpy as np
import pytest
from scipy.stats import binom

from scipy.stats import norm, t

from inpaint360gs.report.stats import (
    HIGHER,
    LOWER,
    NONE,
    SEED_NOISE,
    Interval,
    bootstrap_mean,
    expanded_level,
    first_place,
    paired_difference,
    seed_spread,
)


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
    assert iv == Interval(pytest.approx(0.5), pytest.approx(0.5), pytest.approx(0.5), 15, 5)
    assert iv.excludes_zero() and iv.verdict(HIGHER) == "better" and iv.verdict(LOWER) == "worse"


def test_paired_interval_is_the_bootstrap_of_the_differences_and_deterministic():
    runs = [(f"s{i}", str(k)) for i in range(8) for k in range(3)]
    rng = np.random.default_rng(3)
    a = {r: float(rng.normal()) for r in runs}
    b = {r: float(rng.normal()) for r in runs}
    iv = paired_difference(a, b)
    d = [a[r] - b[r] for r in sorted(runs)]
    assert iv.mean == pytest.approx(np.mean(d)) and (iv.low, iv.high) == bootstrap_mean(d, clusters=[r[0] for r in sorted(runs)])
    assert iv.n == 24 and iv.scenes == 8 and iv.scene_level
    # three seeds per scene: the bootstrap of the eight scene means
    scene_means = [np.mean([a[r] - b[r] for r in sorted(runs) if r[0] == f"s{i}"]) for i in range(8)]
    assert (iv.low, iv.high) == bootstrap_mean(scene_means)
    assert paired_difference(dict(reversed(list(a.items()))), b) == iv
    assert paired_difference(a, b, seed=1) != iv  # the generator's seed is what makes it repeat
    assert not iv.excludes_zero() and iv.verdict(HIGHER) == "tied"
    assert paired_difference(a, {("x", "0"): 1.0}) is None
    one = paired_difference({("s", "0"): 2.0}, {("s", "0"): 1.0})
    assert one == Interval(1.0, None, None, 1, 1) and one.verdict(HIGHER) == SEED_NOISE
    assert paired_difference(a, {**b, runs[0]: None}).n == 23  # a null value leaves its run out


def test_seed_spread_is_the_std_over_seeds_of_the_scene_average():
    vals = {("a", "0"): 10.0, ("b", "0"): 20.0, ("a", "1"): 11.0, ("b", "1"): 23.0, ("a", "2"): 9.0, ("b", "2"): 22.0}
    means = [15.0, 17.0, 15.5]
    assert seed_spread(vals) == pytest.approx(np.std(means, ddof=1))
    assert seed_spread({("a", "0"): 1.0, ("b", "0"): 2.0}) is None  # one seed
    assert seed_spread({**vals, ("a", "0"): None}) is None
    with pytest.raises(ValueError, match="same scenes"):
        seed_spread({("a", "0"): 1.0, ("b", "1"): 2.0})


def test_first_place_needs_an_interval_that_excludes_zero():
    runs = [(f"s{i}", str(k)) for i in range(6) for k in range(3)]
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


@pytest.mark.parametrize("n_scenes", [3, 4, 6])
def test_scenes_with_perfectly_correlated_seeds_have_the_width_of_the_scenes_not_of_the_runs(n_scenes):
    """Every seed of a scene gives the same difference (the seeds move together): the interval is the
    bootstrap of the n scene values (n samples), not of the 3n runs, and is wider than the latter."""
    rng = np.random.default_rng(n_scenes)
    per_scene = rng.normal(1.0, 2.0, n_scenes)
    runs = [(f"s{i}", str(k)) for i in range(n_scenes) for k in range(3)]
    a = {r: float(per_scene[int(r[0][1:])]) for r in runs}
    b = dict.fromkeys(runs, 0.0)
    iv = paired_difference(a, b)
    assert (iv.low, iv.high) == bootstrap_mean(per_scene) and iv.scenes == n_scenes and iv.n == 3 * n_scenes
    runs_only = bootstrap_mean([a[r] for r in sorted(runs)])  # what resampling the runs as if independent gives
    assert iv.high - iv.low > 1.3 * (runs_only[1] - runs_only[0])


def test_two_scenes_give_no_verdict_only_seed_noise():
    """Two scenes x three seeds, one scene +1 and the other +3 at every seed: the six runs look like a
    clear effect, but two scenes are two samples, too few for an interval over scenes. The interval
    then resamples the runs and the verdict is 'seed noise only', never better or worse."""
    runs = [(s, str(k)) for s in ("a", "b") for k in range(3)]
    a = {r: (1.0 if r[0] == "a" else 3.0) + 0.01 * int(r[1]) for r in runs}
    b = dict.fromkeys(runs, 0.0)
    iv = paired_difference(a, b)
    assert iv.scenes == 2 and not iv.scene_level and iv.excludes_zero()
    assert (iv.low, iv.high) == bootstrap_mean([a[r] for r in sorted(runs)])  # the runs' interval
    assert iv.verdict(HIGHER) == SEED_NOISE == iv.verdict(LOWER) and iv.verdict(NONE) == "tied"
    assert bootstrap_mean([a[r] for r in sorted(runs)], clusters=[r[0] for r in sorted(runs)]) == (None, None)  # two samples: none
    assert first_place({"x": a, "y": b}, HIGHER) is None  # no row is first (or tied) from two scenes


def test_unbalanced_clusters_resample_the_mean_over_runs():
    """Scenes with 1, 2 and 3 runs: a resample of three scenes has the mean over the runs it holds; its
    distribution has 27 equally likely draws, whose 5 % and 95 % quantiles the 90 % interval is."""
    groups = [[0.0], [1.0, 3.0], [10.0, 12.0, 14.0]]
    values = [v for g in groups for v in g]
    clusters = [i for i, g in enumerate(groups) for _ in g]
    draws = np.sort([sum(sum(groups[i]) for i in d) / sum(len(groups[i]) for i in d) for d in itertools.product(range(3), repeat=3)])
    cdf = np.arange(1, 28) / 27
    want = (draws[np.searchsorted(cdf, 0.05)], draws[np.searchsorted(cdf, 0.95)])  # both far from a step of the CDF
    for seed in (0, 1, 2):
        assert bootstrap_mean(values, clusters=clusters, expand=False, confidence=0.9, seed=seed) == pytest.approx(want)
    # the same values in another order give the same interval
    order = [5, 0, 3, 1, 4, 2]
    assert bootstrap_mean([values[i] for i in order], clusters=[clusters[i] for i in order]) == bootstrap_mean(values, clusters=clusters)
