"""The batch study: configuration sections, sweep points, and aggregates over planning runs.

The workflow's config has sections ``scene`` (:class:`pih.scene.SceneConfig`), ``validation``
and ``planner`` (:class:`pih.planner.PlannerConfig`) and a ``sweep`` whose keys are dotted config
paths (``planner.start_x_m``) and whose values are lists of levels. A sweep point overrides those
paths; :func:`resolve` applies it and validates the result strictly.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Mapping
from typing import Any

import numpy as np
import pandas as pd

from pih.config import ConfigError, from_mapping
from pih.planner import PlannerConfig
from pih.scene import SceneConfig


def override(config: Mapping[str, Any], point: Mapping[str, Any]) -> dict[str, Any]:
    """Deep copy of ``config`` with each dotted path of ``point`` set to its value."""
    out = copy.deepcopy(dict(config))
    for path, value in point.items():
        node = out
        *parents, leaf = path.split(".")
        for key in parents:
            if not isinstance(node.get(key), dict):
                raise ConfigError(f"sweep key {path!r}: {key!r} is not a config section")
            node = node[key]
        if leaf not in node:
            raise ConfigError(
                f"sweep key {path!r}: no such config key {leaf!r}; allowed: {sorted(node)}"
            )
        node[leaf] = (
            value.item() if isinstance(value, np.generic) else value
        )  # Paramspace gives numpy scalars
    return out


def resolve(
    config: Mapping[str, Any], point: Mapping[str, Any] | None = None
) -> tuple[SceneConfig, PlannerConfig]:
    """Validated scene and planner configs of one sweep point."""
    data = override(config, point or {})
    return from_mapping(SceneConfig, data["scene"], "scene"), from_mapping(
        PlannerConfig, data["planner"], "planner"
    )


def wilson_interval(successes: int, trials: int, z: float = 1.96) -> tuple[float, float]:
    """Wilson score interval of a binomial proportion (95 % for z = 1.96)."""
    if trials == 0:
        return (math.nan, math.nan)
    p = successes / trials
    centre = (p + z * z / (2 * trials)) / (1 + z * z / trials)
    half = (
        z * math.sqrt(p * (1 - p) / trials + z * z / (4 * trials * trials)) / (1 + z * z / trials)
    )
    return (max(0.0, centre - half), min(1.0, centre + half))


def cost_bands(runs: pd.DataFrame, group: str = "method") -> pd.DataFrame:
    """Mean, standard deviation and variance of the best cost per iteration across runs, per
    ``group`` level (the paper's Fig. 9 bands). ``runs`` has columns group, run_id, iteration, cost."""
    stats = runs.groupby([group, "iteration"])["cost"].agg(
        ["mean", "std", "var", "count", "median"]
    )
    return stats.reset_index()


def final_success_fraction(rollouts: pd.DataFrame, last: int = 10) -> float:
    """Fraction of the last ``last`` iterations whose best rollout succeeded: whether a run
    *stays* successful, which a lucky sensed-hole draw in one iteration cannot fake."""
    best = rollouts[rollouts["is_best"]].sort_values("iteration")
    return float(best["success"].tail(last).mean())


def success_table(summaries: pd.DataFrame, group: str = "method") -> pd.DataFrame:
    """Success rate with Wilson 95 % interval, median iterations to success and the mean
    final-success fraction, per group."""
    rows = []
    for level, part in summaries.groupby(group):
        successes = int(part["succeeded"].sum())
        low, high = wilson_interval(successes, len(part))
        iterations = part.loc[part["succeeded"], "success_iteration"]
        rows.append(
            {
                group: level,
                "runs": len(part),
                "successes": successes,
                "success_rate": successes / len(part),
                "ci95_low": low,
                "ci95_high": high,
                "median_iterations_to_success": float(iterations.median())
                if len(iterations)
                else math.nan,
                "mean_final_success_fraction": float(part["final_success_fraction"].mean()),
                "diverged_rollout_fraction": float(part["diverged_fraction"].mean()),
                "median_run_seconds": float(part["seconds"].median()),
            }
        )
    return pd.DataFrame(rows)


def markdown_table(frame: pd.DataFrame, float_format: str = "{:.4g}") -> str:
    """A pipe table (no extra dependency)."""

    def cell(value: Any) -> str:
        if isinstance(value, (float, np.floating)):
            return "" if math.isnan(value) else float_format.format(value)
        return str(value)

    header = "| " + " | ".join(map(str, frame.columns)) + " |"
    rule = "|" + "|".join("---" for _ in frame.columns) + "|"
    body = ["| " + " | ".join(cell(v) for v in row) + " |" for row in frame.itertuples(index=False)]
    return "\n".join([header, rule, *body]) + "\n"
