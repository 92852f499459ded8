"""Intervals and tests over independent runs: Wilson's interval for a success rate, the mean
of per-run rates with it, and for paired comparisons their counts, the exact two-sided sign test,
a paired bootstrap interval on the mean difference and the smallest difference the pairs could
detect (docs/planner.md, "Intervals and tests")."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pandas as pd
from scipy import stats

BOOTSTRAP_RESAMPLES = 9999
"""Resamples of the paired bootstrap (:func:`paired_difference_interval`)."""
BOOTSTRAP_SEED = 0
"""Seed of the paired bootstrap's resampling: the same pairs give the same interval anywhere."""
SPREAD_FLOOR = 0.1
"""The least standard deviation of the paired differences :func:`detectable_difference` assumes:
one trial in ten (pairs all tied show no spread, yet a rerun would)."""
CEILING = 1.0
"""A run's success fraction when every deployment trial inserted."""


def wilson_interval(successes: float, trials: int, z: float = 1.96) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion (95 % for z = 1.96). Over runs, with each
    run's success fraction as one observation, it is conservative: the variance p(1 − p) it
    assumes bounds the true between-run variance of fractions with mean p."""
    if trials == 0:
        return (math.nan, math.nan)
    p = successes / trials
    centre = (p + z * z / (2 * trials)) / (1 + z * z / trials)
    half = (
        z * math.sqrt(p * (1 - p) / trials + z * z / (4 * trials * trials)) / (1 + z * z / trials)
    )
    # Clamped so that rounding never puts p outside its interval (at p = 0 or 1 it is exact).
    return (min(p, max(0.0, centre - half)), max(p, min(1.0, centre + half)))


def rate_over_runs(rates: pd.Series) -> tuple[float, float, float]:
    """Mean of the runs' success fractions and its 95 % Wilson interval, each run one observation;
    a run without that deployment (NaN) is no observation."""
    observed = rates.dropna()
    if observed.empty:
        return (math.nan, math.nan, math.nan)
    rate = float(observed.mean())
    return (rate, *wilson_interval(rate * len(observed), len(observed)))


PAIR_STATISTICS_COLUMNS: dict[str, tuple[str, str]] = {
    "tied_at_ceiling": ("1", "tied pairs where both inserted in every trial: no difference shows"),
    "difference_ci_low": (
        "1",
        (
            f"95 % paired bootstrap interval on mean_difference over the pairs (BCa, "
            f"{BOOTSTRAP_RESAMPLES} resamples, seed {BOOTSTRAP_SEED}), low"
        ),
    ),
    "difference_ci_high": ("1", "95 % paired bootstrap interval on mean_difference, high"),
    "sign_test_p": ("1", "two-sided exact sign test over the untied pairs (scipy binomtest)"),
    "least_possible_p": (
        "1",
        "the smallest sign_test_p the untied pairs allow (all one way): 2^(1 - untied)",
    ),
    "detectable_difference": (
        "1",
        (
            f"the smallest mean difference a paired t-test at 0.05 detects with 80 % power over "
            f"these pairs (their spread, at least {SPREAD_FLOOR})"
        ),
    ),
}
"""Units and descriptions of :func:`pair_counts`' columns beyond the counts and the mean."""


def sign_test_p(better: int, worse: int) -> float:
    """Two-sided exact sign test: the probability of a split of the untied pairs at least this
    uneven if either method were equally likely to do better (1 without untied pairs)."""
    untied = better + worse
    return float(stats.binomtest(better, untied, 0.5).pvalue) if untied else 1.0


def least_sign_test_p(untied: int) -> float:
    """The smallest p :func:`sign_test_p` can give over ``untied`` pairs, all split one way:
    2^(1 − k). Below 0.05 only from 6 untied pairs on."""
    return min(1.0, 2.0 ** (1 - untied))


def paired_difference_interval(
    method: pd.Series | np.ndarray, versus: pd.Series | np.ndarray, confidence: float = 0.95
) -> tuple[float, float]:
    """Interval on the mean over pairs of ``method − versus`` (aligned, one pair a sweep point):
    scipy's paired BCa bootstrap, :data:`BOOTSTRAP_RESAMPLES` resamples of the pairs drawn from
    :data:`BOOTSTRAP_SEED`. Pairs that all differ alike have no spread to resample: the interval
    is that difference."""
    a, b = np.asarray(method, dtype=float), np.asarray(versus, dtype=float)
    difference = a - b
    if len(difference) == 0:
        return (math.nan, math.nan)
    if np.ptp(difference) == 0:
        return (float(difference[0]), float(difference[0]))
    result = stats.bootstrap(
        (a, b),
        lambda x, y, axis=-1: np.mean(x - y, axis=axis),
        paired=True,
        vectorized=True,
        n_resamples=BOOTSTRAP_RESAMPLES,
        confidence_level=confidence,
        method="BCa",
        rng=np.random.default_rng(BOOTSTRAP_SEED),
    )
    low, high = result.confidence_interval
    return (float(low), float(high))


def detectable_difference(
    difference: pd.Series | np.ndarray, alpha: float = 0.05, power: float = 0.8
) -> float:
    """The smallest mean difference the pairs could detect: a two-sided paired t-test at
    ``alpha`` rejects it with probability ``power``, (t_{1−α/2} + t_{power}) · s / √n over n − 1
    degrees of freedom, s the pairs' standard deviation but at least :data:`SPREAD_FLOOR`. NaN
    below two pairs."""
    values = np.asarray(difference, dtype=float)
    n = len(values)
    if n < 2:
        return math.nan
    spread = max(float(np.std(values, ddof=1)), SPREAD_FLOOR)
    quantiles = stats.t.ppf(1 - alpha / 2, n - 1) + stats.t.ppf(power, n - 1)
    return float(quantiles * spread / math.sqrt(n))


def pair_counts(method: pd.Series, versus: pd.Series) -> dict[str, Any]:
    """A paired comparison's columns from two methods' deployment success at the same points
    (aligned; a point either lacks is no pair): how many pairs, better, worse and tied, how many
    tied at the ceiling (both at 1), the mean difference with its
    :func:`paired_difference_interval`, :func:`sign_test_p`, the :func:`least_sign_test_p` its
    untied pairs allow and the :func:`detectable_difference`."""
    both = pd.DataFrame({"a": method, "b": versus}).dropna()
    difference = both["a"] - both["b"]
    better, worse = int((difference > 0).sum()), int((difference < 0).sum())
    low, high = paired_difference_interval(both["a"], both["b"])
    return {
        "pairs": len(difference),
        "better": better,
        "worse": worse,
        "tied": len(difference) - better - worse,
        "tied_at_ceiling": int(((both["a"] == CEILING) & (both["b"] == CEILING)).sum()),
        "mean_difference": float(difference.mean()) if len(difference) else math.nan,
        "difference_ci_low": low,
        "difference_ci_high": high,
        "sign_test_p": sign_test_p(better, worse),
        "least_possible_p": least_sign_test_p(better + worse),
        "detectable_difference": detectable_difference(difference),
    }
