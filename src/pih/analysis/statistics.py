"""Intervals and tests over independent runs: Wilson's interval for a success rate, the mean
of per-run rates with it, and for paired comparisons their counts, the exact two-sided sign test,
an interval on the mean difference and the smallest difference the pairs could detect
(docs/planner.md, "Intervals and tests")."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
import pandas as pd
from scipy import stats

SPREAD_FLOOR = 0.1
"""The least standard deviation of the paired differences the interval and the detectable
difference assume: one trial in ten (pairs all tied show no spread, yet a rerun would)."""
CEILING = 1.0
"""A run's success fraction when every deployment trial inserted."""
ALPHA = 0.05
"""The level of the paired tests and intervals (95 %)."""
POWER = 0.8
"""The power at which :func:`detectable_difference` is detected."""


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


TIE_COLUMNS: dict[str, tuple[str, str]] = {
    "tied_at_ceiling": ("1", "tied pairs where both inserted in every trial: no difference shows"),
    "tied_at_floor": ("1", "tied pairs where neither inserted in any trial"),
}
"""Units and descriptions of :func:`pair_counts`' ties at either end."""
TEST_COLUMNS: dict[str, tuple[str, str]] = {
    "difference_ci_low": (
        "1",
        (
            f"95 % paired t-interval on mean_difference over the pairs, their spread at least "
            f"{SPREAD_FLOOR} (docs/planner.md, Intervals and tests), low"
        ),
    ),
    "difference_ci_high": ("1", "95 % paired t-interval on mean_difference, high"),
    "sign_test_p": ("1", "two-sided exact sign test over the untied pairs (scipy binomtest)"),
    "least_possible_p": (
        "1",
        "the smallest sign_test_p the untied pairs allow (all one way): 2^(1 - untied)",
    ),
    "detectable_difference": (
        "1",
        (
            f"the smallest mean difference a paired t-test at {ALPHA} detects with "
            f"{100 * POWER:.0f} % power over these pairs (their spread at least {SPREAD_FLOOR}); "
            "NaN where the pairs are too few for the sign test to reach 0.05, or nothing in "
            "[-1, 1] is detectable"
        ),
    ),
}
"""Units and descriptions of :func:`pair_counts`' interval and tests on the mean difference."""


def sign_test_p(better: int, worse: int) -> float:
    """Two-sided exact sign test: the probability of a split of the untied pairs at least this
    uneven if either method were equally likely to do better (1 without untied pairs)."""
    untied = better + worse
    return float(stats.binomtest(better, untied, 0.5).pvalue) if untied else 1.0


def least_sign_test_p(untied: int) -> float:
    """The smallest p :func:`sign_test_p` can give over ``untied`` pairs, all split one way:
    2^(1 − k). Below 0.05 only from 6 untied pairs on."""
    return min(1.0, 2.0 ** (1 - untied))


def _floored_spread(difference: np.ndarray) -> float:
    """The pairs' standard deviation, at least :data:`SPREAD_FLOOR`."""
    return max(float(np.std(difference, ddof=1)), SPREAD_FLOOR)


def paired_difference_interval(
    method: pd.Series | np.ndarray, versus: pd.Series | np.ndarray
) -> tuple[float, float]:
    """95 % interval on the mean over pairs of ``method − versus`` (aligned, one pair a sweep
    point): the paired t-interval, mean ± t_{0.975, n−1} · s / √n, with s at least
    :data:`SPREAD_FLOOR` and the ends clipped to [−1, 1]. Not a bootstrap: over 8–11 pairs a
    bootstrap interval cannot reach past the differences observed (pairs all tied give a point),
    and its BCa version excluded 0 where the t-test's p was 0.10 (docs/planner.md). NaN below
    two pairs."""
    difference = np.asarray(method, dtype=float) - np.asarray(versus, dtype=float)
    n = len(difference)
    if n < 2:
        return (math.nan, math.nan)
    mean = float(difference.mean())
    half = stats.t.ppf(1 - ALPHA / 2, n - 1) * _floored_spread(difference) / math.sqrt(n)
    return (max(-1.0, mean - half), min(1.0, mean + half))


def detectable_difference(difference: pd.Series | np.ndarray) -> float:
    """The smallest mean difference the pairs could detect: a two-sided paired t-test at
    :data:`ALPHA` rejects it with probability :data:`POWER`, (t_{1−α/2} + t_{power}) · s / √n
    over n − 1 degrees of freedom, s the pairs' standard deviation but at least
    :data:`SPREAD_FLOOR`. NaN where the headline's sign test could reach no p below α over
    these pairs (fewer than 6) or where no difference within [−1, 1] is detectable."""
    values = np.asarray(difference, dtype=float)
    n = len(values)
    if n < 2 or least_sign_test_p(n) > ALPHA:
        return math.nan
    quantiles = stats.t.ppf(1 - ALPHA / 2, n - 1) + stats.t.ppf(POWER, n - 1)
    detectable = float(quantiles * _floored_spread(values) / math.sqrt(n))
    return detectable if detectable <= 1 else math.nan


def pair_counts(method: pd.Series, versus: pd.Series) -> dict[str, Any]:
    """A paired comparison's columns from two methods' deployment success at the same points
    (aligned; a point either lacks is no pair): how many pairs, better, worse and tied, how many
    tied at the ceiling (both at 1) and at the floor (both at 0), the mean difference with its
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
        "tied_at_floor": int(((both["a"] == 0) & (both["b"] == 0)).sum()),
        "mean_difference": float(difference.mean()) if len(difference) else math.nan,
        "difference_ci_low": low,
        "difference_ci_high": high,
        "sign_test_p": sign_test_p(better, worse),
        "least_possible_p": least_sign_test_p(better + worse),
        "detectable_difference": detectable_difference(difference),
    }
