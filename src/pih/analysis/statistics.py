"""Intervals and tests over independent runs: Wilson's interval for a success rate, the mean
of per-run rates with it, and the exact two-sided sign test for paired comparisons with their
counts."""

from __future__ import annotations

import math
from typing import Any

import pandas as pd


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


def sign_test_p(better: int, worse: int) -> float:
    """Two-sided exact sign test: the probability of a split of the untied pairs at least this
    uneven if either method were equally likely to do better."""
    untied = better + worse
    tail = sum(math.comb(untied, k) for k in range(min(better, worse) + 1)) / 2**untied
    return min(1.0, 2 * tail)


def pair_counts(difference: pd.Series) -> dict[str, Any]:
    """A paired comparison's columns from the per-pair differences in deployment success: how
    many pairs, better, worse and tied, the mean difference and :func:`sign_test_p`."""
    better, worse = int((difference > 0).sum()), int((difference < 0).sum())
    return {
        "pairs": len(difference),
        "better": better,
        "worse": worse,
        "tied": len(difference) - better - worse,
        "mean_difference": float(difference.mean()),
        "sign_test_p": sign_test_p(better, worse),
    }
