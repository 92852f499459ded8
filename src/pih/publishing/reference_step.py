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
    study_tables,
)
from pih.records.outputs import read_provenance
from pih.study.replay_record import COLUMNS, STEP, deployment_trials, replay_name

REFERENCE_STEP_S = 6.25e-5
"""The step check's reference step (docs/simulation.md)."""


@dataclass(frozen=True)
class Replayed:
    """What one :func:`replay_published` call did."""

    made: int
    """runs whose trials were replayed and written"""
    left: int
    """runs still to replay"""
    tables: bool
    """whether the study's tables were re-made (every run replayed, and some in this call)"""


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
    (parts are never mixed). Once every run is replayed, the study's tables are re-made."""
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
            STEP,
            point=run.record["sweep_point"],
            config={"scene": to_mapping(scene), "planner": to_mapping(run.planner)},
            inputs=[path, *sorted(path.parent.glob("redeploy_start_std_m~*.parquet"))],
            simulator={"time_step_s": step_s, "retry_time_step_s": step_s / 2},
        )
        write_table(frame, path.parent / name, provenance, COLUMNS)
        progress(f"{path.parent.name}/{name}: {int(frame['flipped'].sum())} of {len(frame)} flip")
    made = len(todo[:limit])
    tables = made > 0 and made == len(todo) and set(expected) <= set(runs)
    if tables:
        study_tables(root, study)
    return Replayed(made, len(todo) - made, tables)
