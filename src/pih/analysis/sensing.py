"""What the first sensing predicts (docs/sim_to_real.md): planned in a simulator whose hole is
where the run first sensed it, a fixed goal inserts on the real hole only when that sensing
landed close to it. The runs' outcomes say how close is close enough; the sensing model says how
often a first sensing lands that close, and so what success to expect at the sensing's own rate
rather than at the sample's."""

from __future__ import annotations

import math

import pandas as pd
from scipy import stats

SENSING_RATE_COLUMNS: dict[str, tuple[str, str]] = {
    "method": ("", "the planning method"),
    "runs": ("1", "runs planned on the sensed hole"),
    "close_runs": ("1", "runs whose policy inserted in at least half its trials"),
    "farthest_close_m": ("m", "the largest |x error| of a first sensing among the close runs"),
    "nearest_far_m": ("m", "the smallest |x error| of a first sensing among the other runs"),
    "close_probability_low": (
        "1",
        "probability that a first sensing lands within farthest_close_m of the hole",
    ),
    "close_probability_high": ("1", "the same within nearest_far_m"),
    "expected_low": (
        "1",
        "success expected at the sensing's own rate, with the threshold at farthest_close_m",
    ),
    "expected_high": ("1", "the same with the threshold at nearest_far_m"),
    "measured": ("1", "mean success of the runs, as sampled"),
}


def close_probability(radius_m: float, bias_m: float, std_m: float) -> float:
    """Probability that a sensing of the hole's x, N(hole + bias, std²), lands within
    ``radius_m`` of it (the sensing noise of eq. 16)."""
    if std_m == 0:
        return float(abs(bias_m) <= radius_m)
    upper, lower = (radius_m - bias_m) / std_m, (-radius_m - bias_m) / std_m
    return float(stats.norm.cdf(upper) - stats.norm.cdf(lower))


def expected_at_sensing_rate(
    per_run: pd.DataFrame, bias_m: float, std_m: float, success: str = "offset_deploy_success_rate"
) -> pd.DataFrame:
    """Per method, its sensed-hole runs (``per_run.md``'s rows: ``first_sensing_dx_m`` and
    ``success``) split at one distance in x, the only one the sensing model draws: those that
    inserted in at least half their trials all sensed nearer than those that did not. Between the farthest close and the nearest far run
    lies the threshold; at either end, the expected success is P(close) · (the close runs' mean)
    + (1 − P(close)) · (the far runs' mean), P(close) from :func:`close_probability`. A method
    whose runs do not split so, or that has runs on one side only, gets NaN."""
    rows = []
    per_run = per_run.assign(sensed_off_m=per_run["first_sensing_dx_m"].abs())
    for method, runs in per_run.groupby("method", sort=True):
        close = runs[runs[success] >= 0.5]
        far = runs[runs[success] < 0.5]
        farthest = float(close["sensed_off_m"].max()) if len(close) else math.nan
        nearest = float(far["sensed_off_m"].min()) if len(far) else math.nan
        split = len(close) and len(far) and farthest < nearest
        probability = {
            end: close_probability(radius, bias_m, std_m) if split else math.nan
            for end, radius in (("low", farthest), ("high", nearest))
        }
        expected = {
            end: p * close[success].mean() + (1 - p) * far[success].mean()
            for end, p in probability.items()
        }
        rows.append(
            {
                "method": method,
                "runs": len(runs),
                "close_runs": len(close),
                "farthest_close_m": farthest,
                "nearest_far_m": nearest,
                "close_probability_low": probability["low"],
                "close_probability_high": probability["high"],
                "expected_low": expected["low"],
                "expected_high": expected["high"],
                "measured": float(runs[success].mean()),
            }
        )
    return pd.DataFrame(rows, columns=list(SENSING_RATE_COLUMNS))
