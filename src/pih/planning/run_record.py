"""The run record: the columns of a planning run's ``rollouts.parquet`` and ``best_paths.parquet``
(:data:`ROLLOUT_COLUMNS`, :data:`PATH_COLUMNS`), what a run produced (:class:`RunRecord`, rows
collected by :class:`RunRecorder`), and a recorded run read back (:class:`RecordedRun`,
:func:`recorded_pose`, :func:`recorded_rollout`)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from pih.config import recorded_config
from pih.planning.config import COST_TERMS, PlannerConfig, recorded_planner, replace
from pih.planning.costs import CostBalance, CostTerms
from pih.records.outputs import read_provenance
from pih.scene.config import SceneConfig

if TYPE_CHECKING:
    from pih.scene.simulation import PegInHoleScene
    from pih.scene.trace import Trace


class Phase(StrEnum):
    """What a row of ``rollouts.parquet`` records (its ``phase`` column)."""

    TRAIN = "train"  # a sampled rollout of Algorithm 1
    MEAN = "mean"  # the iteration's mean weights W*, evaluated (last_inserted_mean)
    DEPLOY = "deploy"  # a deployment trial of the learned policy
    DEPLOY_FINAL_MEAN = "deploy_final_mean"  # the final mean, beside last_inserted_mean


DEPLOYMENT_PHASES = (Phase.DEPLOY, Phase.DEPLOY_FINAL_MEAN)


def phase_rows(rollouts: pd.DataFrame, phase: Phase) -> pd.DataFrame:
    """The rows of ``rollouts`` recorded under ``phase``."""
    return rollouts[rollouts["phase"] == phase.value]


class Rollout(NamedTuple):
    """One rollout to evaluate: the DMP from ``start`` to ``target`` (P2 poses) with weights W,
    its costs read against the sensed hole q̃_H, simulated with the hole at ``simulated_hole``
    on the planner's own simulator (``planner.simulated_hole``, ``planner.simulator``; None: the
    real scene, as every deployment trial)."""

    start: NDArray[np.float64]
    target: NDArray[np.float64]
    weights: NDArray[np.float64]
    sensed_hole: NDArray[np.float64]
    simulated_hole: NDArray[np.float64] | None = None


def hole_error_m(q_bottom: NDArray[np.float64], hole_xy: NDArray[np.float64]) -> float:
    """|P2 − H| in (x, y) of a tip pose, H the hole frame given."""
    return float(np.hypot(*(q_bottom[:2] - hole_xy[:2])))


def succeeded(trace: Trace, hole_xy: NDArray[np.float64], tolerance_m: float) -> bool:
    """A rollout's ``success``: not diverged, and its tip P2 ends within ``tolerance_m`` of the
    hole H it was simulated with, in (x, y)."""
    return bool(trace.ok and hole_error_m(trace.q_peg_bottom[-1], hole_xy) <= tolerance_m)


ROLLOUT_COLUMNS: dict[str, tuple[str, str]] = {
    "phase": (
        "",
        (
            "train (Algorithm 1), mean (the iteration's mean weights, if evaluated), deploy (the "
            "deployed policy) or deploy_final_mean (the final mean beside last_inserted_mean)"
        ),
    ),
    "iteration": ("1", "iteration i (1-based); deploy rows: the iterations trained"),
    "rollout": ("1", "rollout index within the iteration (deploy: trial index)"),
    "cost": ("1", "inner cost J_inn (eq. 11, balanced if costs.balance); NaN for diverged"),
    "cost_regularization": ("1", "α1‖W‖² (eq. 11)"),
    "cost_spring_energy": ("1", "α2 Σ E_RP (eq. 11)"),
    "cost_hole_distance": ("1", "α3 Σ δq̃ᵀΣ_H⁻¹δq̃ (eq. 11)"),
    "sensed_hole_x_m": ("m", "sensed hole x̃_H (eq. 16b)"),
    "sensed_hole_y_m": ("m", "sensed hole y (exact unless sensing.y_std_m)"),
    "sensed_hole_theta_rad": ("rad", "sensed hole θ (exact unless sensing.theta_std_rad)"),
    "simulated_hole_x_m": (
        "m",
        (
            "x of the hole in the rollout's simulator: the real hole's, or with planner."
            "simulated_hole a sensed one's (training rollouts only; their contact is "
            "planner.simulator's)"
        ),
    ),
    "simulated_hole_y_m": ("m", "y of the hole in the rollout's simulator"),
    "simulated_hole_theta_rad": ("rad", "θ of the hole in the rollout's simulator"),
    "start_x_m": ("m", "peg tip P2 at the start (offset by train_ or deploy_start_std_m), x"),
    "start_y_m": ("m", "P2 at the start, y"),
    "start_theta_rad": ("rad", "P2 at the start, θ"),
    "target_x_m": ("m", "P2 pose the DMP aims at (sensed hole, or the outer level's), x"),
    "target_y_m": ("m", "P2 target, y"),
    "target_theta_rad": ("rad", "P2 target, θ"),
    "target_hole_error_m": ("m", "true |target − H| (x, y): how far the goal is from the hole"),
    "goal_x_m": ("m", "DMP goal q_R(T) (the P1 pose of the target), x"),
    "goal_y_m": ("m", "DMP goal q_R(T), y"),
    "goal_theta_rad": ("rad", "DMP goal q_R(T), θ"),
    "weights": (
        "1",
        (
            "DMP weights W of the rollout (3 × n_basis: x, y, θ; fractions of each DoF's "
            "amplitude, pih.planning.dmp): with start, target and the scene config it replays exactly"
        ),
    ),
    "final_bottom_x_m": ("m", "peg tip P2 at the end, x"),
    "final_bottom_y_m": ("m", "peg tip P2 at the end, y"),
    "final_bottom_theta_rad": ("rad", "peg tip P2 at the end, θ"),
    "final_hole_error_m": ("m", "|P2 − H| (x, y) at the end, H the simulated hole"),
    "success": (
        "1",
        (
            "final_hole_error_m <= success_tolerance_m and not diverged: inserted into the hole "
            "of the rollout's simulator (training rollouts: planner.simulated_hole's, in "
            "planner.simulator's contact; deployment trials: the real scene)"
        ),
    ),
    "is_best": ("1", "lowest cost of its training iteration"),
    "status": ("", "ok or diverged"),
    "reason": ("", "why the rollout diverged"),
    "time_step_s": ("s", "finest step used (solver.retry_time_step_s if an interval was rerun)"),
    "sigma": ("1", "optimizer exploration scale σ_W when sampled (0 for deploy)"),
}
PATH_COLUMNS: dict[str, tuple[str, str]] = {
    "iteration": ("1", "iteration i (1-based)"),
    "time_s": ("s", "simulated time"),
    "robot_x_m": ("m", "robot frame R, x"),
    "robot_y_m": ("m", "robot frame R, y"),
    "robot_theta_rad": ("rad", "robot frame R, θ"),
    "peg_bottom_x_m": ("m", "peg tip P2, x"),
    "peg_bottom_y_m": ("m", "peg tip P2, y"),
    "peg_bottom_theta_rad": ("rad", "peg tip P2, θ"),
    "contact_fx_n": ("N", "contact force on the peg, x"),
    "contact_fy_n": ("N", "contact force on the peg, y"),
    "spring_energy_j": ("J", "spring energy E_RP (eq. 9)"),
}


@dataclass
class RunRecord:
    """What a planning run produced: one row per rollout, one best trajectory per iteration."""

    rollouts: pd.DataFrame
    best_paths: pd.DataFrame
    success_iteration: int | None
    deploy_success_rate: float
    deployed_iteration: int | None  # whose evaluated mean was deployed; None: the final mean
    final_mean_deploy_success_rate: float  # the final mean's, deployed on the same sensed holes
    stop_reason: str
    seeds: dict[str, int]
    cost_divisors: list[float]
    seconds: float
    rollout_seconds: float

    @property
    def succeeded(self) -> bool:
        return self.success_iteration is not None


@dataclass(frozen=True)
class IterationReport:
    """What a planning job logs after each iteration."""

    iteration: int
    iterations: int
    elapsed_s: float
    iteration_best_cost: float
    best_cost_so_far: float
    successes_so_far: int

    @property
    def remaining_s(self) -> float:
        return self.elapsed_s / self.iteration * (self.iterations - self.iteration)

    def __str__(self) -> str:
        return (
            f"iteration {self.iteration}/{self.iterations}: best J_inn {self.iteration_best_cost:.4g}"
            f" (so far {self.best_cost_so_far:.4g}); iterations with a successful best rollout: "
            f"{self.successes_so_far}; elapsed {self.elapsed_s:.0f} s, about "
            f"{self.remaining_s:.0f} s left"
        )


class RunRecorder:
    """Collects the rows of ``rollouts.parquet`` and the best paths of a run."""

    def __init__(self, hole: NDArray[np.float64], tolerance_m: float, scene: PegInHoleScene):
        self.hole = hole
        self.hole_xy = hole[:2]
        self.tolerance_m = tolerance_m
        self.scene = scene
        self.rows: list[dict] = []
        self.paths: list[pd.DataFrame] = []
        self.success_iteration: int | None = None
        self.successes = 0
        self.best_costs: list[float] = []

    def add(
        self,
        phase: Phase,
        iteration: int,
        batch: list[Rollout],
        traces: list[Trace],
        terms: list[CostTerms | None],
        costs: NDArray[np.float64],
        sigma: float,
    ) -> None:
        """Rows of one iteration's rollouts, or of deployment trials (one rollout each)."""
        first = len(self.rows)
        for r, (rollout, trace, term, cost) in enumerate(zip(batch, traces, terms, costs)):
            start, target, weights, sensed, simulated = rollout
            simulated = self.hole if simulated is None else simulated
            final = trace.q_peg_bottom[-1] if len(trace) else np.full(3, np.nan)
            error = hole_error_m(final, simulated)
            self.rows.append(
                {
                    "phase": phase.value,
                    "iteration": iteration,
                    "rollout": r,
                    "cost": float(cost),
                    **{
                        f"cost_{name}": value
                        for name, value in zip(COST_TERMS, term.values if term else [np.nan] * 3)
                    },
                    **_pose_columns("sensed_hole", sensed),
                    **_pose_columns("simulated_hole", simulated),
                    **_pose_columns("start", start),
                    **_pose_columns("target", target),
                    "target_hole_error_m": float(np.hypot(*(target[:2] - self.hole_xy))),
                    **_pose_columns("goal", self.scene.peg_top_from_bottom(target)),
                    "weights": np.asarray(weights, dtype=float).copy(),
                    **_pose_columns("final_bottom", final),
                    "final_hole_error_m": error,
                    "success": succeeded(trace, simulated, self.tolerance_m),
                    "is_best": False,
                    "status": trace.status,
                    "reason": trace.reason,
                    "time_step_s": trace.time_step_s,
                    "sigma": sigma,
                }
            )
        if phase == Phase.TRAIN:
            best = int(np.nanargmin(costs)) if np.any(np.isfinite(costs)) else 0
            row = self.rows[first + best]
            row["is_best"] = True
            self.paths.append(_best_path(iteration, traces[best]))
            self.best_costs.append(float(costs[best]))
            if row["success"]:
                self.successes += 1
                if self.success_iteration is None:
                    self.success_iteration = iteration

    def add_deployment(
        self,
        phase: Phase,
        iterations_trained: int,
        trials: list[Rollout],
        results: list[tuple[Trace, CostTerms | None]],
        balance: CostBalance,
    ) -> float:
        """Rows of deployment rollouts (one per trial) under ``phase``; the fraction that
        inserted (true |P2 − H| ≤ tolerance)."""
        first = len(self.rows)
        traces, terms = zip(*results)
        self.add(phase, iterations_trained, trials, traces, terms, balance.totals(terms), 0.0)
        return float(np.mean([row["success"] for row in self.rows[first:]]))

    def report(self, iteration: int, iterations: int, elapsed_s: float) -> IterationReport:
        finite = [c for c in self.best_costs if math.isfinite(c)]
        return IterationReport(
            iteration=iteration,
            iterations=iterations,
            elapsed_s=elapsed_s,
            iteration_best_cost=self.best_costs[-1],
            best_cost_so_far=min(finite) if finite else math.nan,
            successes_so_far=self.successes,
        )

    def tables(self) -> tuple[pd.DataFrame, pd.DataFrame]:
        return (
            pd.DataFrame(self.rows)[list(ROLLOUT_COLUMNS)],
            pd.concat(self.paths, ignore_index=True)[list(PATH_COLUMNS)],
        )


def _pose_columns(prefix: str, q: NDArray[np.float64]) -> dict[str, float]:
    return {
        f"{prefix}_x_m": float(q[0]),
        f"{prefix}_y_m": float(q[1]),
        f"{prefix}_theta_rad": float(q[2]),
    }


def _best_path(iteration: int, trace: Trace) -> pd.DataFrame:
    return pd.DataFrame(
        {
            "iteration": iteration,
            "time_s": trace.time_s,
            "robot_x_m": trace.q_robot[:, 0],
            "robot_y_m": trace.q_robot[:, 1],
            "robot_theta_rad": trace.q_robot[:, 2],
            "peg_bottom_x_m": trace.q_peg_bottom[:, 0],
            "peg_bottom_y_m": trace.q_peg_bottom[:, 1],
            "peg_bottom_theta_rad": trace.q_peg_bottom[:, 2],
            "contact_fx_n": trace.contact_force[:, 0],
            "contact_fy_n": trace.contact_force[:, 1],
            "spring_energy_j": trace.spring_energy_j,
        }
    )


def recorded_pose(row: pd.Series, prefix: str) -> NDArray[np.float64]:
    """The (x, y, θ) pose a row of ``rollouts.parquet`` records under ``prefix`` (``start``,
    ``target``, ``final_bottom``, …)."""
    return row[[f"{prefix}_x_m", f"{prefix}_y_m", f"{prefix}_theta_rad"]].to_numpy(float)


def recorded_rollout(row: pd.Series) -> Rollout:
    """The rollout a row of ``rollouts.parquet`` records; ``Planner.evaluate_rollout`` on it
    (with the run's scene and planner config) replays it exactly, e.g. to look at one
    deployment trial. Records that predate ``simulated_hole_*`` ran on the scene's hole."""
    start, target, sensed = (recorded_pose(row, p) for p in ("start", "target", "sensed_hole"))
    # A deployment trial ran on the real scene, whatever the training simulator.
    deployed = row.get("phase") in DEPLOYMENT_PHASES
    simulated = (
        recorded_pose(row, "simulated_hole")
        if "simulated_hole_x_m" in row and not deployed
        else None
    )
    return Rollout(start, target, np.asarray(row["weights"], float), sensed, simulated)


@dataclass(frozen=True)
class RecordedRun:
    """A planning run as its ``rollouts.parquet`` records it: the rows, the provenance record,
    and the run's scene and planner configs (keys the run predates read as their defaults)."""

    rollouts: pd.DataFrame
    record: dict[str, Any]
    scene: SceneConfig
    planner: PlannerConfig

    @classmethod
    def read(cls, path: str | Path) -> RecordedRun:
        record = read_provenance(path)
        config = record["config"]
        return cls(
            pd.read_parquet(path),
            record,
            recorded_config(SceneConfig, config, "scene"),
            recorded_planner(config),
        )

    def redeployment_config(self, start_std_m: float) -> PlannerConfig:
        """The run's planner config deploying from starts offset by N(0, start_std_m²). A
        ConfigError for a std out of range, a ValueError for a run that cannot be redeployed."""
        if "weights" not in self.rollouts:
            raise ValueError("it predates recorded weights")
        return replace(self.planner, deploy_start_std_m=start_std_m)
