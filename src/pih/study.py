"""The batch study: configuration sections, sweep points, and aggregates over planning runs.

The workflow's config has sections ``scene`` (:class:`pih.scene.SceneConfig`), ``validation``
and ``planner`` (:class:`pih.planner.PlannerConfig`) and a ``sweep`` whose keys are dotted config
paths (``planner.start_x_m``) and whose values are lists of levels. A sweep point overrides those
paths; :func:`resolve` applies it and validates the result strictly.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd

from pih.config import ConfigError, from_mapping
from pih.planner import PlannerConfig
from pih.scene import SceneConfig
from pih.traces import read_metadata, read_provenance

METHOD_KEY = "planner.method"


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


def final_success_fraction(rollouts: pd.DataFrame, last: int = 10) -> float:
    """Fraction of the last ``last`` iterations whose best rollout succeeded: whether a run
    *stays* successful, which a lucky sensed-hole draw in one iteration cannot fake."""
    best = rollouts[rollouts["is_best"]].sort_values("iteration")
    return float(best["success"].tail(last).mean())


_LEVEL_COLUMNS = {
    "method": ("", "planning method"),
    "dimension": ("", "sweep dimension the row is split by ('all': not split)"),
    "level": ("", "level of that dimension"),
}
BEST_COST_COLUMNS: dict[str, tuple[str, str]] = {
    "iteration": ("1", "iteration"),
    "cost": ("1", "best inner cost J_inn of the iteration (eq. 11)"),
    "method": ("", "planning method"),
    "run": ("", "run directory (sweep point)"),
}
BAND_COLUMNS: dict[str, tuple[str, str]] = {
    **_LEVEL_COLUMNS,
    "iteration": ("1", "iteration"),
    "mean": ("1", "mean over runs of the best J_inn"),
    "std": ("1", "standard deviation over runs"),
    "var": ("1", "variance over runs"),
    "count": ("1", "runs"),
    "median": ("1", "median over runs"),
}
SUCCESS_COLUMNS: dict[str, tuple[str, str]] = {
    **_LEVEL_COLUMNS,
    "runs": ("1", "planning runs"),
    "successes": ("1", "runs whose best rollout succeeded in some iteration"),
    "success_rate": ("1", "successes / runs"),
    "ci95_low": ("1", "Wilson 95 % interval, low"),
    "ci95_high": ("1", "Wilson 95 % interval, high"),
    "median_iterations_to_success": ("1", "median first successful iteration"),
    "mean_final_success_fraction": ("1", "mean fraction of the last 10 iterations that succeeded"),
    "diverged_rollout_fraction": ("1", "mean fraction of diverged rollouts"),
    "median_run_seconds": ("s", "median wall time per run"),
}


def run_tables(
    rollout_files: Iterable[str | Path], sweep_keys: list[str], default_method: str
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """From planning-run records: the best cost per iteration of every run (long table) and one
    summary row per run, each tagged with the run's method and sweep levels."""
    bests, summaries = [], []
    for path in map(Path, rollout_files):
        point = read_provenance(path)["sweep_point"]
        run = read_metadata(path, "run")
        rollouts = pd.read_parquet(path)
        tags = {"method": point.get(METHOD_KEY, default_method), "run": path.parent.name}
        tags.update({key: str(point[key]) for key in sweep_keys if key != METHOD_KEY})
        best = rollouts[rollouts["is_best"]][["iteration", "cost"]]
        bests.append(best.assign(**tags))
        summaries.append(
            {
                **tags,
                "succeeded": run["success_iteration"] is not None,
                "success_iteration": run["success_iteration"],
                "final_success_fraction": final_success_fraction(rollouts),
                "diverged_fraction": float((rollouts["status"] != "ok").mean()),
                "seconds": run["seconds"],
            }
        )
    return pd.concat(bests, ignore_index=True), pd.DataFrame(summaries)


def level_columns(sweep_keys: list[str]) -> dict[str, tuple[str, str]]:
    """Unit specs of the per-run sweep-level columns of :func:`run_tables`' outputs."""
    return {key: ("", f"sweep level of {key}") for key in sweep_keys if key != METHOD_KEY}


def _by_dimension(frame: pd.DataFrame, sweep_keys: list[str], table) -> pd.DataFrame:
    """``table(part)`` per method overall and per method × level of every other dimension."""
    parts = [table(frame).assign(dimension="all", level="all")]
    for key in sweep_keys:
        if key != METHOD_KEY:
            parts += [
                table(part).assign(dimension=key, level=level) for level, part in frame.groupby(key)
            ]
    return pd.concat(parts, ignore_index=True)


def cost_bands(runs: pd.DataFrame, sweep_keys: list[str]) -> pd.DataFrame:
    """Mean, standard deviation, variance and median of the best cost per iteration, per method,
    overall and per level of every other sweep dimension (the paper's Fig. 9 bands)."""

    def bands(part: pd.DataFrame) -> pd.DataFrame:
        stats = part.groupby(["method", "iteration"])["cost"].agg(
            ["mean", "std", "var", "count", "median"]
        )
        return stats.reset_index()

    return _by_dimension(runs, sweep_keys, bands)


def success_table(summaries: pd.DataFrame, sweep_keys: list[str]) -> pd.DataFrame:
    """Per method, overall and per level of every other dimension: success rate (first success
    within the budget) with a Wilson 95 % interval, median iterations to success, mean
    final-success fraction, diverged-rollout fraction and median seconds per run."""

    def table(part: pd.DataFrame) -> pd.DataFrame:
        rows = []
        for method, runs in part.groupby("method"):
            successes = int(runs["succeeded"].sum())
            low, high = wilson_interval(successes, len(runs))
            iterations = runs.loc[runs["succeeded"], "success_iteration"]
            rows.append(
                {
                    "method": method,
                    "runs": len(runs),
                    "successes": successes,
                    "success_rate": successes / len(runs),
                    "ci95_low": low,
                    "ci95_high": high,
                    "median_iterations_to_success": float(iterations.median())
                    if len(iterations)
                    else math.nan,
                    "mean_final_success_fraction": float(runs["final_success_fraction"].mean()),
                    "diverged_rollout_fraction": float(runs["diverged_fraction"].mean()),
                    "median_run_seconds": float(runs["seconds"].median()),
                }
            )
        return pd.DataFrame(rows)

    return _by_dimension(summaries, sweep_keys, table)


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
