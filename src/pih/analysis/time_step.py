"""Deployment success at two time steps: each run's recorded deployment trials, and the same
trials replayed at a finer step (:mod:`pih.study.replay_record`), with intervals over runs and
the paired sign tests at each; docs/simulation.md, "The headline at the reference step"."""

from __future__ import annotations

import dataclasses

import pandas as pd

from pih.analysis.aggregate import PlanningTables, compared_keys, level_label, paired_table
from pih.analysis.run_summary import level_columns
from pih.analysis.statistics import rate_over_runs
from pih.study.replay_record import source_start_std_m

RATE_COLUMNS: dict[str, tuple[str, str]] = {
    "time_step_s": ("s", "the step the trials were simulated at (the run's own, or a replay's)"),
    "start_std_m": (
        "m",
        "std of the trials' start offset in x and y (the run's own trials: its deploy_start_std_m)",
    ),
    "phase": ("", "deploy (the deployed policy) or deploy_final_mean (the final mean)"),
    "deploy_success_rate": ("1", "fraction of the run's trials that inserted"),
    "trials": ("1", "the run's trials"),
    "flipped_trials": ("1", "trials whose outcome differs from the one at the run's own step"),
}
"""Per run, one row per step, start std and phase (:func:`replay_rates`)."""


def replay_rates(
    replay: pd.DataFrame, step_s: float, recorded_step_s: float, deploy_start_std_m: float
) -> pd.DataFrame:
    """One run's deployment success per start std and phase at its own step
    (``recorded_step_s``: the recorded outcomes) and at ``step_s`` (the replay's), from its replay
    file's rows (a replay at the run's own step: its rows once); the run's own trials start
    ``deploy_start_std_m`` off."""
    stds = replay["source"].map(lambda source: source_start_std_m(source, deploy_start_std_m))
    trials = replay.assign(start_std_m=stds)
    steps = [(recorded_step_s, "recorded_inserted")] if step_s != recorded_step_s else []
    parts = []
    for step, outcome in [*steps, (step_s, "inserted")]:
        grouped = trials.groupby(["start_std_m", "phase"], sort=True)
        part = grouped.agg(
            deploy_success_rate=(outcome, "mean"),
            trials=(outcome, "size"),
            flipped_trials=("flipped", "sum"),
        ).reset_index()
        if outcome == "recorded_inserted":
            part["flipped_trials"] = 0
        parts.append(part.assign(time_step_s=step))
    return pd.concat(parts, ignore_index=True)[list(RATE_COLUMNS)]


TIME_STEP_COLUMNS: dict[str, tuple[str, str]] = {
    "method": ("", "planning method: one_level, one_level/<stable goal> or bilevel/<outer rule>"),
    "time_step_s": RATE_COLUMNS["time_step_s"],
    "start_std_m": RATE_COLUMNS["start_std_m"],
    "phase": RATE_COLUMNS["phase"],
    "runs": ("1", "independent planning runs"),
    "deploy_success_rate": ("1", "mean over runs of the fraction of trials that inserted"),
    "deploy_ci_low": ("1", "95 % Wilson interval over runs (each run one observation), low"),
    "deploy_ci_high": ("1", "95 % Wilson interval over runs, high"),
    "runs_all_inserted": ("1", "runs whose every trial inserted"),
    "trials": ("1", "trials in all"),
    "flipped_trials": ("1", "trials whose outcome differs from the one at the runs' own step"),
}


def time_step_columns(sweep_keys: list[str]) -> dict[str, tuple[str, str]]:
    """Unit specs of :func:`time_step_table`'s columns for a sweep."""
    method, *rest = TIME_STEP_COLUMNS.items()
    return dict([method, *level_columns(compared_keys(sweep_keys)).items(), *rest])


def time_step_table(replays: pd.DataFrame, sweep_keys: list[str]) -> pd.DataFrame:
    """Deployment success per method, level of every compared dimension, step, start std and
    phase, with a 95 % interval over runs: the study's trials at the runs' own step beside the
    same trials at a replay's."""
    compared = compared_keys(sweep_keys)
    conditions = ["time_step_s", "start_std_m", "phase"]
    rows = []
    for (method, *levels, step, std, phase), runs in replays.groupby(
        ["method", *compared, *conditions], sort=True
    ):
        rate, low, high = rate_over_runs(runs["deploy_success_rate"])
        rows.append(
            {
                "method": method,
                **dict(zip(compared, levels, strict=True)),
                "time_step_s": step,
                "start_std_m": std,
                "phase": phase,
                "runs": len(runs),
                "deploy_success_rate": rate,
                "deploy_ci_low": low,
                "deploy_ci_high": high,
                "runs_all_inserted": int((runs["deploy_success_rate"] == 1).sum()),
                "trials": int(runs["trials"].sum()),
                "flipped_trials": int(runs["flipped_trials"].sum()),
            }
        )
    table = pd.DataFrame(rows, columns=list(time_step_columns(sweep_keys)))
    # The deployed policy first, each from the training start, then from offset starts, the
    # finer step beside the coarser one.
    order = ["phase", *compared, "start_std_m", "method", "time_step_s"]
    ascending = [True] * (len(order) - 1) + [False]
    return table.sort_values(order, ascending=ascending, kind="stable").reset_index(drop=True)


def step_level(step_s: float, start_std_m: float, label: str = "") -> str:
    """The ``level`` of the paired rows at one step and start std (dimension ``time_step_s``),
    e.g. ``starts 0.001 m off at 6.25e-05 s``, then the compared levels' :func:`level_label`."""
    starts = "training start" if start_std_m == 0 else f"starts {start_std_m:g} m off"
    return ", ".join(part for part in (f"{starts} at {step_s:g} s", label) if part)


def time_step_pairs(replays: pd.DataFrame, sweep_keys: list[str]) -> pd.DataFrame:
    """:func:`pih.analysis.aggregate.paired_table` of the deployed policies at each step and start
    std (dimension ``time_step_s``, level :func:`step_level`), pooled over the compared
    dimensions and per joint level of them (which do not pool)."""
    compared = compared_keys(sweep_keys)
    deployed = replays[replays["phase"] == "deploy"]
    parts = []
    # Each start's pairs at the coarser step, then at the finer one.
    for std in sorted(deployed["start_std_m"].unique()):
        for step in sorted(deployed["time_step_s"].unique(), reverse=True):
            part = deployed[(deployed["start_std_m"] == std) & (deployed["time_step_s"] == step)]
            groups = [((), part), *(part.groupby(compared) if compared else [])]
            for levels, group in groups:
                paired = paired_table(group, sweep_keys)
                level = step_level(step, std, level_label(compared[: len(levels)], levels))
                parts.append(
                    paired[paired["dimension"] == "all"].assign(
                        dimension="time_step_s", level=level
                    )
                )
    return pd.concat(parts, ignore_index=True)


def with_time_step(
    tables: PlanningTables, replays: pd.DataFrame, sweep_keys: list[str]
) -> PlanningTables:
    """``tables`` with the success and pairs at each step of the runs' replays, the pairs among
    the paired rows too; as they were without replays."""
    if replays.empty:
        return tables
    pairs = time_step_pairs(replays, sweep_keys)
    return dataclasses.replace(
        tables,
        time_step=time_step_table(replays, sweep_keys),
        time_step_pairs=pairs,
        paired=pd.concat([tables.paired, pairs], ignore_index=True),
    )
