"""The planner's configuration (paper Table 4 and §3.3): :class:`PlannerConfig` and its
sections, validated; :func:`replace` for validated changes. No Drake: building a study's job
graph reads these without loading the simulator. The code that uses them: :mod:`pih.planning.costs`
(eq. 11), :mod:`pih.planning.outer` (eq. 15–16), :mod:`pih.planning.planner` (Algorithm 1). docs/planner.md
explains the choices.
"""

from __future__ import annotations

import copy
import dataclasses
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Literal, get_args

import numpy as np
from numpy.typing import NDArray

from pih.config import described, recorded_config, require, require_finite, require_positive
from pih.planning.dmp import DmpConfig
from pih.planning.optimizers import OptimizerConfig
from pih.scene.config import ContactModel

Goal = Literal[
    "sensed_hole",
    "mean_sensed_hole",
    "calibrated_mean_sensed_hole",
    "explored_argmin",
    "deepest_explored",
]
ONE_LEVEL: Goal = "sensed_hole"
"""The goal of one-level planning as the paper has it: each fresh sensing."""
STABLE_GOALS: tuple[str, ...] = ("mean_sensed_hole", "calibrated_mean_sensed_hole")
"""One-level with a stable goal: the mean of the run's sensings (docs/planner.md)."""
ONE_LEVEL_GOALS: tuple[str, ...] = (ONE_LEVEL, *STABLE_GOALS)
OUTER_RULES: tuple[str, ...] = ("explored_argmin", "deepest_explored")
"""Bilevel's outer rules (planner.outer)."""
GOALS: tuple[str, ...] = (*ONE_LEVEL_GOALS, *OUTER_RULES)


Balance = Literal["none", "first_iteration_median"]
Redraw = Literal["per_iteration", "per_run"]
GoalTilt = Literal["explored", "sensed"]
DeployPolicy = Literal["final_mean", "last_inserted_mean"]
SimulatedHole = Literal["true_hole", "sensed_per_run", "sensed_per_iteration"]
SIMULATED_HOLES: tuple[str, ...] = ("true_hole", "sensed_per_run", "sensed_per_iteration")
DEPLOY_POLICIES: tuple[str, ...] = ("final_mean", "last_inserted_mean")
COST_TERMS: tuple[str, ...] = ("regularization", "spring_energy", "hole_distance")
MAX_START_HEIGHT_M = 0.15
"""Highest start allowed above the hole's top surface (the paper's Fig. 8 starts ≈0.1 m up)."""


@dataclass(frozen=True)
class CostConfig:
    """Weights of eq. 11 (paper Table 4), the sampling of its sums, and their balance."""

    regularization: float = described(1.0e4, "α1, the weight of ‖W‖² in eq. 11 (Table 4)")
    spring_energy: float = described(
        20.0, "α2, the weight of the spring energy in eq. 11 (Table 4)"
    )
    hole_distance: float = described(
        10.0, "α3, the weight of the distance to the sensed hole in eq. 11 (Table 4)"
    )
    # So that the weights' balance does not change with the simulator's time step.
    sample_period_s: float = described(
        0.01, "the sums over t in eq. 11 run over samples this far apart (not in the paper)"
    )
    include_settling: bool = described(
        True, "whether the sums also run over the settling time after the DMP's duration T"
    )
    # first_iteration_median makes the terms start at the similar sizes the paper asks for (§3.3).
    balance: Balance = described(
        "none",
        "none: eq. 11 as printed; first_iteration_median: each term is divided by its median "
        "over the first iteration's rollouts (then weighted by α), divisors fixed after "
        "iteration 1",
    )

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
    """Visual noise on the hole's pose (paper §3.2: x only) and the belief Σ_H of eq. 11 and 15."""

    bias_m: float = described(0.005, "μ_x, the bias of the sensed hole's x (Table 4)")
    std_m: float = described(0.005, "σ_x, the standard deviation of the sensed hole's x (Table 4)")
    # The paper senses y_H and θ_H exactly (eq. 16b); these ask what noise on them costs.
    y_std_m: float = described(
        0.0, "standard deviation of the sensed hole's depth y_H; 0: exact, the paper (eq. 16b)"
    )
    theta_std_rad: float = described(
        0.0, "standard deviation of the sensed hole's tilt θ_H; 0: exact, the paper (eq. 16b)"
    )
    # What the outer level explores and what judges a mean's insertion (last_inserted_mean) are
    # observations of the peg tip; the costs read the simulator's.
    tip_std_m: float = described(
        0.0,
        "standard deviation of the observed peg-tip pose P2 in x and y, each 10 ms sample "
        "independently: the outer level's explored poses and the depth that judges a mean's "
        "insertion; 0: exact (not in the paper)",
    )
    # x: the vision noise σ_x; y and θ are sensed exactly (eq. 16b), so their belief is tight:
    # 1 mm and 0.02 rad (with a loose θ belief the outer level picks tilted explored poses, and a
    # tilted goal jams the peg in the hole). A tight y makes J_out prefer explored poses at the
    # hole's depth over poses beside it.
    hole_std: tuple[float, float, float] = described(
        (0.005, 0.001, 0.02),
        "the belief Σ_H = diag(std²) of eq. 11 and 15, for (x m, y m, θ rad) (not in the paper)",
    )
    redraw: Redraw = described(
        "per_iteration",
        "per_iteration: the hole is sensed anew every iteration (Algorithm 1, Fig. 6); "
        "per_run: once per run",
    )

    def validate(self, prefix: str = "") -> None:
        require_finite(prefix + "bias_m", self.bias_m)
        require(
            math.isfinite(self.std_m) and self.std_m >= 0,
            prefix + "std_m",
            "a finite std >= 0 m",
            self.std_m,
        )
        for key, unit in (("y_std_m", "m"), ("theta_std_rad", "rad"), ("tip_std_m", "m")):
            std = getattr(self, key)
            require(math.isfinite(std) and std >= 0, prefix + key, f"a finite std >= 0 {unit}", std)
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
    """Settings of bilevel's outer rules (``planner.goal``, eq. 15–16); see docs/planner.md."""

    goal_tilt: GoalTilt = described(
        "explored",
        "the paper's rule's goal tilt: the chosen explored pose's (explored) or θ_H (sensed)",
    )
    entry_depth_m: float = described(
        0.001,
        "deepest_explored: how far below the top surface counts as inside the chamfer or hole, "
        "for a peg within max_tilt_rad of upright",
    )
    # A steeply tilted peg can dip its tip centre into the chamfer from beside the hole.
    max_tilt_rad: float = described(
        0.05, "deepest_explored: the largest tilt from upright of a peg that counts as inside"
    )

    def validate(self, prefix: str = "") -> None:
        require_positive(self, ("entry_depth_m", "max_tilt_rad"), prefix)


@dataclass(frozen=True)
class SimulatorConfig:
    """The planner's own simulator: where the scene its training rollouts (sampled and mean) run
    on differs from the real ``scene``, beyond the hole (``planner.simulated_hole``). Deployment
    trials and redeployments always run on the real scene; the rollout's time grid is the real
    scene's step (docs/planner.md, "The planner's own simulator")."""

    # The paper's thesis (its abstract): point contact's sim-to-real gap is why planning needs
    # hydroelastic contact. Training in point contact and deploying on the hydroelastic scene
    # tests it.
    contact_model: ContactModel | None = described(
        None,
        "Drake's contact model of the training simulator (the levels of "
        "scene.solver.contact_model); null: the real scene's",
    )
    point_stiffness_n_per_m: float | None = described(
        None,
        "the training simulator's point-contact stiffness (as "
        "scene.material.point_stiffness_n_per_m); null: the real scene's",
    )

    def validate(self, prefix: str = "") -> None:
        model = self.contact_model
        models = get_args(ContactModel)
        allowed = f"one of {list(models)} or null"
        require(model is None or model in models, prefix + "contact_model", allowed, model)
        stiffness = self.point_stiffness_n_per_m
        require(
            stiffness is None or (math.isfinite(stiffness) and stiffness > 0),
            prefix + "point_stiffness_n_per_m",
            "a finite value > 0 or null",
            stiffness,
        )

    def check_scene(self, scene_contact_model: str, prefix: str = "planner.simulator.") -> None:
        """Refuse a setting that would change nothing on the study's real scene of this contact
        model: labelled runs that trained on the real scene after all. A study's check, not the
        planner's: a redeployment on a model error may run on the simulator's own scene."""
        model = self.contact_model or scene_contact_model
        require(
            self.point_stiffness_n_per_m is None or model != "hydroelastic",
            prefix + "point_stiffness_n_per_m",
            f"null while the training contact model is hydroelastic (set {prefix}contact_model: "
            "point, or leave the stiffness null)",
            self.point_stiffness_n_per_m,
        )
        require(
            self.contact_model is None or self.contact_model != scene_contact_model,
            prefix + "contact_model",
            f"null or another model than the scene's own ({scene_contact_model})",
            self.contact_model,
        )

    @property
    def scene_changes(self) -> dict[str, object]:
        """The training simulator's differences from the real scene, as ``SceneConfig.replace``
        takes them (``section__field``)."""
        changes = {
            "solver__contact_model": self.contact_model,
            "material__point_stiffness_n_per_m": self.point_stiffness_n_per_m,
        }
        return {key: value for key, value in changes.items() if value is not None}


@dataclass(frozen=True)
class PlannerConfig:
    """The planner (paper Table 4, §3.3; docs/planner.md): method, start, budget, deployment."""

    goal: Goal = described(
        "explored_argmin",
        "the DMP's goal q_R(T), which names the method: sensed_hole (one-level: each fresh "
        "sensing q̃_H, the paper); mean_sensed_hole (one-level with a stable goal: in training "
        "the mean of the run's sensings so far, deployed at the mean of all of them, reading no "
        "fresh sensing); calibrated_mean_sensed_hole (the same less the known bias "
        "sensing.bias_m in x); bilevel's outer level (planner.outer) with explored_argmin (the paper's rule, "
        "arg min J_out over the peg-tip poses P2 explored by the previous iteration, eq. 15–16) "
        "or deepest_explored (ours: once some rollout has put P2 more than entry_depth_m below "
        "the hole's top surface with the peg within max_tilt_rad of the hole's axis, aim along "
        "that axis: x of the deepest such P2 so far, the sensed depth y_H and tilt θ_H; before "
        "that the paper's rule)",
    )
    iterations: int = described(50, "training iterations (Table 4, §3.3)")
    start_x_m: float = described(
        -0.035, "x of the peg centre at the start (paper §3.3: x_P from −0.04 to −0.03 m)"
    )
    # 5 mm clears the surface so the first contact is made by the planned motion (Fig. 8: ≈0.1 m).
    start_height_m: float = described(
        0.005,
        "height of the peg tip P2 above the hole's top surface at the start (not in the paper)",
    )
    # 0.3 s is ~2 periods of the peg on the 1000 N/m spring.
    settle_s: float = described(
        0.3,
        "extra simulated time after the DMP's duration T, so the peg settles before success is "
        "judged (not in the paper)",
    )
    # 1 mm is well inside the hole (the chamfer alone is 2.5 mm deep) and tighter than the 5 mm
    # visual noise.
    success_tolerance_m: float = described(
        0.001, "success: |P2 − H| (x, y) at the end at most this (not in the paper)"
    )
    seed: int = described(
        0,
        "the run's seed: with optimizer.seed and the run's sweep levels (all but the method's), "
        "it seeds the sensed holes, the exploration noise and the deployment trials "
        "(pih.planning.planner.run_seeds)",
    )
    deploy_trials: int = described(
        10,
        "after the last iteration, the learned policy (mean weights, no exploration) is deployed "
        "this many times, each against a freshly sensed hole: the headline success metric",
    )
    # With last_inserted_mean the final mean is deployed too, on the same sensed holes (phase
    # ``deploy_final_mean``), so one training run measures both policies.
    deploy_policy: DeployPolicy = described(
        "last_inserted_mean",
        "which weights are deployed: the optimizer's mean after the last iteration (final_mean), "
        "or, evaluating the mean once per iteration as dmpbbo does, the latest mean whose "
        "rollout inserted by the planner's own observation, else the final mean "
        "(last_inserted_mean)",
    )
    # Without it a bilevel policy whose goal does not depend on the sensed hole deploys the same
    # rollout every trial; with it, the trials ask whether the policy tolerates a start the
    # robot reaches only to within σ.
    deploy_start_std_m: float = described(
        0.0,
        "each deployment trial starts the peg tip this far off the training start, x and y each "
        "N(0, σ²) from the deployment stream; 0: every trial starts where training did (not in "
        "the paper)",
    )
    # The optimizer then ranks weights by how they do from starts the robot reaches only to
    # within σ.
    train_start_std_m: float = described(
        0.0,
        "each training rollout (sampled and the evaluated mean) starts this far off the nominal "
        "start, x and y each N(0, σ²) from the run's start stream: robust training; 0: every "
        "training rollout starts at the nominal start, Algorithm 1 (not in the paper)",
    )
    # Beyond the paper (docs/planner.md, "Planning on the sensed hole"): a robot plans in a
    # simulator built from what its camera saw, then acts on the real hole.
    simulated_hole: SimulatedHole = described(
        "true_hole",
        "where the training rollouts' simulator puts the hole: true_hole (the real hole, the "
        "paper), sensed_per_run (at the run's first sensed pose q̃_H) or sensed_per_iteration "
        "(at each iteration's q̃_H: planning over a distribution of holes); deployment trials "
        "always run on the real hole",
    )
    # 0 by default: the paper's bands compare runs over the same iterations.
    convergence_window: int = described(
        0,
        "stop early when the best J_inn of the last this many iterations varies by less than "
        "convergence_tolerance relative to its mean; 0: run the whole budget",
    )
    convergence_tolerance: float = described(
        0.01, "the relative variation of the early stop (convergence_window)"
    )
    # T = 3 s (not in the paper): 3.3 s simulated per rollout with the settling time.
    dmp: DmpConfig = field(default_factory=DmpConfig)
    optimizer: OptimizerConfig = field(default_factory=OptimizerConfig)
    costs: CostConfig = field(default_factory=CostConfig)
    sensing: SensingConfig = field(default_factory=SensingConfig)
    outer: OuterConfig = field(default_factory=OuterConfig)
    simulator: SimulatorConfig = field(default_factory=SimulatorConfig)

    def validate(self, prefix: str = "") -> None:
        require(self.goal in GOALS, prefix + "goal", f"one of {list(GOALS)}", self.goal)
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
            self.simulated_hole in SIMULATED_HOLES,
            prefix + "simulated_hole",
            f"one of {list(SIMULATED_HOLES)}",
            self.simulated_hole,
        )
        require(
            self.simulated_hole == "true_hole" or self.sensing.theta_std_rad == 0,
            prefix + "sensing.theta_std_rad",
            f"0 when {prefix}simulated_hole is {self.simulated_hole!r} (the simulated hole "
            "cannot tilt)",
            self.sensing.theta_std_rad,
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
        self.simulator.validate(prefix + "simulator.")


def is_one_level(goal: str) -> bool:
    """Whether a goal is one-level's (no outer level: it ignores ``planner.outer``)."""
    return goal in ONE_LEVEL_GOALS


def method_label(goal: str) -> str:
    """The method a goal names, as tables label it: ``one_level`` (the paper's),
    ``one_level/<stable goal>`` or ``bilevel/<outer rule>``."""
    if goal == ONE_LEVEL:
        return "one_level"
    return f"one_level/{goal}" if is_one_level(goal) else f"bilevel/{goal}"


def stable_goal(
    goal: str, sensings: list[NDArray[np.float64]], sensing: SensingConfig
) -> NDArray[np.float64]:
    """A stable goal (:data:`STABLE_GOALS`): the mean of ``sensings``, less the known bias μ_x
    in x when calibrated."""
    mean = np.mean(sensings, axis=0)
    if goal == "calibrated_mean_sensed_hole":
        mean[0] -= sensing.bias_m
    return mean


def upgraded(planner: Mapping[str, Any]) -> dict[str, Any]:
    """A recorded ``planner`` section in today's keys: records from before ``planner.goal``
    name the method with ``method`` (one_level, bilevel) and ``outer.rule``."""
    planner = copy.deepcopy(dict(planner))
    if "method" in planner:
        method = planner.pop("method")
        rule = (planner.get("outer") or {}).pop("rule", "explored_argmin")
        planner["goal"] = ONE_LEVEL if method == "one_level" else rule
    return planner


def recorded_planner(config: Mapping[str, Any]) -> PlannerConfig:
    """The ``planner`` section of a recorded config (a provenance record's), keys the run
    predates read as their defaults, old method keys :func:`upgraded`."""
    return recorded_config(PlannerConfig, {"planner": upgraded(config["planner"])}, "planner")


def replace(config: PlannerConfig, **changes: object) -> PlannerConfig:
    """dataclasses.replace with validation."""
    new = dataclasses.replace(config, **changes)
    new.validate()
    return new
