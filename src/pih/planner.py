"""DMP + black-box-optimization insertion planner, one-level and bilevel (paper §3, Algorithm 1).

Each iteration i:

1. **Sense** the hole: x̃_H ~ N(x_H + μ_x, σ_x²), y_H and θ_H exact (eq. 16b), drawn from the
   run's seeded generator: anew every iteration (Algorithm 1) or once per run
   (``sensing.redraw``); the same for all of that iteration's rollouts.
2. **Goal** q_R(T) of the DMP. The robot frame R rests on the peg top P1, so "put the peg tip
   P2 at pose q" means q_R(T) = q_P1 of the peg whose P2 is at q (the frame offset of eq. 4–5).
   *One-level*: q = q̃_H. *Bilevel*: the outer level (:class:`OuterLevel`); the paper's rule is
   q = arg min J_out(q_P2, q̃_H) (eq. 15–16) over Q_P, the P2 poses explored by the previous
   iteration's non-diverged rollouts. In the first iteration both methods use q̃_H (§3.3).
3. **Rollouts**: r weight vectors W ~ N(W*, σ_W) (eq. 12, or CMA-ES) → DMP (eq. A1) →
   simulator (eq. 1) → inner cost J_inn (eq. 11).
4. **Update** W* from the costs (eq. 13, or CMA-ES).

After the last iteration the learned policy W* is **deployed** ``deploy_trials`` times, each
against a freshly sensed hole (and, with ``deploy_start_std_m``, from an offset start), with no
exploration noise: the fraction that inserts answers
"would this policy insert if deployed?". A rollout *succeeds* when the true (not sensed) distance
between P2 and the hole frame H at its end is within ``success_tolerance_m``. docs/planner.md
explains the choices.
"""

from __future__ import annotations

import dataclasses
import hashlib
import math
import multiprocessing
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Literal, Self

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from pih.config import recorded_config, require, require_finite, require_positive
from pih.dmp import Dmp, DmpConfig
from pih.frames import spring_energy
from pih.optimizers import OptimizerConfig, make_optimizer
from pih.outputs import read_provenance
from pih.scene import PegInHoleScene, RobotTrajectory, Trace
from pih.scene_config import SceneConfig

Method = Literal["one_level", "bilevel"]
METHODS: tuple[str, ...] = ("one_level", "bilevel")


Balance = Literal["none", "first_iteration_median"]
Redraw = Literal["per_iteration", "per_run"]
OuterRule = Literal["explored_argmin", "deepest_explored"]
GoalTilt = Literal["explored", "sensed"]
DeployPolicy = Literal["final_mean", "last_inserted_mean"]
DEPLOY_POLICIES: tuple[str, ...] = ("final_mean", "last_inserted_mean")
COST_TERMS: tuple[str, ...] = ("regularization", "spring_energy", "hole_distance")
MAX_START_HEIGHT_M = 0.15
"""Highest start allowed above the hole's top surface (the paper's Fig. 8 starts ≈0.1 m up)."""


@dataclass(frozen=True)
class CostConfig:
    """Weights of eq. 11 (paper Table 4), the sampling of its sums, and their balance."""

    regularization: float = 1.0e4  # α1
    spring_energy: float = 20.0  # α2
    hole_distance: float = 10.0  # α3
    # The sums over t in eq. 11 run over samples this far apart, so the weights' balance does
    # not change with the simulator's time step. Not in the paper.
    sample_period_s: float = 0.01
    # Whether the sums also run over the settling time after the DMP's duration T.
    include_settling: bool = True
    # "none": eq. 11 as printed. "first_iteration_median": each term is divided by its median
    # over the first iteration's rollouts (then weighted by α), so the terms start at the
    # similar sizes the paper asks for (§3.3); the divisors are fixed after iteration 1.
    balance: Balance = "none"

    def validate(self, prefix: str = "") -> None:
        require_positive(self, COST_TERMS, prefix, allow_zero=True)
        require(
            math.isfinite(self.sample_period_s) and self.sample_period_s > 0,
            prefix + "sample_period_s",
            "a finite period > 0 s",
            self.sample_period_s,
        )
        if self.balance != "none":
            for name in COST_TERMS:
                require(
                    getattr(self, name) > 0,
                    prefix + name,
                    f"a weight > 0 when {prefix}balance is {self.balance!r} "
                    "(a zero term has a zero median to divide by)",
                    getattr(self, name),
                )


@dataclass(frozen=True)
class SensingConfig:
    """Visual noise on the hole's x (paper §3.2) and the belief Σ_H of eq. 11 and 15."""

    bias_m: float = 0.005  # μ_x, Table 4
    std_m: float = 0.005  # σ_x, Table 4
    # Σ_H = diag(σ²) for (x, y, θ). Not in the paper. x: the vision noise σ_x; y and θ are sensed
    # exactly (eq. 16b), so their belief is tight: 1 mm and 0.02 rad (with a loose θ belief the
    # outer level picks tilted explored poses, and a tilted goal jams the peg in the hole). A
    # tight y makes J_out prefer explored poses at the hole's depth over poses beside it.
    hole_std: tuple[float, float, float] = (0.005, 0.001, 0.02)
    # "per_iteration": the hole is sensed anew every iteration (Algorithm 1, Fig. 6);
    # "per_run": once per run.
    redraw: Redraw = "per_iteration"

    def validate(self, prefix: str = "") -> None:
        require_finite(prefix + "bias_m", self.bias_m)
        require(
            math.isfinite(self.std_m) and self.std_m >= 0,
            prefix + "std_m",
            "a finite std >= 0 m",
            self.std_m,
        )
        require(
            all(math.isfinite(s) and s > 0 for s in self.hole_std),
            prefix + "hole_std",
            "three finite standard deviations > 0 (Σ_H must be non-singular)",
            self.hole_std,
        )

    @property
    def hole_precision(self) -> NDArray[np.float64]:
        """Diagonal of Σ_H⁻¹."""
        return 1.0 / np.square(self.hole_std)


@dataclass(frozen=True)
class OuterConfig:
    """How bilevel's outer level sets the DMP goal (eq. 15–16); see docs/planner.md."""

    # "explored_argmin": the paper's rule, arg min J_out over the peg-tip poses P2 explored by
    # the previous iteration. "deepest_explored": once some rollout has put P2 more than
    # entry_depth_m below the hole's top surface with the peg within max_tilt_rad of the hole's
    # axis, aim along that axis (x of the deepest such P2 so far, the sensed depth y_H and tilt
    # θ_H, eq. 16b: exact); before that, the paper's rule.
    rule: OuterRule = "explored_argmin"
    # The paper's rule's goal tilt: the chosen explored pose's ("explored") or θ_H ("sensed").
    goal_tilt: GoalTilt = "explored"
    # deepest_explored: how far below the top surface counts as inside the chamfer or hole...
    entry_depth_m: float = 0.001
    # ...for a peg this close to upright (a steeply tilted peg can dip its tip centre into the
    # chamfer from beside the hole).
    max_tilt_rad: float = 0.05

    def validate(self, prefix: str = "") -> None:
        require_positive(self, ("entry_depth_m", "max_tilt_rad"), prefix)


@dataclass(frozen=True)
class PlannerConfig:
    method: Method = "bilevel"
    iterations: int = 50  # Table 4 / §3.3
    # Start of the peg centre's x (paper §3.3: x_P from −0.04 to −0.03 m).
    start_x_m: float = -0.035
    # Height of the peg tip P2 above the hole's top surface at the start. Not in the paper: 5 mm
    # clears the surface so the first contact is made by the planned motion (Fig. 8: ≈0.1 m).
    start_height_m: float = 0.005
    # Extra simulated time after the DMP's duration T, so the peg settles before success is judged.
    # Not in the paper; 0.3 s is ~2 periods of the peg on the 1000 N/m spring.
    settle_s: float = 0.3
    # Success: |P2 − H| (x, y) at the end. Not in the paper; 1 mm is well inside the hole
    # (the chamfer alone is 2.5 mm deep) and tighter than the 5 mm visual noise.
    success_tolerance_m: float = 0.001
    # The run's seed. With optimizer.seed and the run's sweep levels (all but the method's), it
    # seeds the sensed holes, the exploration noise and the deployment trials (see run_seeds).
    seed: int = 0
    # After the last iteration, the learned policy (mean weights, no exploration) is deployed
    # this many times, each against a freshly sensed hole: the headline success metric.
    deploy_trials: int = 10
    # Which weights are deployed: the optimizer's mean after the last iteration, or (evaluating
    # the mean once per iteration, as dmpbbo does) the latest mean whose rollout inserted by
    # the planner's own observation (``Planner.inserted``); the final mean if none did. With
    # the latter the final mean is deployed too, on the same sensed holes (phase
    # ``deploy_final_mean``), so one training run measures both policies.
    deploy_policy: DeployPolicy = "last_inserted_mean"
    # Each deployment trial starts the peg tip this far off the training start, x and y each
    # N(0, σ²) from the deployment stream (0: every trial starts where training did). Without
    # it a bilevel policy whose goal does not depend on the sensed hole deploys the same
    # rollout every trial; with it, the trials ask whether the policy tolerates a start the
    # robot reaches only to within σ. Not in the paper.
    deploy_start_std_m: float = 0.0
    # Each training rollout (sampled and the evaluated mean) starts this far off the nominal
    # start, x and y each N(0, σ²) from the run's start stream, so the optimizer ranks weights
    # by how they do from starts the robot reaches only to within σ (robust training; 0: every
    # training rollout starts at the nominal start, Algorithm 1). Not in the paper.
    train_start_std_m: float = 0.0
    # Stop early when the best J_inn of the last `convergence_window` iterations varies by less
    # than `convergence_tolerance` relative to its mean; 0 runs the whole budget (the paper's
    # bands compare runs over the same iterations).
    convergence_window: int = 0
    convergence_tolerance: float = 0.01
    # T = 3 s (not in the paper): 3.3 s simulated per rollout with the settling time.
    dmp: DmpConfig = field(default_factory=DmpConfig)
    optimizer: OptimizerConfig = field(default_factory=OptimizerConfig)
    costs: CostConfig = field(default_factory=CostConfig)
    sensing: SensingConfig = field(default_factory=SensingConfig)
    outer: OuterConfig = field(default_factory=OuterConfig)

    def validate(self, prefix: str = "") -> None:
        require(self.method in METHODS, prefix + "method", f"one of {list(METHODS)}", self.method)
        require(self.iterations >= 1, prefix + "iterations", "an integer >= 1", self.iterations)
        require_finite(prefix + "start_x_m", self.start_x_m)
        require_positive(self, ("start_height_m", "success_tolerance_m"), prefix)
        require(
            self.start_height_m <= MAX_START_HEIGHT_M,
            prefix + "start_height_m",
            f"a height <= {MAX_START_HEIGHT_M} m above the hole's top surface",
            self.start_height_m,
        )
        require_positive(self, ("settle_s",), prefix, allow_zero=True)
        require(self.seed >= 0, prefix + "seed", "an integer >= 0", self.seed)
        require(
            self.deploy_trials >= 1, prefix + "deploy_trials", "an integer >= 1", self.deploy_trials
        )
        for key in ("train_start_std_m", "deploy_start_std_m"):
            std = getattr(self, key)
            require(
                math.isfinite(std) and 0 <= std <= self.start_height_m / 4,
                prefix + key,
                f"a std >= 0 m and <= start_height_m / 4 ({self.start_height_m / 4:g} m), so "
                "that offset starts stay above the hole's top surface",
                std,
            )
        require(
            self.deploy_policy in DEPLOY_POLICIES,
            prefix + "deploy_policy",
            f"one of {list(DEPLOY_POLICIES)}",
            self.deploy_policy,
        )
        require(
            self.convergence_window == 0 or self.convergence_window >= 2,
            prefix + "convergence_window",
            "0 (no early stop) or an integer >= 2 (one iteration's spread is always 0)",
            self.convergence_window,
        )
        require(
            math.isfinite(self.convergence_tolerance) and self.convergence_tolerance > 0,
            prefix + "convergence_tolerance",
            "a finite value > 0",
            self.convergence_tolerance,
        )
        self.dmp.validate(prefix + "dmp.")
        self.optimizer.validate(prefix + "optimizer.")
        self.costs.validate(prefix + "costs.")
        self.sensing.validate(prefix + "sensing.")
        self.outer.validate(prefix + "outer.")


# --------------------------------------------------------------------------------------------
# Costs (eq. 11, 15) and the outer level (eq. 15–16)


@dataclass(frozen=True)
class CostTerms:
    """The three terms of J_inn (eq. 11), weights applied."""

    regularization: float
    spring_energy: float
    hole_distance: float

    @property
    def values(self) -> NDArray[np.float64]:
        return np.array([self.regularization, self.spring_energy, self.hole_distance])


def inner_cost(
    weights: NDArray[np.float64],
    q_robot: NDArray[np.float64],
    q_peg_top: NDArray[np.float64],
    q_peg_bottom: NDArray[np.float64],
    sensed_hole: NDArray[np.float64],
    stiffness: tuple[float, float, float],
    costs: CostConfig,
    sensing: SensingConfig,
) -> CostTerms:
    """J_inn = α1‖W‖² + α2 Σ_t E_RP(t) + α3 Σ_t δq̃ᵀ Σ_H⁻¹ δq̃, δq̃ = q_P2 − q̃_H (eq. 11);
    the sums run over the cost samples given."""
    energy = spring_energy(q_robot, q_peg_top, stiffness)
    return CostTerms(
        regularization=costs.regularization * float(np.dot(weights, weights)),
        spring_energy=costs.spring_energy * float(np.sum(energy)),
        hole_distance=costs.hole_distance
        * float(np.sum(hole_distance(q_peg_bottom, sensed_hole, sensing))),
    )


def hole_distance(
    q_peg_bottom: NDArray[np.float64], sensed_hole: NDArray[np.float64], sensing: SensingConfig
) -> NDArray[np.float64]:
    """δq̃ᵀ Σ_H⁻¹ δq̃ per sample (the summand of eq. 11's third term; 2·J_out of eq. 15)."""
    delta = np.asarray(q_peg_bottom) - sensed_hole
    return np.sum(sensing.hole_precision * delta * delta, axis=-1)


def outer_goal(
    explored_bottom: NDArray[np.float64], sensed_hole: NDArray[np.float64], sensing: SensingConfig
) -> NDArray[np.float64]:
    """arg min over explored P2 poses of J_out(q_P2, q̃_H) (eq. 15–16)."""
    return explored_bottom[
        int(np.argmin(0.5 * hole_distance(explored_bottom, sensed_hole, sensing)))
    ]


CLEAN_OVERLAP_M = 1.0e-4
"""deepest_explored only trusts P2 samples whose peg–hole overlap is at most this: a one-step
solver transient (up to 1 mm, docs/simulation.md) must not read as a pose inside the hole."""


class OuterLevel:
    """Bilevel's goal (eq. 15–16) from what the rollouts explored; ``goal`` is the P2 target.

    Q_P is the previous iteration's explored P2 poses (Algorithm 1); ``deepest`` is the deepest
    clean P2 pose of the whole run so far (used by the ``deepest_explored`` rule).
    """

    def __init__(self, config: PlannerConfig, hole_depth_m: float, hole_theta_rad: float) -> None:
        self.config = config
        self.hole_depth_m = hole_depth_m
        self.hole_theta_rad = hole_theta_rad  # θ_H, sensed exactly (eq. 16b)
        self.explored: NDArray[np.float64] | None = None
        self.deepest: NDArray[np.float64] | None = None

    def observe(self, traces: list[Trace], samples: slice) -> None:
        """Q_P ← the P2 poses of this iteration's non-diverged rollouts; remember the deepest
        clean, near-upright one of the run."""
        ok = [t for t in traces if t.ok]
        if not ok:
            return
        self.explored = np.vstack([t.q_peg_bottom[samples] for t in ok])
        upright = self.config.outer.max_tilt_rad
        candidates = np.vstack(
            [
                t.q_peg_bottom[samples][
                    (t.penetration_m[samples] <= CLEAN_OVERLAP_M)
                    & (np.abs(t.q_peg_bottom[samples][:, 2] - self.hole_theta_rad) <= upright)
                ]
                for t in ok
            ]
        )
        if candidates.size:
            candidate = candidates[int(np.argmin(candidates[:, 1]))]
            if self.deepest is None or candidate[1] < self.deepest[1]:
                self.deepest = candidate

    def goal(self, sensed: NDArray[np.float64]) -> NDArray[np.float64]:
        """The P2 pose the DMP aims at: q̃_H until something was explored."""
        cfg = self.config.outer
        if self.explored is None:
            return sensed.copy()
        top_y = sensed[1] + self.hole_depth_m  # y_H is sensed exactly (eq. 16b)
        if (
            cfg.rule == "deepest_explored"
            and self.deepest is not None
            and self.deepest[1] < top_y - cfg.entry_depth_m
        ):
            return np.array([self.deepest[0], sensed[1], sensed[2]])  # along the hole's axis
        chosen = outer_goal(self.explored, sensed, self.config.sensing).copy()
        if cfg.goal_tilt == "sensed":
            chosen[2] = sensed[2]
        return chosen


def run_seeds(config: PlannerConfig, seed_key: str = "") -> dict[str, int]:
    """The run's independent streams, from ``planner.seed``, ``optimizer.seed`` and the run's
    sweep levels other than the method's (``seed_key``): sensed holes (``noise``), exploration
    noise, deployment trials, and training starts (``start``, drawn only when
    ``train_start_std_m`` > 0). Runs that differ only in method share them (common random
    numbers); any other difference gives independent streams."""
    words = np.frombuffer(hashlib.sha256(seed_key.encode()).digest(), dtype=np.uint32)
    root = np.random.SeedSequence([config.seed, config.optimizer.seed, *words.tolist()])
    # Spawned children depend only on their index, so adding a stream keeps the others.
    names = ("noise", "exploration", "deployment", "start")
    return {name: int(c.generate_state(1)[0]) for name, c in zip(names, root.spawn(len(names)))}


class CostBalance:
    """eq. 11's total, optionally with each term divided by its first-iteration median."""

    def __init__(self, config: CostConfig, divisors: list[float] | None = None) -> None:
        """``divisors``: a run's recorded ones (its provenance's ``cost_divisors``), kept."""
        self.divisors = np.ones(len(COST_TERMS)) if divisors is None else np.asarray(divisors)
        self._fixed = config.balance == "none" or divisors is not None

    def totals(self, terms: list[CostTerms | None]) -> NDArray[np.float64]:
        """J_inn of each rollout (NaN for diverged ones); fixes the divisors on first use."""
        values = np.array([t.values if t else np.full(3, np.nan) for t in terms])
        if not self._fixed:
            medians = np.nanmedian(values, axis=0) if np.isfinite(values).any() else None
            if medians is not None and np.all(np.isfinite(medians) & (medians > 0)):
                self.divisors = medians
                self._fixed = True
        return np.sum(values / self.divisors, axis=1)


# --------------------------------------------------------------------------------------------
# The run record


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
    "sensed_hole_y_m": ("m", "sensed hole y (exact)"),
    "sensed_hole_theta_rad": ("rad", "sensed hole θ (exact)"),
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
            "amplitude, pih.dmp): with start, target and the scene config it replays exactly"
        ),
    ),
    "final_bottom_x_m": ("m", "peg tip P2 at the end, x"),
    "final_bottom_y_m": ("m", "peg tip P2 at the end, y"),
    "final_bottom_theta_rad": ("rad", "peg tip P2 at the end, θ"),
    "final_hole_error_m": ("m", "true |P2 − H| (x, y) at the end"),
    "success": ("1", "final_hole_error_m <= success_tolerance_m and not diverged"),
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
        phase: str,
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
            start, target, weights, sensed = rollout
            final = trace.q_peg_bottom[-1] if len(trace) else np.full(3, np.nan)
            error = float(np.hypot(*(final[:2] - self.hole_xy)))
            self.rows.append(
                {
                    "phase": phase,
                    "iteration": iteration,
                    "rollout": r,
                    "cost": float(cost),
                    **{
                        f"cost_{name}": value
                        for name, value in zip(COST_TERMS, term.values if term else [np.nan] * 3)
                    },
                    **_pose_columns("sensed_hole", sensed),
                    **_pose_columns("start", start),
                    **_pose_columns("target", target),
                    "target_hole_error_m": float(np.hypot(*(target[:2] - self.hole_xy))),
                    **_pose_columns("goal", self.scene.peg_top_from_bottom(target)),
                    "weights": np.asarray(weights, dtype=float).copy(),
                    **_pose_columns("final_bottom", final),
                    "final_hole_error_m": error,
                    "success": bool(trace.ok and error <= self.tolerance_m),
                    "is_best": False,
                    "status": trace.status,
                    "reason": trace.reason,
                    "time_step_s": trace.time_step_s,
                    "sigma": sigma,
                }
            )
        if phase == "train":
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
        phase: str,
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


# --------------------------------------------------------------------------------------------
# Algorithm 1


class Planner:
    """Algorithm 1 on one scene. The scene (and its Drake diagram) is reused by every rollout."""

    def __init__(self, scene: PegInHoleScene, config: PlannerConfig, seed_key: str = "") -> None:
        config.validate()
        self.scene = scene
        self.config = config
        self.seeds = run_seeds(config, seed_key)
        hole = scene.config.hole
        self.start_bottom = np.array([config.start_x_m, hole.top_y_m + config.start_height_m, 0.0])
        settle = config.settle_s
        step = scene.config.solver.time_step_s
        self.times_s = np.arange(0.0, config.dmp.duration_s + settle + 0.5 * step, step)
        every = max(1, round(config.costs.sample_period_s / step))
        end = None
        if not config.costs.include_settling:
            end = int(np.searchsorted(self.times_s, config.dmp.duration_s + 0.5 * step))
        self.cost_samples = slice(0, end, every)

    @classmethod
    def from_configs(cls, scene: SceneConfig, config: PlannerConfig, seed_key: str = "") -> Planner:
        """A planner on a new scene. The planner never reads contact-patch counts, so the scene
        skips that per-step callback."""
        scene_config = scene.replace(solver__log_contact_patches=False)
        return cls(PegInHoleScene(scene_config), config, seed_key)

    def sense_hole(self, rng: np.random.Generator) -> NDArray[np.float64]:
        """q̃_H = [N(x_H + μ_x, σ_x²), y_H, θ_H] (eq. 16b)."""
        truth = self.scene.hole_pose
        sensing = self.config.sensing
        return np.array([rng.normal(truth[0] + sensing.bias_m, sensing.std_m), truth[1], truth[2]])

    def dmp(self, start: NDArray[np.float64], target: NDArray[np.float64]) -> Dmp:
        """The DMP from the P1 pose of the peg whose tip P2 is at ``start`` to q_R(T), the P1 pose
        of the peg whose tip is at ``target``."""
        top = self.scene.peg_top_from_bottom
        return Dmp(self.config.dmp, top(start), top(target))

    def evaluate(
        self, dmp: Dmp, weights: NDArray[np.float64], sensed_hole: NDArray[np.float64]
    ) -> tuple[Trace, CostTerms | None]:
        """One rollout: DMP → simulator → J_inn's terms (None if the simulation diverged)."""
        poses, _ = dmp.rollout(weights, self.times_s)
        trace = self.scene.rollout(RobotTrajectory(self.times_s, poses))
        if not trace.ok:
            return trace, None
        k = self.cost_samples
        terms = inner_cost(
            weights,
            trace.q_robot[k],
            trace.q_peg_top[k],
            trace.q_peg_bottom[k],
            sensed_hole,
            self.scene.config.spring.stiffness,
            self.config.costs,
            self.config.sensing,
        )
        return trace, terms

    def inserted(self, trace: Trace, sensed_hole: NDArray[np.float64]) -> bool:
        """Whether a rollout ended with the peg in the hole, as the planner can observe it: the
        tip within ``success_tolerance_m`` of the sensed depth y_H (exact, eq. 16b). Only a peg
        inside the hole gets there; the top surface is a hole depth above."""
        return bool(
            trace.ok
            and trace.q_peg_bottom[-1][1] <= sensed_hole[1] + self.config.success_tolerance_m
        )

    def target(self, outer: OuterLevel, sensed: NDArray[np.float64]) -> NDArray[np.float64]:
        """One-level aims at the sensed hole; bilevel where its outer level says."""
        return sensed.copy() if self.config.method == "one_level" else outer.goal(sensed)

    def run(
        self, progress: Callable[[IterationReport], None] | None = None, workers: int = 1
    ) -> RunRecord:
        """Algorithm 1, then the deployment trials of the learned policy. With ``workers`` > 1
        an iteration's rollouts run in that many processes (:class:`RolloutWorkers`); the
        record is the same for any number of workers."""
        with RolloutWorkers(self, workers) as rollouts:
            return self._run(rollouts, progress)

    def _run(
        self, rollouts: RolloutWorkers, progress: Callable[[IterationReport], None] | None
    ) -> RunRecord:
        cfg = self.config
        noise = np.random.default_rng(self.seeds["noise"])
        optimizer = make_optimizer(
            dataclasses.replace(cfg.optimizer, seed=self.seeds["exploration"]),
            np.zeros(3 * cfg.dmp.n_basis),
        )
        outer = OuterLevel(cfg, self.scene.config.hole.depth_m, self.scene.hole_pose[2])
        balance = CostBalance(cfg.costs)
        recorder = RunRecorder(self.scene.hole_pose, cfg.success_tolerance_m, self.scene)
        stop_reason = f"iteration budget ({cfg.iterations})"
        started = time.perf_counter()
        rollout_seconds = 0.0
        evaluate_mean = cfg.deploy_policy == "last_inserted_mean"
        policy, deployed_iteration = None, None
        start_rng = np.random.default_rng(self.seeds["start"])
        sensed = self.sense_hole(noise)
        for iteration in range(1, cfg.iterations + 1):
            if iteration > 1 and cfg.sensing.redraw == "per_iteration":
                sensed = self.sense_hole(noise)
            target = self.target(outer, sensed)
            sigma = optimizer.sigma
            mean = optimizer.mean
            samples = optimizer.ask()
            train_std = cfg.train_start_std_m
            batch = [(self.offset_start(start_rng, train_std), target, w, sensed) for w in samples]
            # Drawn under every deploy policy, so that the next training starts do not depend on it.
            mean_start = self.offset_start(start_rng, train_std)
            if evaluate_mean:
                batch.append((mean_start, target, mean, sensed))
            t0 = time.perf_counter()
            results = rollouts.evaluate(batch)
            rollout_seconds += time.perf_counter() - t0
            traces, terms = zip(*results[: len(samples)])
            costs = balance.totals(list(terms))
            optimizer.tell(samples, costs)
            outer.observe(list(traces), self.cost_samples)
            recorder.add("train", iteration, batch, traces, terms, costs, sigma)
            if evaluate_mean:
                trace, term = results[-1]
                recorder.add(
                    "mean", iteration, batch[-1:], [trace], [term], balance.totals([term]), 0.0
                )
                if self.inserted(trace, sensed):
                    policy, deployed_iteration = mean, iteration
            if progress:
                progress(recorder.report(iteration, cfg.iterations, time.perf_counter() - started))
            if self._converged(recorder.best_costs):
                stop_reason = f"converged at iteration {iteration}"
                break
        situations = self.deployment_trials(outer)

        def trials(weights: NDArray[np.float64]) -> list[Rollout]:
            return [(start, target, weights, sensed) for start, target, sensed in situations]

        final_mean = optimizer.mean
        deployed = trials(final_mean if policy is None else policy)
        deployed_results = rollouts.evaluate(deployed)
        deploy_rate = recorder.add_deployment(
            "deploy", iteration, deployed, deployed_results, balance
        )
        final_mean_rate = deploy_rate
        if evaluate_mean:
            # The final mean in the same situations: the comparison policy, from the same
            # training. It is the deployed one when no evaluated mean inserted.
            final = trials(final_mean)
            final_mean_rate = recorder.add_deployment(
                "deploy_final_mean",
                iteration,
                final,
                deployed_results if policy is None else rollouts.evaluate(final),
                balance,
            )
        rollouts, best_paths = recorder.tables()
        return RunRecord(
            rollouts=rollouts,
            best_paths=best_paths,
            success_iteration=recorder.success_iteration,
            deploy_success_rate=deploy_rate,
            deployed_iteration=deployed_iteration,
            final_mean_deploy_success_rate=final_mean_rate,
            stop_reason=stop_reason,
            seeds=self.seeds,
            cost_divisors=balance.divisors.tolist(),
            seconds=time.perf_counter() - started,
            rollout_seconds=rollout_seconds,
        )

    def offset_start(self, rng: np.random.Generator, std_m: float) -> NDArray[np.float64]:
        """The nominal start, offset in x and y by N(0, std_m²) when std_m > 0 (no draw
        otherwise): a training rollout's (``train_start_std_m``) or a deployment trial's
        (``deploy_start_std_m``)."""
        start = self.start_bottom.copy()
        if std_m > 0:
            start[:2] += rng.normal(0, std_m, 2)
        return start

    def deployment_draws(self) -> list[tuple[NDArray[np.float64], NDArray[np.float64]]]:
        """``deploy_trials`` (start, sensed hole) pairs from the run's deployment stream: each
        hole freshly sensed, then each start offset in x and y by N(0, deploy_start_std_m²)."""
        rng = np.random.default_rng(self.seeds["deployment"])
        n = self.config.deploy_trials
        sensings = [self.sense_hole(rng) for _ in range(n)]
        # Drawn after the holes, so the holes are the same for every deploy_start_std_m.
        starts = [self.offset_start(rng, self.config.deploy_start_std_m) for _ in range(n)]
        return list(zip(starts, sensings, strict=True))

    def deployment_trials(self, outer: OuterLevel) -> list[tuple[NDArray, NDArray, NDArray]]:
        """The (start, target, sensed hole) of each deployment trial: one-level aims at the
        freshly sensed hole, bilevel where its outer level puts the goal."""
        return [
            (start, self.target(outer, sensed), sensed) for start, sensed in self.deployment_draws()
        ]

    def redeployment(self, recorded: pd.DataFrame) -> list[Rollout]:
        """The deployment a run would have made with this planner's ``deploy_start_std_m``:
        the recorded trials' policy, targets and sensed holes (rows of one deployment phase of
        its ``rollouts.parquet``, by trial), from the starts this deployment stream draws. The
        holes are drawn before the starts, so the stream must give the recorded holes back: a
        check that this planner has the run's seeds and trial count."""
        rows = recorded.sort_values("rollout")
        draws = self.deployment_draws()
        if len(rows) != len(draws):
            raise ValueError(f"{len(rows)} recorded trials, deploy_trials is {len(draws)}")
        trials = []
        for (_, row), (start, sensed) in zip(rows.iterrows(), draws):
            if not np.array_equal(sensed, recorded_pose(row, "sensed_hole")):
                raise ValueError(
                    f"trial {row['rollout']}: the deployment stream senses the hole at {sensed}, "
                    f"not where the record does (not the run's seeds)"
                )
            weights = np.asarray(row["weights"], float)
            trials.append((start, recorded_pose(row, "target"), weights, sensed))
        return trials

    def redeploy(
        self, rollouts: pd.DataFrame, cost_divisors: list[float], workers: int = 1
    ) -> pd.DataFrame:
        """The deployment phases of a run's ``rollouts.parquet`` (``deploy``, and
        ``deploy_final_mean`` if recorded) deployed again with this planner's
        ``deploy_start_std_m`` (:meth:`redeployment`): rows in the same columns, J_inn balanced
        with the run's ``cost_divisors``."""
        recorder = RunRecorder(self.scene.hole_pose, self.config.success_tolerance_m, self.scene)
        balance = CostBalance(self.config.costs, cost_divisors)
        done: dict[bytes, list[tuple[Trace, CostTerms | None]]] = {}
        with RolloutWorkers(self, workers) as pool:
            for phase in ("deploy", "deploy_final_mean"):
                recorded = rollouts[rollouts["phase"] == phase]
                if recorded.empty:
                    continue
                trials = self.redeployment(recorded)
                # Both phases deploy one policy in the same situations when no mean inserted.
                policy = np.asarray(trials[0][2]).tobytes()
                if policy not in done:
                    done[policy] = pool.evaluate(trials)
                iterations = int(recorded["iteration"].iloc[0])
                recorder.add_deployment(phase, iterations, trials, done[policy], balance)
        return pd.DataFrame(recorder.rows, columns=list(ROLLOUT_COLUMNS))

    def _converged(self, best_costs: list[float]) -> bool:
        window = self.config.convergence_window
        if window == 0 or len(best_costs) < window:
            return False
        recent = np.asarray(best_costs[-window:])
        if not np.all(np.isfinite(recent)):
            return False
        return float(np.ptp(recent)) <= self.config.convergence_tolerance * abs(
            float(recent.mean())
        )


Rollout = tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]
"""One rollout to evaluate: (P2 pose at the start, P2 target of the DMP's goal, weights W,
sensed hole q̃_H)."""


def recorded_pose(row: pd.Series, prefix: str) -> NDArray[np.float64]:
    """The (x, y, θ) pose a row of ``rollouts.parquet`` records under ``prefix`` (``start``,
    ``target``, ``final_bottom``, …)."""
    return row[[f"{prefix}_x_m", f"{prefix}_y_m", f"{prefix}_theta_rad"]].to_numpy(float)


def recorded_rollout(row: pd.Series) -> Rollout:
    """The rollout a row of ``rollouts.parquet`` records; ``Planner.evaluate`` on it (with the
    run's scene and planner config) replays it exactly, e.g. to look at one deployment trial."""
    start, target, sensed = (recorded_pose(row, p) for p in ("start", "target", "sensed_hole"))
    return start, target, np.asarray(row["weights"], float), sensed


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
            recorded_config(PlannerConfig, config, "planner"),
        )

    def redeployment_config(self, start_std_m: float) -> PlannerConfig:
        """The run's planner config deploying from starts offset by N(0, start_std_m²). A
        ConfigError for a std out of range, a ValueError for a run that cannot be redeployed."""
        if "weights" not in self.rollouts:
            raise ValueError("it predates recorded weights")
        return replace(self.planner, deploy_start_std_m=start_std_m)

    def redeploy(self, start_std_m: float, workers: int = 1) -> pd.DataFrame:
        """The run's deployment phases deployed again from starts offset by N(0, start_std_m²):
        the deployment it would have made with ``planner.deploy_start_std_m = start_std_m``
        (:meth:`Planner.redeploy`)."""
        config = self.redeployment_config(start_std_m)
        planner = Planner.from_configs(self.scene, config, self.record["seed_key"])
        return planner.redeploy(self.rollouts, self.record["result"]["cost_divisors"], workers)


class RolloutWorkers:
    """Evaluates a planner's rollouts in this process, or in ``workers`` processes that each
    build the same scene once (one Drake diagram per process). Rollouts are deterministic
    given (target, W, q̃_H), and results come back in order, so the run does not depend on
    the number of workers. Use as a context manager."""

    def __init__(self, planner: Planner, workers: int = 1) -> None:
        require(isinstance(workers, int) and workers >= 1, "workers", "an integer >= 1", workers)
        self.planner = planner
        self.workers = workers
        self._pool: ProcessPoolExecutor | None = None

    def __enter__(self) -> Self:
        if self.workers > 1:
            # "fork", not "spawn": spawn re-runs the main module in each worker, and a Snakemake
            # script has no __main__ guard (each worker would rerun the whole job). Each worker
            # builds its own scene; nothing of the parent's diagram is used.
            self._pool = ProcessPoolExecutor(
                self.workers,
                mp_context=multiprocessing.get_context("fork"),
                initializer=_start_worker,
                initargs=(self.planner.scene.config, self.planner.config),
            )
        return self

    def __exit__(self, *exc: object) -> None:
        if self._pool is not None:
            self._pool.shutdown(cancel_futures=True)

    def evaluate(self, rollouts: list[Rollout]) -> list[tuple[Trace, CostTerms | None]]:
        if self._pool is None:
            return [_evaluate(self.planner, rollout) for rollout in rollouts]
        return list(self._pool.map(_evaluate_in_worker, rollouts))


_WORKER_PLANNER: Planner | None = None


def _start_worker(scene: SceneConfig, config: PlannerConfig) -> None:
    global _WORKER_PLANNER
    _WORKER_PLANNER = Planner(PegInHoleScene(scene), config)


def _evaluate(planner: Planner, rollout: Rollout) -> tuple[Trace, CostTerms | None]:
    start, target, weights, sensed = rollout
    return planner.evaluate(planner.dmp(start, target), weights, sensed)


def _evaluate_in_worker(rollout: Rollout) -> tuple[Trace, CostTerms | None]:
    assert _WORKER_PLANNER is not None
    return _evaluate(_WORKER_PLANNER, rollout)


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


def replace(config: PlannerConfig, **changes: object) -> PlannerConfig:
    """dataclasses.replace with validation."""
    new = dataclasses.replace(config, **changes)
    new.validate()
    return new
