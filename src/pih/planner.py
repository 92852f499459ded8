"""DMP + black-box-optimization insertion planner, one-level and bilevel (paper §3, Algorithm 1).

Each iteration i:

1. **Sense** the hole: x̃_H ~ N(x_H + μ_x, σ_x²), y_H and θ_H exact (eq. 16b), drawn from the
   run's seeded generator, so the sensed hole changes every iteration but is the same for all of
   that iteration's rollouts.
2. **Goal** q_R(T) of the DMP. The robot frame R rests on the peg top P1, so "put the peg tip
   P2 at pose q" means q_R(T) = q_P1 of the peg whose P2 is at q (the frame offset of eq. 4–5).
   *One-level*: q = q̃_H. *Bilevel*: q = arg min J_out(q_P2, q̃_H) (eq. 15–16) over Q_P, the
   peg-tip poses P2 explored by the previous iteration's rollouts — every cost sample of every
   rollout that did not diverge. P2 is searched (not P1, as Algorithm 1's typography suggests)
   because eq. 15–16c define J_out on q_P2, the point that must reach the hole. In the first
   iteration, with nothing explored yet, both methods use q̃_H (paper §3.3: "the same initial goal").
3. **Rollouts**: r weight vectors W ~ N(W*, σ_W) (eq. 12, or CMA-ES) → DMP (eq. A1) →
   simulator (eq. 1) → inner cost J_inn (eq. 11).
4. **Update** W* from the costs (eq. 13, or CMA-ES).

A rollout *succeeds* when the true (not sensed) distance between P2 and the hole frame H at its end
is within ``success_tolerance_m``; a run succeeds at the first iteration whose best rollout does.
"""

from __future__ import annotations

import dataclasses
import math
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from pih.config import ConfigError, require, require_finite, require_positive
from pih.dmp import Dmp, DmpConfig
from pih.frames import spring_energy
from pih.optimizers import OptimizerConfig, make_optimizer
from pih.scene import PegInHoleScene, RobotTrajectory, SceneConfig, Trace

Method = Literal["one_level", "bilevel"]
METHODS: tuple[str, ...] = ("one_level", "bilevel")


@dataclass(frozen=True)
class CostConfig:
    """Weights of eq. 11 (paper Table 4) and the sampling of its sums."""

    regularization: float = 1.0e4  # α1
    spring_energy: float = 20.0  # α2
    hole_distance: float = 10.0  # α3
    # The sums over t in eq. 11 run over samples this far apart, so the weights' balance does
    # not change with the simulator's time step. Not in the paper.
    sample_period_s: float = 0.01

    def validate(self, prefix: str = "") -> None:
        names = ("regularization", "spring_energy", "hole_distance")
        require_positive(self, names, prefix, allow_zero=True)
        require(
            math.isfinite(self.sample_period_s) and self.sample_period_s > 0,
            prefix + "sample_period_s",
            "a finite period > 0 s",
            self.sample_period_s,
        )


@dataclass(frozen=True)
class SensingConfig:
    """Visual noise on the hole's x (paper §3.2) and the belief Σ_H of eq. 11 and 15."""

    bias_m: float = 0.005  # μ_x, Table 4
    std_m: float = 0.005  # σ_x, Table 4
    # Σ_H = diag(σ²) for (x, y, θ). Not in the paper. x: the vision noise σ_x; y and θ are sensed
    # exactly (eq. 16b), so their belief is tight: 1 mm and 0.02 rad (with a loose θ belief the outer
    # level picks tilted explored poses, and a tilted goal jams the peg in the hole). A tight y makes J_out prefer
    # explored poses at the hole's depth over poses beside it at the sensed x.
    hole_std: tuple[float, float, float] = (0.005, 0.001, 0.02)

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
class PlannerConfig:
    method: Method = "bilevel"
    iterations: int = 50  # Table 4 / §3.3
    # Start of the peg centre's x (paper §3.3: x_P from −0.04 to −0.03 m).
    start_x_m: float = -0.035
    # Height of the peg tip P2 above the hole's top surface at the start. Not in the paper: 5 mm
    # clears the surface so the first contact is made by the planned motion.
    start_height_m: float = 0.005
    # Extra simulated time after the DMP's duration T, so the peg settles before success is judged.
    # Not in the paper; 0.3 s is ~2 periods of the peg on the 1000 N/m spring.
    settle_s: float = 0.3
    # Success: |P2 − H| (x, y) at the end. Not in the paper; 1 mm is well inside the hole
    # (the chamfer alone is 2.5 mm deep) and tighter than the 5 mm visual noise.
    success_tolerance_m: float = 0.001
    # The run's seed: it draws the sensed holes and, with optimizer.seed, the exploration noise.
    # Both methods at one seed see the same sensed holes and exploration noise (common random
    # numbers); different seeds are independent.
    seed: int = 0
    # Stop early when the best J_inn of the last `convergence_window` iterations varies by less
    # than `convergence_tolerance` relative to its mean; 0 runs the whole budget (the paper's
    # bands compare runs over the same iterations).
    convergence_window: int = 0
    convergence_tolerance: float = 0.01
    # T = 3 s (not in the paper): 3.3 s simulated per rollout, ≈110 s per 50 × 10 run here.
    dmp: DmpConfig = field(default_factory=lambda: DmpConfig(duration_s=3.0))
    optimizer: OptimizerConfig = field(default_factory=OptimizerConfig)
    costs: CostConfig = field(default_factory=CostConfig)
    sensing: SensingConfig = field(default_factory=SensingConfig)

    def validate(self, prefix: str = "") -> None:
        require(self.method in METHODS, prefix + "method", f"one of {list(METHODS)}", self.method)
        require(self.iterations >= 1, prefix + "iterations", "an integer >= 1", self.iterations)
        require_finite(prefix + "start_x_m", self.start_x_m)
        require_positive(self, ("start_height_m", "success_tolerance_m"), prefix)
        require_positive(self, ("settle_s",), prefix, allow_zero=True)
        require(self.seed >= 0, prefix + "seed", "an integer >= 0", self.seed)
        require(
            self.convergence_window >= 0,
            prefix + "convergence_window",
            "an integer >= 0 (0: no early stop)",
            self.convergence_window,
        )
        require(
            math.isfinite(self.convergence_tolerance) and self.convergence_tolerance > 0,
            prefix + "convergence_tolerance",
            "a finite value > 0",
            self.convergence_tolerance,
        )
        for section in ("dmp", "optimizer"):
            try:
                getattr(self, section).validate()
            except ValueError as error:
                raise ConfigError(f"{prefix}{section}.{error}") from None
        self.costs.validate(prefix + "costs.")
        self.sensing.validate(prefix + "sensing.")


# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class CostTerms:
    """The three terms of J_inn (eq. 11), weights applied."""

    regularization: float
    spring_energy: float
    hole_distance: float

    @property
    def total(self) -> float:
        return self.regularization + self.spring_energy + self.hole_distance


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


# --------------------------------------------------------------------------------------------


@dataclass
class RunRecord:
    """What a planning run produced: one row per rollout, one best trajectory per iteration."""

    rollouts: pd.DataFrame
    best_paths: pd.DataFrame
    success_iteration: int | None
    stop_reason: str
    seeds: dict[str, int]
    seconds: float
    rollout_seconds: float

    @property
    def succeeded(self) -> bool:
        return self.success_iteration is not None


ROLLOUT_COLUMNS: dict[str, tuple[str, str]] = {
    "iteration": ("1", "iteration i (1-based)"),
    "rollout": ("1", "rollout index within the iteration"),
    "cost": ("1", "inner cost J_inn (eq. 11); NaN for diverged rollouts"),
    "cost_regularization": ("1", "α1‖W‖² (eq. 11)"),
    "cost_spring_energy": ("1", "α2 Σ E_RP (eq. 11)"),
    "cost_hole_distance": ("1", "α3 Σ δq̃ᵀΣ_H⁻¹δq̃ (eq. 11)"),
    "sensed_hole_x_m": ("m", "sensed hole x̃_H of this iteration (eq. 16b)"),
    "sensed_hole_y_m": ("m", "sensed hole y (exact)"),
    "sensed_hole_theta_rad": ("rad", "sensed hole θ (exact)"),
    "goal_x_m": ("m", "DMP goal q_R(T), x"),
    "goal_y_m": ("m", "DMP goal q_R(T), y"),
    "goal_theta_rad": ("rad", "DMP goal q_R(T), θ"),
    "final_bottom_x_m": ("m", "peg tip P2 at the end, x"),
    "final_bottom_y_m": ("m", "peg tip P2 at the end, y"),
    "final_bottom_theta_rad": ("rad", "peg tip P2 at the end, θ"),
    "final_hole_error_m": ("m", "true |P2 − H| (x, y) at the end"),
    "success": ("1", "final_hole_error_m <= success_tolerance_m and not diverged"),
    "is_best": ("1", "lowest cost of its iteration"),
    "status": ("", "ok or diverged"),
    "reason": ("", "why the rollout diverged"),
    "sigma": ("1", "optimizer exploration scale σ_W when sampled"),
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

Progress = Callable[[int, float, bool], None]


class Planner:
    """Algorithm 1 on one scene. The scene (and its Drake diagram) is reused by every rollout."""

    def __init__(self, scene: PegInHoleScene, config: PlannerConfig) -> None:
        config.validate()
        self.scene = scene
        self.config = config
        hole = scene.config.hole
        self.start_bottom = np.array([config.start_x_m, hole.top_y_m + config.start_height_m, 0.0])
        self.start_robot = scene.peg_top_from_bottom(self.start_bottom)
        duration = config.dmp.duration_s + config.settle_s
        step = scene.config.solver.time_step_s
        self.times_s = np.arange(0.0, duration + 0.5 * step, step)
        every = max(1, round(config.costs.sample_period_s / step))
        self.cost_samples = slice(0, None, every)

    @classmethod
    def from_configs(cls, scene: SceneConfig, config: PlannerConfig) -> Planner:
        """A planner on a new scene. The planner never reads contact-patch counts, so the scene
        skips that per-step callback."""
        return cls(PegInHoleScene(scene.replace(solver__log_contact_patches=False)), config)

    @property
    def seeds(self) -> dict[str, int]:
        """The run's seeds: the sensed-hole generator's and the optimizer's (derived)."""
        cfg = self.config
        exploration = np.random.SeedSequence([cfg.optimizer.seed, cfg.seed]).generate_state(1)[0]
        return {"noise": cfg.seed, "exploration": int(exploration)}

    def sense_hole(self, rng: np.random.Generator) -> NDArray[np.float64]:
        """q̃_H = [N(x_H + μ_x, σ_x²), y_H, θ_H] (eq. 16b)."""
        truth = self.scene.hole_pose
        sensing = self.config.sensing
        return np.array([rng.normal(truth[0] + sensing.bias_m, sensing.std_m), truth[1], truth[2]])

    def evaluate(
        self, dmp: Dmp, weights: NDArray[np.float64], sensed_hole: NDArray[np.float64]
    ) -> tuple[Trace, CostTerms | None]:
        """One rollout: DMP → simulator → J_inn (None if the simulation diverged)."""
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

    def run(self, progress: Progress | None = None) -> RunRecord:
        cfg = self.config
        seeds = self.seeds
        rng = np.random.default_rng(seeds["noise"])
        optimizer = make_optimizer(
            dataclasses.replace(cfg.optimizer, seed=seeds["exploration"]),
            np.zeros(3 * cfg.dmp.n_basis),
        )
        stop_reason = f"iteration budget ({cfg.iterations})"
        best_costs: list[float] = []
        hole_xy = self.scene.hole_pose[:2]
        rows: list[dict] = []
        paths: list[pd.DataFrame] = []
        explored: NDArray[np.float64] | None = None
        success_iteration: int | None = None
        rollout_seconds = 0.0
        started = time.perf_counter()
        for iteration in range(1, cfg.iterations + 1):
            sensed = self.sense_hole(rng)
            target = (
                sensed
                if cfg.method == "one_level" or explored is None
                else outer_goal(explored, sensed, cfg.sensing)
            )
            dmp = Dmp(cfg.dmp, self.start_robot, self.scene.peg_top_from_bottom(target))
            sigma = optimizer.sigma
            samples = optimizer.ask()
            costs = np.full(len(samples), np.nan)
            traces: list[Trace] = []
            for r, weights in enumerate(samples):
                t0 = time.perf_counter()
                trace, terms = self.evaluate(dmp, weights, sensed)
                rollout_seconds += time.perf_counter() - t0
                traces.append(trace)
                final = trace.q_peg_bottom[-1] if len(trace) else np.full(3, np.nan)
                error = float(np.hypot(*(final[:2] - hole_xy)))
                costs[r] = terms.total if terms else np.nan
                rows.append(
                    {
                        "iteration": iteration,
                        "rollout": r,
                        "cost": costs[r],
                        "cost_regularization": terms.regularization if terms else np.nan,
                        "cost_spring_energy": terms.spring_energy if terms else np.nan,
                        "cost_hole_distance": terms.hole_distance if terms else np.nan,
                        **_pose_columns("sensed_hole", sensed),
                        **_pose_columns("goal", dmp.goal),
                        **_pose_columns("final_bottom", final),
                        "final_hole_error_m": error,
                        "success": bool(trace.ok and error <= cfg.success_tolerance_m),
                        "is_best": False,
                        "status": trace.status,
                        "reason": trace.reason,
                        "sigma": sigma,
                    }
                )
            optimizer.tell(samples, costs)
            ok = [t for t in traces if t.ok]
            explored = (
                np.vstack([t.q_peg_bottom[self.cost_samples] for t in ok]) if ok else explored
            )
            best = int(np.nanargmin(costs)) if np.any(np.isfinite(costs)) else 0
            rows[-len(samples) + best]["is_best"] = True
            paths.append(_best_path(iteration, traces[best]))
            best_success = rows[-len(samples) + best]["success"]
            if best_success and success_iteration is None:
                success_iteration = iteration
            if progress:
                progress(iteration, float(costs[best]), bool(best_success))
            best_costs.append(float(costs[best]))
            if self._converged(best_costs):
                stop_reason = f"converged at iteration {iteration}"
                break
        return RunRecord(
            rollouts=pd.DataFrame(rows)[list(ROLLOUT_COLUMNS)],
            best_paths=pd.concat(paths, ignore_index=True)[list(PATH_COLUMNS)],
            success_iteration=success_iteration,
            stop_reason=stop_reason,
            seeds=seeds,
            seconds=time.perf_counter() - started,
            rollout_seconds=rollout_seconds,
        )

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
