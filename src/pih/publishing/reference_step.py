"""A published study's deployment trials replayed at a finer time step, the step check's
reference (``pih publish --study S --replay-step``): what the headline measures, simulated
where the physics has converged. One file per run, beside it, made in parts; the run's own files
stay as they are."""

from __future__ import annotations

import importlib.metadata
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd

from pih.publishing.equivalence import current_hashes
from pih.publishing.published import (
    PublishedStudy,
    one_line,
    published_run_reasons,
    published_runs,
)
from pih.records.outputs import read_provenance

REFERENCE_STEP_S = 6.25e-5
"""The step check's reference step (docs/simulation.md)."""
DEPLOYMENT_PHASES = ("deploy", "deploy_final_mean")
"""The trials a run's deployment makes: the deployed policy's and its final mean's."""
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


def replay_name(step_s: float) -> str:
    """The file a run's deployment trials replayed at ``step_s`` are written to, beside it."""
    return f"replay_time_step_s~{step_s:g}.parquet"


def deployment_trials(run: Path, rollouts: pd.DataFrame) -> pd.DataFrame:
    """A run's deployment trials (``run``: its directory; ``rollouts``: its record's rows):
    every row of :data:`DEPLOYMENT_PHASES` from the training start and from each offset-start
    redeployment, ``source`` naming which (on the training scene: model errors are other
    physics)."""
    sources = [("training start", rollouts)]
    sources += [
        (path.stem.removeprefix("redeploy_"), pd.read_parquet(path))
        for path in sorted(run.glob("redeploy_start_std_m~*.parquet"))
    ]
    trials = [
        rows[rows["phase"].isin(DEPLOYMENT_PHASES)].assign(source=source)
        for source, rows in sources
    ]
    return pd.concat(trials, ignore_index=True)


@dataclass(frozen=True)
class Replayed:
    """What one :func:`replay_published` call did."""

    made: int
    """runs whose trials were replayed and written"""
    left: int
    """runs still to replay"""


def replay_published(
    study: PublishedStudy,
    step_s: float = REFERENCE_STEP_S,
    root: Path = Path("."),
    workers: int = 1,
    limit: int | None = None,
    progress: Callable[[str], None] = print,
) -> Replayed:
    """Replay every deployment trial of ``study``'s published runs at ``step_s`` (retry at half
    of it), one file per run beside it (:func:`replay_name`), with the step, the rollout hash,
    Drake and the CPU in its provenance; at most ``limit`` runs in this call. Refused in one line
    before any is replayed: a published run that is stray or not current, or a replay already
    there made by another Drake or by rollout code that is neither today's nor verified current
    (parts are never mixed)."""
    from pih.config import to_mapping
    from pih.planning.run_record import RecordedRun
    from pih.records.outputs import write_table
    from pih.records.provenance import record
    from pih.study.replay import at_step, replay_rows

    expected, runs = published_runs(root / study.directory, study)
    current, drake = current_hashes(), importlib.metadata.version("drake")
    name = replay_name(step_s)
    reasons = published_run_reasons(root, expected, runs, current)
    for path in sorted(path.parent / name for path in runs.values()):
        if path.is_file():
            made = read_provenance(path)
            if made["packages"]["drake"] != drake:
                reasons.append(
                    f"{path}: replayed by Drake {made['packages']['drake']}, not {drake}"
                )
            if made["rollout_code_sha256"] not in current:
                reasons.append(f"{path}: replayed by other rollout code ({made['code_version']})")
    if reasons:
        raise ValueError(one_line(root / study.directory, reasons))
    todo = sorted(
        (path for path in runs.values() if not (path.parent / name).is_file()),
        key=lambda path: path.parent.name,
    )
    for path in todo[:limit]:
        run = RecordedRun.read(path)
        trials = deployment_trials(path.parent, run.rollouts)
        scene = at_step(run.scene, step_s)
        replayed = replay_rows(trials, scene, run.planner, workers)
        frame = pd.DataFrame(
            {
                "source": trials["source"],
                "phase": trials["phase"],
                "iteration": trials["iteration"],
                "rollout": trials["rollout"],
                "recorded_inserted": trials["success"].astype(bool),
                "recorded_p2_x_m": trials["final_bottom_x_m"],
                "recorded_p2_y_m": trials["final_bottom_y_m"],
                "inserted": replayed[:, 0] > 0,
                "p2_x_m": replayed[:, 1],
                "p2_y_m": replayed[:, 2],
            }
        )
        frame["flipped"] = frame["inserted"] != frame["recorded_inserted"]
        frame["dp2_m"] = np.hypot(
            frame["p2_x_m"] - frame["recorded_p2_x_m"], frame["p2_y_m"] - frame["recorded_p2_y_m"]
        )
        provenance = record(
            "replay_step",
            point=run.record["sweep_point"],
            config={"scene": to_mapping(scene), "planner": to_mapping(run.planner)},
            inputs=[path, *sorted(path.parent.glob("redeploy_start_std_m~*.parquet"))],
            simulator={"time_step_s": step_s, "retry_time_step_s": step_s / 2},
        )
        write_table(frame, path.parent / name, provenance, COLUMNS)
        progress(f"{path.parent.name}/{name}: {int(frame['flipped'].sum())} of {len(frame)} flip")
    made = len(todo[:limit])
    return Replayed(made, len(todo) - made)
