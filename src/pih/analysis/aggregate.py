"""Aggregates over planning runs (their per-run rows from :mod:`pih.analysis.run_summary`): the
cost bands (Fig. 9), deployment success with intervals over independent runs, paired
comparisons, and the Markdown tables. docs/planner.md explains the statistics.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
import pandas as pd

from pih.analysis.ladder import ALL_RUNGS, ladder_pairs, ladder_table
from pih.analysis.run_summary import (
    FIRST_SENSING_COLUMNS,
    NO_MODEL_ERROR,
    REPLICATE_KEYS,
    compared_keys,
    level_columns,
    split_keys,
)
from pih.analysis.statistics import TEST_COLUMNS, TIE_COLUMNS, pair_counts, rate_over_runs
from pih.analysis.training_model import simulator_keys, training_model_table
from pih.study.points import VARIANT_KEY


def ablation_table(success: pd.DataFrame) -> pd.DataFrame:
    """The rows of :func:`success_table` split by the compared dimensions (e.g. ``variant``) and
    the overall rows; the replicate dimensions (start, seed) are pooled."""
    return success[~success["dimension"].isin(REPLICATE_KEYS)]


def compared_rows(table: pd.DataFrame) -> pd.DataFrame:
    """The rows of a per-dimension table (:func:`success_table`, :func:`cost_bands`) split by a
    compared dimension (an ablation's variants: different designs that do not pool); empty when
    the study compares none."""
    rows = ablation_table(table)
    return rows[rows["dimension"] != "all"]


def figure_bands(bands: pd.DataFrame) -> pd.DataFrame:
    """The rows of :func:`cost_bands` that Fig. 9 draws: per method over all runs, or, where the
    study compares another dimension (an ablation's variants, whose costs differ in scale and
    design), per method and level of it, the method labelled ``<method>, <dimension> <level>``."""
    compared = compared_rows(bands)
    if compared.empty:
        return bands[bands["dimension"] == "all"]
    name = compared["dimension"].str.rsplit(".", n=1).str[-1]
    return compared.assign(method=compared["method"] + ", " + name + " " + compared["level"])


_LEVEL_COLUMNS = {
    "method": ("", "planning method: one_level, one_level/<stable goal> or bilevel/<outer rule>"),
    "dimension": ("", "sweep dimension the row is split by ('all': not split)"),
    "level": ("", "level of that dimension"),
}
ALL_RUNS = "all"
"""The ``pooled`` of a row that pools every run of its level (:func:`balanced_cells`)."""
POOLED_COLUMN: dict[str, tuple[str, str]] = {
    "pooled": (
        "",
        (
            "which runs of its level the row pools: all, or only the cells of the other compared "
            "dimensions that every level of its dimension ran (docs/planner.md, Pooling studies)"
        ),
    ),
}
BAND_COLUMNS: dict[str, tuple[str, str]] = {
    **_LEVEL_COLUMNS,
    **POOLED_COLUMN,
    "iteration": ("1", "iteration"),
    "mean": ("1", "mean over runs of the best J_inn"),
    "std": ("1", "standard deviation over runs"),
    "var": ("1", "variance over runs"),
    "count": ("1", "runs with a finite best J_inn"),
    "median": ("1", "median over runs"),
}
SUCCESS_COLUMNS: dict[str, tuple[str, str]] = {
    **_LEVEL_COLUMNS,
    **POOLED_COLUMN,
    "runs": ("1", "independent planning runs"),
    "deploy_success_rate": (
        "1",
        "mean over runs of the fraction of deployment trials that inserted (the headline)",
    ),
    "deploy_ci_low": ("1", "95 % Wilson interval over runs (each run one observation), low"),
    "deploy_ci_high": ("1", "95 % Wilson interval over runs, high"),
    "final_mean_deploy_success_rate": (
        "1",
        "the same for the final mean weights, deployed on the same sensed holes (NaN: not run)",
    ),
    "final_mean_deploy_ci_low": ("1", "95 % Wilson interval over runs, low"),
    "final_mean_deploy_ci_high": ("1", "95 % Wilson interval over runs, high"),
    "final_iteration_success_rate": ("1", "runs whose last iteration's best rollout succeeded"),
    "mean_last10_success_fraction": (
        "1",
        "mean fraction of the last 10 iterations whose best rollout succeeded",
    ),
    "mean_policy_last10_success_fraction": (
        "1",
        "mean fraction of the last 10 iterations whose mean weights inserted (NaN: not evaluated)",
    ),
    "first_success_rate": ("1", "runs whose best rollout succeeded in some iteration"),
    "median_first_success_iteration": ("1", "median first iteration with a successful best"),
    "median_goal_iteration": (
        "1",
        "median first iteration whose goal was within tolerance of the true hole (never: NaN)",
    ),
    "diverged_rollout_fraction": ("1", "mean fraction of diverged training rollouts"),
    "retried_rollout_fraction": (
        "1",
        "mean fraction of training rollouts with an interval rerun at solver.retry_time_step_s",
    ),
    "deploy_diverged_fraction": (
        "1",
        "mean fraction of deployment trials that ended in a simulation failure (not successes)",
    ),
    "runs_repeating_training": (
        "1",
        "runs whose every deployment trial only repeated a training rollout (cannot fail)",
    ),
}


ROBUSTNESS_COLUMNS: dict[str, tuple[str, str]] = {
    "method": ("", "planning method: one_level, one_level/<stable goal> or bilevel/<outer rule>"),
    "start_std_m": ("m", "std of the deployment trials' start offset in x and y"),
    "model_error": (
        "",
        "the real scene's difference from training's (robustness.model_error), or none",
    ),
    "runs": ("1", "independent planning runs"),
    "deploy_success_rate": ("1", "mean over runs of the fraction of trials that inserted"),
    "deploy_ci_low": ("1", "95 % Wilson interval over runs (each run one observation), low"),
    "deploy_ci_high": ("1", "95 % Wilson interval over runs, high"),
    "runs_all_inserted": ("1", "runs whose every trial inserted"),
}


def robustness_columns(sweep_keys: list[str]) -> dict[str, tuple[str, str]]:
    """Unit specs of :func:`robustness_table`'s columns for a sweep."""
    method, *rest = ROBUSTNESS_COLUMNS.items()
    return dict([method, *level_columns(compared_keys(sweep_keys)).items(), *rest])


def robustness_table(deployments: pd.DataFrame, sweep_keys: list[str]) -> pd.DataFrame:
    """Deployment success per method, level of every compared dimension, start std and model
    error, over the runs' own deployments (at their ``deploy_start_std_m``) and their
    redeployments (:func:`redeployment_summaries`); a run redeployed at its own std counts
    once."""
    compared = compared_keys(sweep_keys)
    conditions = ["start_std_m", "model_error"]
    unique = _with_model_error(deployments).drop_duplicates(["run", *conditions])
    rows = []
    for (method, *levels, std, error), runs in unique.groupby(["method", *compared, *conditions]):
        rate, low, high = rate_over_runs(runs["deploy_success_rate"])
        rows.append(
            {
                "method": method,
                **dict(zip(compared, levels, strict=True)),
                "start_std_m": std,
                "model_error": error,
                "runs": len(runs),
                "deploy_success_rate": rate,
                "deploy_ci_low": low,
                "deploy_ci_high": high,
                "runs_all_inserted": int((runs["deploy_success_rate"] == 1).sum()),
            }
        )
    table = pd.DataFrame(rows, columns=list(robustness_columns(sweep_keys)))
    # The scene the policy was trained on first, then each model error.
    order = (table["model_error"] != NO_MODEL_ERROR).astype(int)
    return table.iloc[order.argsort(kind="stable")].reset_index(drop=True)


def headline_std(robustness: pd.DataFrame) -> float | None:
    """The start std of the headline: the smallest σ > 0 the study redeployed at."""
    stds = sorted(s for s in robustness["start_std_m"].unique() if s > 0)
    return float(stds[0]) if stds else None


PER_RUN_COLUMNS: dict[str, tuple[str, str]] = {
    "method": ("", "planning method: one_level, one_level/<stable goal> or bilevel/<outer rule>"),
    "run": ("", "run directory (sweep point)"),
    **FIRST_SENSING_COLUMNS,
    "goal_iteration": (
        "1",
        "first iteration whose goal was within tolerance of the true hole (empty: never)",
    ),
    "deploy_success_rate": ("1", "fraction of the trials from the training start that inserted"),
    "offset_start_std_m": ("m", "std of the offset starts below (the headline's; NaN: none)"),
    "offset_deploy_success_rate": (
        "1",
        "fraction of the trials from starts offset by that std that inserted, on the training scene",
    ),
}


def per_run_columns(sweep_keys: list[str]) -> dict[str, tuple[str, str]]:
    """Unit specs of :func:`per_run_table`'s columns for a sweep."""
    method, *rest = PER_RUN_COLUMNS.items()
    return dict([method, *level_columns(sweep_keys).items(), *rest])


def per_run_table(
    summaries: pd.DataFrame, deployments: pd.DataFrame, sweep_keys: list[str]
) -> pd.DataFrame:
    """One row per planning run: where its first sensing landed relative to the real hole,
    beside its deployment success from the training start and from starts offset by the
    headline std (the smallest σ > 0 redeployed at, on the training scene); by compared level,
    method and sensing error."""
    trained = _with_model_error(deployments)
    trained = trained[trained["model_error"] == NO_MODEL_ERROR]
    std = headline_std(trained)
    offset = trained[trained["start_std_m"] == std].drop_duplicates("run")
    table = summaries.assign(
        offset_start_std_m=math.nan if std is None else std,
        offset_deploy_success_rate=summaries["run"].map(
            offset.set_index("run")["deploy_success_rate"]
        ),
    )
    order = [*compared_keys(sweep_keys), "method", "first_sensing_error_m", "run"]
    table = table.sort_values(order, kind="stable").reset_index(drop=True)
    return table[list(per_run_columns(sweep_keys))]


def on_training_scene(robustness: pd.DataFrame) -> pd.DataFrame:
    """The deployments on the scene the policies were trained on (no model error)."""
    if "model_error" not in robustness:
        return robustness
    return robustness[robustness["model_error"] == NO_MODEL_ERROR]


def offset_level(level: object, start_std_m: float) -> str:
    """The ``level`` of a paired row over the deployments from starts offset by ``start_std_m``
    at one level of a compared dimension (e.g. ``sensed_per_run, starts 0.001 m off``)."""
    return f"{level}, starts {start_std_m:g} m off"


def robustness_pairs(deployments: pd.DataFrame, sweep_keys: list[str]) -> pd.DataFrame:
    """:func:`paired_table` per start std (dimension ``start_std_m``) on the training scene,
    from offset starts per level of every compared dimension too (level :func:`offset_level`:
    the modes of a sim-to-real study do not pool), and per model error (dimension
    ``model_error``)."""
    frame = _with_model_error(deployments)
    exact = frame[frame["model_error"] == NO_MODEL_ERROR].drop_duplicates(["run", "start_std_m"])
    paired = paired_table(
        exact.assign(start_std_m=exact["start_std_m"].map(str)), [*sweep_keys, "start_std_m"]
    )
    parts = [paired[paired["dimension"] == "start_std_m"]]
    compared = compared_keys(sweep_keys)
    for std, part in exact[exact["start_std_m"] > 0].groupby("start_std_m"):
        per_level = paired_table(part, sweep_keys)
        per_level = per_level[per_level["dimension"].isin(compared)]
        if len(per_level):
            levels = [offset_level(v, std) for v in per_level["level"]]
            parts.append(per_level.assign(level=levels))
    errors = frame[frame["model_error"] != NO_MODEL_ERROR].drop_duplicates(["run", "model_error"])
    for error, part in errors.groupby("model_error"):
        groups = [((), part), *(part.groupby(compared) if compared else [])]
        for levels, group in groups:
            paired = paired_table(group, sweep_keys)
            level = model_error_level(error, level_label(compared[: len(levels)], levels))
            parts.append(
                paired[paired["dimension"] == "all"].assign(dimension="model_error", level=level)
            )
    return pd.concat(parts, ignore_index=True)


def level_label(keys: list[str], levels: tuple) -> str:
    """One joint level of compared dimensions, named by their last path components
    (``friction = 0.3, goal_tilt = sensed``); empty for none."""
    return ", ".join(
        f"{key.rsplit('.', 1)[-1]} = {level}" for key, level in zip(keys, levels, strict=True)
    )


def model_error_level(error: str, label: str) -> str:
    """The ``level`` of the paired rows under a model error (dimension ``model_error``): the
    error, pooled over the compared dimensions, or at one joint level of them
    (:func:`level_label`: the levels do not pool)."""
    return f"{error}, {label}" if label else error


def _with_model_error(deployments: pd.DataFrame) -> pd.DataFrame:
    """Deployments with a ``model_error`` column (records that predate it: none)."""
    if "model_error" not in deployments:
        return deployments.assign(model_error=NO_MODEL_ERROR)
    return deployments.assign(model_error=deployments["model_error"].fillna(NO_MODEL_ERROR))


def _by_dimension(frame: pd.DataFrame, sweep_keys: list[str], table) -> pd.DataFrame:
    """``table(part)`` per method overall and per method × level of every other dimension that
    has more than one level (a single level's rows would repeat the overall ones), a method's
    runs at each level kept to the cells every level ran (:func:`balanced_cells`; column
    ``pooled`` says which)."""
    parts = [table(frame).assign(dimension="all", level="all", pooled=ALL_RUNS)]
    for key in split_keys(sweep_keys):
        if frame[key].nunique() < 2:
            continue
        kept = {m: balanced_cells(runs, key, sweep_keys) for m, runs in frame.groupby("method")}
        pooled = {method: label for method, (_, label) in kept.items()}
        for level, part in pd.concat([runs for runs, _ in kept.values()]).groupby(key):
            rows = table(part)
            parts.append(rows.assign(dimension=key, level=level, pooled=rows["method"].map(pooled)))
    return pd.concat(parts, ignore_index=True)


def crossed_keys(runs: pd.DataFrame, key: str, sweep_keys: list[str]) -> list[str]:
    """The compared dimensions (not start, not seed) that cross ``key`` in ``runs``: neither
    nested in it (each of their levels under one level of ``key``, as the point stiffness under
    ``contact_model``) nor it in them (each level of ``key`` under one of theirs)."""
    return [
        other
        for other in compared_keys(sweep_keys)
        if other != key
        and runs.groupby(other)[key].nunique().max() > 1
        and runs.groupby(key)[other].nunique().max() > 1
    ]


def balanced_cells(runs: pd.DataFrame, key: str, sweep_keys: list[str]) -> tuple[pd.DataFrame, str]:
    """One method's ``runs`` kept to the cells (joint levels of the :func:`crossed_keys`) that
    every level of ``key`` ran, so that its levels' rows differ in ``key`` alone, and what they
    keep in words: :data:`ALL_RUNS` when every level ran the same cells, or when no cell is
    common to all (then says so: the rows mix designs)."""
    crossed = crossed_keys(runs, key, sweep_keys)
    if not crossed:
        return runs, ALL_RUNS
    cells = pd.MultiIndex.from_frame(runs[crossed].astype(str))
    per_level = [set(cells[(runs[key] == level).to_numpy()]) for level in runs[key].unique()]
    common = set.intersection(*per_level)
    if all(level == common for level in per_level):
        return runs, ALL_RUNS
    if not common:
        return runs, f"{ALL_RUNS}: no cell of {', '.join(crossed)} ran at every level"
    return runs[cells.isin(list(common))], f"only {_cells_label(runs, crossed, common)}"


def _cells_label(runs: pd.DataFrame, keys: list[str], cells: set[tuple]) -> str:
    """``cells`` of ``keys`` in words: the levels kept of each key that lost some, or, when the
    cells are not all combinations of those, each cell."""
    kept = {key: sorted({cell[i] for cell in cells}) for i, key in enumerate(keys)}
    if len(cells) < math.prod(len(levels) for levels in kept.values()):
        return " or ".join(
            "(" + ", ".join(f"{k} = {v}" for k, v in zip(keys, cell, strict=True)) + ")"
            for cell in sorted(cells)
        )
    lost = [key for key in keys if len(kept[key]) < runs[key].nunique()]
    return ", ".join(f"{key} = {' or '.join(kept[key])}" for key in lost)


def cost_bands(runs: pd.DataFrame, sweep_keys: list[str]) -> pd.DataFrame:
    """Mean, standard deviation, variance and median of the best cost per iteration, per method,
    overall and per level of every other sweep dimension (the paper's Fig. 9 bands)."""

    def bands(part: pd.DataFrame) -> pd.DataFrame:
        stats = part.groupby(["method", "iteration"])["cost"].agg(
            ["mean", "std", "var", "count", "median"]
        )
        return stats.reset_index()

    return _by_dimension(runs, sweep_keys, bands)


def _median_or_never(values: pd.Series, runs: int) -> float:
    """Median over runs where a missing value means "never" (sorted after every number)."""
    reached = np.sort(values.dropna().to_numpy(dtype=float))
    if runs == 0 or len(reached) <= (runs - 1) // 2:
        return math.nan
    ordered = np.concatenate([reached, np.full(runs - len(reached), np.inf)])
    median = float(np.median(ordered))
    return median if math.isfinite(median) else math.nan


PAIRED_COLUMNS: dict[str, tuple[str, str]] = {
    **_LEVEL_COLUMNS,
    **POOLED_COLUMN,
    "versus": ("", "the method compared against, at the same sweep points"),
    "pairs": (
        "1",
        "sweep points both methods ran: the same levels but the method's, so the same draws",
    ),
    "better": ("1", "pairs where `method` deployed more often than `versus`"),
    "worse": ("1", "pairs where `method` deployed less often"),
    "tied": ("1", "pairs with equal deployment success"),
    **TIE_COLUMNS,
    "mean_difference": (
        "1",
        "mean over pairs of the deployment success of `method` minus that of `versus`",
    ),
    **TEST_COLUMNS,
}


def paired_table(summaries: pd.DataFrame, sweep_keys: list[str]) -> pd.DataFrame:
    """Every two methods compared at the sweep points both ran (common random numbers make each
    point a pair), overall and per level of every compared dimension (not start or seed, where
    a level holds one pair): which deployed more often, the mean difference, a sign test."""
    points = split_keys(sweep_keys)

    def table(part: pd.DataFrame) -> pd.DataFrame:
        success = part.assign(point=0).set_index(["point", *points, "method"])
        wide = success["deploy_success_rate"].unstack("method")  # duplicate runs: an error
        rows = []
        for a, b in itertools.combinations(sorted(wide.columns), 2):
            counts = pair_counts(wide[a], wide[b])
            if counts["pairs"]:
                rows.append({"method": a, "versus": b, **counts})
        return pd.DataFrame(
            rows, columns=[c for c in PAIRED_COLUMNS if c not in ("dimension", "level", "pooled")]
        )

    paired = _by_dimension(summaries, sweep_keys, table)
    return paired[~paired["dimension"].isin(REPLICATE_KEYS)][list(PAIRED_COLUMNS)].reset_index(
        drop=True
    )


def success_table(summaries: pd.DataFrame, sweep_keys: list[str]) -> pd.DataFrame:
    """Per method, overall and per level of every other dimension: deployment success with a
    95 % interval over independent runs, and the training-time success measures."""

    def table(part: pd.DataFrame) -> pd.DataFrame:
        rows = []
        for method, runs in part.groupby("method"):
            n = len(runs)
            rates = {}
            for prefix in ("", "final_mean_"):
                rate, low, high = rate_over_runs(runs[f"{prefix}deploy_success_rate"])
                rates |= {
                    f"{prefix}deploy_success_rate": rate,
                    f"{prefix}deploy_ci_low": low,
                    f"{prefix}deploy_ci_high": high,
                }
            rows.append(
                {
                    "method": method,
                    "runs": n,
                    **rates,
                    "final_iteration_success_rate": float(runs["final_iteration_success"].mean()),
                    "mean_last10_success_fraction": float(runs["final_success_fraction"].mean()),
                    "mean_policy_last10_success_fraction": float(
                        runs["mean_policy_last10_success"].mean()
                    ),
                    "first_success_rate": float(runs["first_success_iteration"].notna().mean()),
                    "median_first_success_iteration": _median_or_never(
                        runs["first_success_iteration"], n
                    ),
                    "median_goal_iteration": _median_or_never(runs["goal_iteration"], n),
                    "diverged_rollout_fraction": float(runs["diverged_fraction"].mean()),
                    "retried_rollout_fraction": float(runs["retried_fraction"].mean()),
                    "deploy_diverged_fraction": float(runs["deploy_diverged_fraction"].mean()),
                    "runs_repeating_training": int(runs["deploy_repeats_training"].sum()),
                }
            )
        return pd.DataFrame(rows)

    return _by_dimension(summaries, sweep_keys, table)[list(SUCCESS_COLUMNS)]


@dataclass
class PlanningTables:
    """The tables over a study's planning runs (docs/planner.md)."""

    bands: pd.DataFrame
    success: pd.DataFrame
    ablation: pd.DataFrame
    variant_pairs: pd.DataFrame
    paired: pd.DataFrame
    robustness: pd.DataFrame
    robustness_pairs: pd.DataFrame
    per_run: pd.DataFrame
    time_step: pd.DataFrame | None = None
    """success at the runs' own step and at a replay's (:mod:`pih.analysis.time_step`)"""
    time_step_pairs: pd.DataFrame | None = None
    training_model: pd.DataFrame | None = None
    """the planner's simulator against reality (:mod:`pih.analysis.training_model`); None when
    the study sweeps no simulator"""
    ladder: pd.DataFrame | None = None
    """success per rung of the deployment ladder (:mod:`pih.analysis.ladder`); None with fewer
    than two rungs"""
    ladder_pairs: pd.DataFrame | None = None


def variant_pairs(summaries: pd.DataFrame, sweep_keys: list[str], reference: str) -> pd.DataFrame:
    """Each variant of an ablation against the reference variant (the sweep's first, e.g. the
    paper-literal one), method by method, at the points both ran: the
    same levels but the variant's, so the same draws. Rows as :func:`paired_table`'s, with
    dimension ``variant``, the variant as level and ``versus`` naming the reference."""
    columns = list(PAIRED_COLUMNS)
    if VARIANT_KEY not in sweep_keys:
        return pd.DataFrame(columns=columns)
    others = [k for k in split_keys(sweep_keys) if k != VARIANT_KEY]
    reference_runs = summaries[summaries[VARIANT_KEY] == reference].set_index(["method", *others])
    rows = []
    variants = summaries[summaries[VARIANT_KEY] != reference]
    for (level, method), runs in variants.groupby([VARIANT_KEY, "method"], sort=True):
        joined = runs.set_index(["method", *others]).join(
            reference_runs[["deploy_success_rate"]].add_suffix("_reference"), how="inner"
        )
        if joined.empty:
            continue
        rows.append(
            {
                "method": method,
                "dimension": VARIANT_KEY,
                "level": level,
                "versus": f"{method} at {VARIANT_KEY} {reference}",
                "pooled": ALL_RUNS,
                **pair_counts(
                    joined["deploy_success_rate"], joined["deploy_success_rate_reference"]
                ),
            }
        )
    return pd.DataFrame(rows, columns=columns)


def planning_tables(
    runs: pd.DataFrame,
    summaries: pd.DataFrame,
    deployments: pd.DataFrame,
    sweep_keys: list[str],
    reference_variant: str | None = None,
) -> PlanningTables:
    """Cost bands, success, ablation, paired (per start std, and each variant against
    ``reference_variant``, too) and robustness tables from :func:`run_tables`' outputs and
    every deployment at every start std (the runs' own and :func:`redeployment_summaries`')."""
    success = success_table(summaries, sweep_keys)
    against_reference = (
        variant_pairs(summaries, sweep_keys, reference_variant)
        if reference_variant is not None
        else pd.DataFrame(columns=list(PAIRED_COLUMNS))
    )
    redeployed = robustness_pairs(deployments, sweep_keys)
    paired = [paired_table(summaries, sweep_keys), against_reference, redeployed]
    ladder = ladder_table(deployments, sweep_keys)
    climbed = ladder.loc[ladder["rung"] != ALL_RUNGS, "rung"].nunique() >= 2
    return PlanningTables(
        bands=cost_bands(runs, sweep_keys),
        success=success,
        ablation=ablation_table(success),
        variant_pairs=against_reference,
        paired=pd.concat([p for p in paired if not p.empty] or paired[:1], ignore_index=True),
        robustness=robustness_table(deployments, sweep_keys),
        robustness_pairs=redeployed,
        per_run=per_run_table(summaries, deployments, sweep_keys),
        training_model=(
            training_model_table(deployments, sweep_keys, headline_std(deployments) or 0.0)
            if simulator_keys(sweep_keys)
            else None
        ),
        ladder=ladder if climbed else None,
        ladder_pairs=ladder_pairs(deployments, sweep_keys) if climbed else None,
    )
