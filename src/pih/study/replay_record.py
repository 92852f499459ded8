"""What a replay file holds: a run's deployment trials replayed at a finer time step, one file
beside the run (``replay_time_step_s~<step>.parquet``, made by ``pih publish --replay-step``),
read by the study's tables (:mod:`pih.analysis.time_step`) and by the step check's deployment
part (``benchmarks/step_convergence.py``). No Drake here."""

from __future__ import annotations

from pathlib import Path

import pandas as pd

STEP = "replay_step"
"""The provenance step of a replay file."""
PATTERN = "replay_time_step_s~*.parquet"
DEPLOYMENT_PHASES = ("deploy", "deploy_final_mean")
"""The trials a run's deployment makes: the deployed policy's and its final mean's."""
TRAINING_START = "training start"
"""``source`` of the trials from the run's own deployment; offset starts' name their file."""
COLUMNS = {
    "source": ("1", "where the trials start: the training start, or the offset starts' file"),
    "phase": ("1", "deploy (the deployed policy) or deploy_final_mean (the final mean)"),
    "iteration": ("1", "the iteration the trial is recorded under"),
    "rollout": ("1", "the trial's index"),
    "recorded_inserted": ("1", "the recorded outcome, at the run's own step"),
    "recorded_p2_x_m": ("m", "the recorded final P2 x"),
    "recorded_p2_y_m": ("m", "the recorded final P2 y"),
    "inserted": ("1", "the outcome at the replay's step (|P2 − H| ≤ tolerance, not diverged)"),
    "p2_x_m": ("m", "final P2 x at the replay's step"),
    "p2_y_m": ("m", "final P2 y at the replay's step"),
    "flipped": ("1", "the outcome at the replay's step differs from the recorded one"),
    "dp2_m": ("m", "|ΔP2|: distance between the recorded final P2 and the replay's"),
}
"""A replay file's columns: one row per deployment trial of the run."""
KEYS = ["source", "phase", "iteration", "rollout"]
"""The columns that name a trial among a run's (:func:`deployment_trials`' rows)."""


def replay_name(step_s: float) -> str:
    """The file a run's deployment trials replayed at ``step_s`` are written to, beside it."""
    return f"replay_time_step_s~{step_s:g}.parquet"


def source_start_std_m(source: str, deploy_start_std_m: float) -> float:
    """The start std of a ``source``: the run's own (``planner.deploy_start_std_m``) for the
    training start, else its file's (``start_std_m~0.001`` → 0.001)."""
    if source == TRAINING_START:
        return deploy_start_std_m
    return float(source.removeprefix("start_std_m~"))


def deployment_trials(run: Path, rollouts: pd.DataFrame) -> pd.DataFrame:
    """A run's deployment trials (``run``: its directory; ``rollouts``: its record's rows):
    every row of :data:`DEPLOYMENT_PHASES` from the training start and from each offset-start
    redeployment, ``source`` naming which (on the training scene: model errors are other
    physics). A replay file's rows are these, in this order."""
    sources = [(TRAINING_START, rollouts)]
    sources += [
        (path.stem.removeprefix("redeploy_"), pd.read_parquet(path))
        for path in sorted(run.glob("redeploy_start_std_m~*.parquet"))
    ]
    trials = [
        rows[rows["phase"].isin(DEPLOYMENT_PHASES)].assign(source=source)
        for source, rows in sources
    ]
    return pd.concat(trials, ignore_index=True)
