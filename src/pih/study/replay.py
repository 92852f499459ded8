"""Recorded rollouts simulated again at another setting (a finer time step): each row's robot
motion from its recorded start, target, DMP weights and simulated hole, its outcome judged as
the run judged it. The step check (``benchmarks/step_convergence.py``) and the published
studies' reference-step replays (:mod:`pih.publishing.reference_step`) share it."""

from __future__ import annotations

import numpy as np
import pandas as pd

from pih.planning.config import PlannerConfig
from pih.planning.planner import Planner, RolloutWorkers
from pih.planning.run_record import recorded_rollout, succeeded
from pih.scene.config import SceneConfig


def at_step(scene: SceneConfig, step_s: float) -> SceneConfig:
    """The scene at ``step_s``, its divergence retry at half of it (as the study's setting)."""
    return scene.replace(solver__time_step_s=step_s, solver__retry_time_step_s=step_s / 2)


def replay_rows(
    rows: pd.DataFrame, scene: SceneConfig, planner_config: PlannerConfig, workers: int
) -> np.ndarray:
    """Per row of ``rollouts.parquet`` (or a table with its pose and weight columns): whether it
    inserted as the ``success`` column defines it, and the final P2 x and y, at ``scene``."""
    planner = Planner.from_configs(scene, planner_config)
    rollouts = [recorded_rollout(row) for _, row in rows.iterrows()]
    with RolloutWorkers(planner, workers) as pool:
        traces = [trace for trace, _ in pool.evaluate(rollouts)]
    tolerance = planner_config.success_tolerance_m
    holes = [
        planner.scene.hole_pose if r.simulated_hole is None else r.simulated_hole for r in rollouts
    ]
    return np.array(
        [
            (succeeded(t, hole, tolerance), *t.q_peg_bottom[-1][:2])
            for t, hole in zip(traces, holes, strict=True)
        ],
        dtype=float,
    ).reshape(len(rollouts), 3)
