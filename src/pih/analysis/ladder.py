"""The deployment ladder (docs/planner.md, "The deployment ladder"): the runs deployed again on
real scenes harder than their training's, from starts further off and with the hole moved, so
that comparisons tied at 10 of 10 can come apart. A rung is one such deployment of every run; a
run's ladder score is its mean success over the rungs every run in the table has, one number a
run (its rungs reuse its own deployment draws, so they are not independent of each other).
Methods are paired at the same sweep point and, when the study sweeps the planner's simulator,
each training model with its twin trained on the real scene's model."""

from __future__ import annotations

import itertools
import math

import pandas as pd

from pih.analysis.run_summary import NO_MODEL_ERROR, compared_keys, split_keys
from pih.analysis.statistics import TEST_COLUMNS, TIE_COLUMNS, pair_counts, rate_over_runs
from pih.analysis.training_model import (
    REAL_SCENE,
    SIMULATED_HOLE_KEY,
    simulator_keys,
    training_model,
)

ALL_RUNGS = "all rungs"
"""The rung of a run's ladder score."""

LADDER_COLUMNS: dict[str, tuple[str, str]] = {
    "method": ("", "planning method: one_level, one_level/<stable goal> or bilevel/<outer rule>"),
    "rung": (
        "",
        (
            "the real scene deployed on: starts σ mm off on the training scene, the hole moved "
            f"by x mm (from starts off by the model errors' σ), or {ALL_RUNGS} (the ladder score)"
        ),
    ),
    "start_std_m": ("m", "std of the trials' start offset in x and y (NaN: all rungs)"),
    "hole_shift_m": ("m", "how far the real hole moved in x after training (NaN: all rungs)"),
    "rungs": ("1", "rungs the row is over: 1, or for the score the rungs every run has"),
    "runs": ("1", "independent planning runs"),
    "deploy_success_rate": ("1", "mean over runs of the fraction of trials that inserted"),
    "deploy_ci_low": ("1", "95 % Wilson interval over runs (each run one observation), low"),
    "deploy_ci_high": ("1", "95 % Wilson interval over runs, high"),
    "runs_all_inserted": ("1", "runs whose every trial inserted"),
    "runs_none_inserted": ("1", "runs none of whose trials inserted"),
}
LADDER_PAIR_COLUMNS: dict[str, tuple[str, str]] = {
    "method": ("", "the method compared"),
    "versus": (
        "",
        "the method it is compared with at the same points, or its twin trained on the real scene",
    ),
    "rung": ("", "the ladder rung (as in the ladder table)"),
    "rungs": ("1", "rungs the row is over (as in the ladder table)"),
    "pairs": ("1", "sweep points (or twins) both ran: the same draws"),
    "better": ("1", "pairs where `method` deployed more often than `versus`"),
    "worse": ("1", "pairs where `method` deployed less often"),
    "tied": ("1", "pairs with equal deployment success"),
    **TIE_COLUMNS,
    "mean_difference": ("1", "mean over pairs of `method`'s success minus `versus`'s"),
    **TEST_COLUMNS,
}


def ladder_columns(
    columns: dict[str, tuple[str, str]], compared: dict[str, tuple[str, str]]
) -> dict[str, tuple[str, str]]:
    """``columns`` (:data:`LADDER_COLUMNS` or :data:`LADDER_PAIR_COLUMNS`) with the compared
    dimensions' level columns where the tables put them."""
    names = list(columns.items())
    at = 1 if "versus" not in columns else 2
    return dict([*names[:at], *compared.items(), *names[at:]])


def rung_label(start_std_m: float, hole_shift_m: float, moved_std_m: float | None = None) -> str:
    """A rung's name: ``starts 1.25 mm off`` on the training scene, ``hole +0.75 mm`` moved (and
    its starts when they are not ``moved_std_m``, the moved holes' usual σ)."""
    if hole_shift_m == 0:
        return f"starts {1e3 * start_std_m:g} mm off"
    starts = "" if start_std_m == moved_std_m else f", starts {1e3 * start_std_m:g} mm off"
    return f"hole {1e3 * hole_shift_m:+g} mm{starts}"


def ladder_runs(deployments: pd.DataFrame, sweep_keys: list[str]) -> pd.DataFrame:
    """One row per run and rung: every deployment from offset starts on the training scene or
    on a scene whose hole alone moved (``hole_shift_m``, :func:`pih.analysis.pooling.pool`; two
    model errors that move it alike are one rung), and per run its :data:`ALL_RUNGS` score over
    the rungs every run here has (``rungs``: how many; 1 on a rung's own rows)."""
    frame = deployments.assign(
        model_error=deployments.get("model_error", NO_MODEL_ERROR),
        hole_shift_m=deployments.get("hole_shift_m", 0.0),
    )
    frame["model_error"] = frame["model_error"].fillna(NO_MODEL_ERROR)
    trained = (frame["model_error"] == NO_MODEL_ERROR) & (frame["start_std_m"] > 0)
    moved = frame["hole_shift_m"].notna() & (frame["hole_shift_m"] != 0)
    frame = frame[trained | moved].drop_duplicates(["run", "start_std_m", "hole_shift_m"])
    levels = split_keys(sweep_keys)
    columns = ["method", "run", *levels, "start_std_m", "hole_shift_m", "deploy_success_rate"]
    stds = frame.loc[frame["hole_shift_m"] != 0, "start_std_m"]
    moved_std = float(stds.mode().iloc[0]) if len(stds) else None
    frame = frame[columns].assign(
        rung=[
            rung_label(s, h, moved_std)
            for s, h in zip(frame["start_std_m"], frame["hole_shift_m"], strict=True)
        ],
        rungs=1,
    )
    if frame.empty:
        return frame
    common = frozenset.intersection(*frame.groupby("run")["rung"].agg(frozenset))
    score = (
        frame[frame["rung"].isin(common)]
        .groupby(["method", "run", *levels], as_index=False)["deploy_success_rate"]
        .mean()
        .assign(rung=ALL_RUNGS, start_std_m=math.nan, hole_shift_m=math.nan, rungs=len(common))
    )
    return pd.concat([frame, score[frame.columns]], ignore_index=True)


def _rung_order(rungs: pd.DataFrame) -> list[str]:
    """Rungs from the training scene's by start std, then the moved hole by its shift, then the
    score."""
    unique = rungs.drop_duplicates("rung")
    shift = unique["hole_shift_m"].fillna(math.inf)
    key = unique.assign(moved=shift != 0, shift=shift, std=unique["start_std_m"].fillna(math.inf))
    return key.sort_values(["moved", "shift", "std"], kind="stable")["rung"].tolist()


def ladder_table(deployments: pd.DataFrame, sweep_keys: list[str]) -> pd.DataFrame:
    """Per method, level of every compared dimension and rung: deployment success with its 95 %
    interval over runs, and the runs that inserted in every trial and in none."""
    compared = compared_keys(sweep_keys)
    runs = ladder_runs(deployments, sweep_keys)
    columns = [*list(LADDER_COLUMNS)[:1], *compared, *list(LADDER_COLUMNS)[1:]]
    if runs.empty:
        return pd.DataFrame(columns=columns)
    order = {rung: i for i, rung in enumerate(_rung_order(runs))}
    rows = []
    for (method, *levels, rung), part in runs.groupby(["method", *compared, "rung"]):
        rate, low, high = rate_over_runs(part["deploy_success_rate"])
        rows.append(
            {
                "method": method,
                **dict(zip(compared, levels, strict=True)),
                "rung": rung,
                "start_std_m": part["start_std_m"].iloc[0],
                "hole_shift_m": part["hole_shift_m"].iloc[0],
                "rungs": int(part["rungs"].iloc[0]),
                "runs": len(part),
                "deploy_success_rate": rate,
                "deploy_ci_low": low,
                "deploy_ci_high": high,
                "runs_all_inserted": int((part["deploy_success_rate"] == 1).sum()),
                "runs_none_inserted": int((part["deploy_success_rate"] == 0).sum()),
            }
        )
    table = pd.DataFrame(rows, columns=columns)
    table = table.assign(order=table["rung"].map(order))
    return table.sort_values([*compared, "order", "method"], kind="stable")[columns].reset_index(
        drop=True
    )


def _pairs(frame: pd.DataFrame, index: list[str], column: str) -> list[dict[str, object]]:
    """Every two values of ``column`` compared at the ``index`` both ran."""
    wide = frame.set_index([*index, column])["deploy_success_rate"].unstack(column)
    rows = []
    for a, b in itertools.combinations(sorted(wide.columns), 2):
        counts = pair_counts(wide[a], wide[b])
        if counts["pairs"]:
            rows.append({"method": a, "versus": b, **counts})
    return rows


def ladder_pairs(deployments: pd.DataFrame, sweep_keys: list[str]) -> pd.DataFrame:
    """Per rung: every two methods at the sweep points both ran, per level of every compared
    dimension (those levels do not pool); with a swept planner's simulator, each training model
    against the twin of the same method trained on the real scene's model."""
    runs = ladder_runs(deployments, sweep_keys)
    levels = split_keys(sweep_keys)
    compared = compared_keys(sweep_keys)
    columns = [*list(LADDER_PAIR_COLUMNS)[:2], *compared, *list(LADDER_PAIR_COLUMNS)[2:]]
    if runs.empty:
        return pd.DataFrame(columns=columns)
    rows = []
    for (rung, *group), part in runs.groupby(["rung", *compared]):
        named = {**dict(zip(compared, group, strict=True)), "rung": rung}
        named["rungs"] = int(part["rungs"].iloc[0])
        rows += [{**r, **named} for r in _pairs(part, levels, "method")]
    keys = simulator_keys(sweep_keys)
    if keys:
        # Only runs trained on the true hole, as in the training-model table.
        true_hole = runs
        if SIMULATED_HOLE_KEY in runs:
            true_hole = runs[runs[SIMULATED_HOLE_KEY] == "true_hole"]
        models = true_hole.assign(
            training_model=true_hole.apply(training_model, axis=1, args=(keys,))
        )
        twins = [k for k in levels if k not in keys]
        for (rung, method), part in models.groupby(["rung", "method"]):
            real = part[part["training_model"] == REAL_SCENE].set_index(twins)
            for model, trained in part[part["training_model"] != REAL_SCENE].groupby(
                "training_model"
            ):
                own = trained.set_index(twins)["deploy_success_rate"]
                reference = real["deploy_success_rate"].reindex(own.index)
                counts = pair_counts(own, reference)
                if not counts["pairs"]:
                    continue
                rows.append(
                    {
                        "method": f"{method}, trained {model}",
                        "versus": f"{method}, trained {REAL_SCENE} model",
                        **trained.iloc[0][[*compared, "rungs"]].to_dict(),
                        "rung": rung,
                        **counts,
                    }
                )
    table = pd.DataFrame(rows, columns=columns)
    order = {rung: i for i, rung in enumerate(_rung_order(runs))}
    table = table.assign(order=table["rung"].map(order))
    return table.sort_values(["order", *compared], kind="stable")[columns].reset_index(drop=True)
