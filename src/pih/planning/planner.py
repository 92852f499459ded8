"""DMP + black-box-optimization insertion planner, one-level and bilevel (paper §3, Algorithm 1).

Each iteration i:

1. **Sense** the hole: x̃_H ~ N(x_H + μ_x, σ_x²), y_H and θ_H exact (eq. 16b; or noisy with
   ``sensing.y_std_m``, ``theta_std_rad``), drawn from the run's seeded generator: anew every
   iteration (Algorithm 1) or once per run (``sensing.redraw``); the same for all of that
   iteration's rollouts.
2. **Goal** q_R(T) of the DMP. The robot frame R rests on the peg top P1, so "put the peg tip
   P2 at pose q" means q_R(T) = q_P1 of the peg whose P2 is at q (the frame offset of eq. 4–5).
   *One-level*: q = q̃_H. *Bilevel*: the outer level (:mod:`pih.planning.outer`); the paper's rule is
   q = arg min J_out(q_P2, q̃_H) (eq. 15–16) over Q_P, the P2 poses explored by the previous
   iteration's non-diverged rollouts. In the first iteration both methods use q̃_H (§3.3).
3. **Rollouts**: r weight vectors W ~ N(W*, σ_W) (eq. 12, or CMA-ES) → DMP (eq. A1) →
   simulator (eq. 1) → inner cost J_inn (eq. 11, :mod:`pih.planning.costs`). The simulator has the real
   hole (the paper), or with ``simulated_hole`` the sensed one: the run's first q̃_H, or each
   iteration's.
4. **Update** W* from the costs (eq. 13, or CMA-ES).

After the last iteration the learned policy W* is **deployed** ``deploy_trials`` times, each
against a freshly sensed hole (and, with ``deploy_start_std_m``, from an offset start), with no
exploration noise: the fraction that inserts answers
"would this policy insert if deployed?". A rollout *succeeds* when the true (not sensed) distance
between P2 and the hole frame H at its end is within ``success_tolerance_m``. docs/planner.md
explains the choices. The configuration is :mod:`pih.planning.config`; what a run records,
:mod:`pih.planning.run_record`.
"""

from __future__ import annotations

import dataclasses
import hashlib
import multiprocessing
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass, field
from typing import Self

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from pih.config import require
from pih.planning.config import ONE_LEVEL, STABLE_GOALS, PlannerConfig, stable_goal
from pih.planning.costs import CostBalance, CostTerms, inner_cost
from pih.planning.dmp import Dmp
from pih.planning.optimizers import Optimizer, make_optimizer
from pih.planning.outer import OuterLevel
from pih.planning.run_record import (
    DEPLOYMENT_PHASES,
    ROLLOUT_COLUMNS,
    IterationReport,
    Phase,
    Rollout,
    RunRecord,
    RunRecorder,
    phase_rows,
    recorded_pose,
)
from pih.scene.config import SceneConfig
from pih.scene.simulation import PegInHoleScene
from pih.scene.trace import RobotTrajectory, Trace


def run_seeds(config: PlannerConfig, seed_key: str = "") -> dict[str, int]:
    """The run's independent streams, from ``planner.seed``, ``optimizer.seed`` and the run's
    sweep levels other than the method's (``seed_key``): sensed holes (``noise``), exploration
    noise, deployment trials, training starts (``start``, drawn only when
    ``train_start_std_m`` > 0) and observed tip poses (``observation``, drawn only when
    ``sensing.tip_std_m`` > 0). Runs that differ only in method share them (common random
    numbers); any other difference gives independent streams."""
    words = np.frombuffer(hashlib.sha256(seed_key.encode()).digest(), dtype=np.uint32)
    root = np.random.SeedSequence([config.seed, config.optimizer.seed, *words.tolist()])
    # Spawned children depend only on their index, so adding a stream keeps the others.
    names = ("noise", "exploration", "deployment", "start", "observation")
    return {name: int(c.generate_state(1)[0]) for name, c in zip(names, root.spawn(len(names)))}


@dataclass(frozen=True)
class Streams:
    """The generators Algorithm 1 draws from during training (:func:`run_seeds`)."""

    noise: np.random.Generator
    start: np.random.Generator
    observation: np.random.Generator

    @classmethod
    def of(cls, seeds: dict[str, int]) -> Streams:
        return cls(
            *(np.random.default_rng(seeds[name]) for name in ("noise", "start", "observation"))
        )


@dataclass
class Training:
    """A run's learning state: the optimizer (W*), bilevel's outer level, the cost balance, the
    record so far, the mean that last inserted (``last_inserted_mean``) and why training
    stopped."""

    optimizer: Optimizer
    outer: OuterLevel
    balance: CostBalance
    recorder: RunRecorder
    evaluates_mean: bool
    stop_reason: str
    started: float = field(default_factory=time.perf_counter)
    iterations: int = 0
    rollout_seconds: float = 0.0
    sigma: float = 0.0
    samples: NDArray[np.float64] = field(default_factory=lambda: np.empty((0, 0)))
    inserted_mean: NDArray[np.float64] | None = None
    inserted_iteration: int | None = None
    sensings: list[NDArray[np.float64]] = field(default_factory=list)
    """every sensing of the hole so far (a stable goal is their mean)"""

    @classmethod
    def start(cls, planner: Planner) -> Training:
        cfg = planner.config
        optimizer = make_optimizer(
            dataclasses.replace(cfg.optimizer, seed=planner.seeds["exploration"]),
            np.zeros(3 * cfg.dmp.n_basis),
        )
        hole = planner.scene.hole_pose
        return cls(
            optimizer=optimizer,
            outer=OuterLevel(cfg, planner.scene.config.hole.depth_m, hole[2]),
            balance=CostBalance(cfg.costs),
            recorder=RunRecorder(hole, cfg.success_tolerance_m, planner.scene),
            evaluates_mean=cfg.deploy_policy == "last_inserted_mean",
            stop_reason=f"iteration budget ({cfg.iterations})",
        )

    def evaluate(
        self, rollouts: RolloutWorkers, batch: list[Rollout]
    ) -> list[tuple[Trace, CostTerms | None]]:
        """The batch's (trace, J_inn terms), timed."""
        t0 = time.perf_counter()
        results = rollouts.evaluate(batch)
        self.rollout_seconds += time.perf_counter() - t0
        return results

    def report(self, iteration: int, iterations: int) -> IterationReport:
        return self.recorder.report(iteration, iterations, time.perf_counter() - self.started)


class Planner:
    """Algorithm 1 on one scene, the real one. The scene (and its Drake diagram) is reused by
    every rollout; training rollouts run on the planner's own simulator where it differs
    (``planner.simulator``, ``simulated_hole``): a copy of the scene with its contact model and
    the hole at a sensed pose (the latest such copy is kept)."""

    def __init__(self, scene: PegInHoleScene, config: PlannerConfig, seed_key: str = "") -> None:
        config.validate()
        self.scene = scene
        self._training: tuple[bytes, PegInHoleScene] | None = None
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
        """q̃_H = [N(x_H + μ_x, σ_x²), y_H, θ_H] (eq. 16b); y_H and θ_H drawn around the truth
        only when ``sensing.y_std_m`` / ``theta_std_rad`` > 0 (the x stream is unchanged)."""
        truth = self.scene.hole_pose
        sensing = self.config.sensing
        sensed = np.array([rng.normal(truth[0] + sensing.bias_m, sensing.std_m), *truth[1:]])
        for axis, std in ((1, sensing.y_std_m), (2, sensing.theta_std_rad)):
            if std > 0:
                sensed[axis] = rng.normal(truth[axis], std)
        return sensed

    @property
    def training_scene_config(self) -> SceneConfig:
        """The scene of the planner's own simulator, the hole aside: the real scene with
        ``planner.simulator``'s changes (its contact model)."""
        changes = self.config.simulator.scene_changes
        return self.scene.config.replace(**changes) if changes else self.scene.config

    def scene_for(self, simulated_hole: NDArray[np.float64] | None) -> PegInHoleScene:
        """The scene a rollout simulates: the real one (``simulated_hole`` None: deployment), or
        the training simulator (:attr:`training_scene_config`) with the hole frame H at that
        pose's x and y; the real scene itself where that is no different."""
        if simulated_hole is None:
            return self.scene
        changes = self.config.simulator.scene_changes
        if not changes and np.array_equal(simulated_hole, self.scene.hole_pose):
            return self.scene
        key = np.asarray(simulated_hole, float).tobytes()
        if self._training is None or self._training[0] != key:
            config = self.scene.config.replace(
                **changes, hole__x_m=float(simulated_hole[0]), hole__y_m=float(simulated_hole[1])
            )
            self._training = (key, PegInHoleScene(config))
        return self._training[1]

    def simulated_hole(
        self, sensed: NDArray[np.float64], first_sensed: NDArray[np.float64]
    ) -> NDArray[np.float64] | None:
        """Where a training rollout's simulator puts the hole (``simulated_hole``); None: the
        real scene itself (the real hole, and no ``planner.simulator`` change)."""
        mode = self.config.simulated_hole
        if mode == "true_hole":
            return self.scene.hole_pose.copy() if self.config.simulator.scene_changes else None
        return (first_sensed if mode == "sensed_per_run" else sensed).copy()

    def dmp(self, start: NDArray[np.float64], target: NDArray[np.float64]) -> Dmp:
        """The DMP from the P1 pose of the peg whose tip P2 is at ``start`` to q_R(T), the P1 pose
        of the peg whose tip is at ``target``."""
        top = self.scene.peg_top_from_bottom
        return Dmp(self.config.dmp, top(start), top(target))

    def evaluate_rollout(self, rollout: Rollout) -> tuple[Trace, CostTerms | None]:
        """:meth:`evaluate` of a :class:`Rollout`, on the scene of its simulated hole."""
        dmp = self.dmp(rollout.start, rollout.target)
        return self.evaluate(dmp, rollout.weights, rollout.sensed_hole, rollout.simulated_hole)

    def evaluate(
        self,
        dmp: Dmp,
        weights: NDArray[np.float64],
        sensed_hole: NDArray[np.float64],
        simulated_hole: NDArray[np.float64] | None = None,
    ) -> tuple[Trace, CostTerms | None]:
        """One rollout: DMP → simulator (:meth:`scene_for` ``simulated_hole``) → J_inn's terms
        (None if the simulation diverged)."""
        poses, _ = dmp.rollout(weights, self.times_s)
        trace = self.scene_for(simulated_hole).rollout(RobotTrajectory(self.times_s, poses))
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

    def inserted(
        self,
        trace: Trace,
        sensed_hole: NDArray[np.float64],
        observed_tip: NDArray[np.float64] | None = None,
    ) -> bool:
        """Whether a rollout ended with the peg in the hole, as the planner can observe it: the
        (observed) tip within ``success_tolerance_m`` of the sensed depth y_H (exact, eq. 16b).
        Only a peg inside the hole gets there; the top surface is a hole depth above."""
        tip = trace.q_peg_bottom[-1] if observed_tip is None else observed_tip
        return bool(trace.ok and tip[1] <= sensed_hole[1] + self.config.success_tolerance_m)

    def observed_tips(
        self, poses: NDArray[np.float64], rng: np.random.Generator
    ) -> NDArray[np.float64]:
        """P2 poses as the planner observes them: with N(0, tip_std_m²) added to x and y of
        each when ``sensing.tip_std_m`` > 0 (drawn from ``rng``; no draw otherwise)."""
        tips = np.array(poses, dtype=float, copy=True)
        std = self.config.sensing.tip_std_m
        if std > 0:
            tips[..., :2] += rng.normal(0.0, std, tips[..., :2].shape)
        return tips

    def target(self, training: Training, sensed: NDArray[np.float64]) -> NDArray[np.float64]:
        """One-level aims at the sensed hole, or with a stable goal at the mean of the run's
        sensings so far; bilevel where its outer level says."""
        goal = self.config.goal
        if goal == ONE_LEVEL:
            return sensed.copy()
        if goal in STABLE_GOALS:
            return stable_goal(goal, training.sensings, self.config.sensing)
        return training.outer.goal(sensed)

    def run(
        self, progress: Callable[[IterationReport], None] | None = None, workers: int = 1
    ) -> RunRecord:
        """Algorithm 1 (:meth:`train`), then the deployment trials of the learned policy
        (:meth:`deploy`). With ``workers`` > 1 an iteration's rollouts run in that many
        processes (:class:`RolloutWorkers`); the record is the same for any number of workers."""
        started = time.perf_counter()
        with RolloutWorkers(self, workers) as rollouts:
            training = self.train(rollouts, progress)
            return self.deploy(rollouts, training, started)

    def train(
        self,
        rollouts: RolloutWorkers,
        progress: Callable[[IterationReport], None] | None = None,
    ) -> Training:
        """Algorithm 1: each iteration senses the hole, sets the goal, evaluates a batch of
        rollouts and learns from it, until the budget or convergence."""
        cfg = self.config
        training = Training.start(self)
        streams = Streams.of(self.seeds)
        sensed = first_sensed = self.sense_hole(streams.noise)
        training.sensings.append(sensed)
        for iteration in range(1, cfg.iterations + 1):
            # 1. Sense the hole: anew each iteration (Algorithm 1) or once per run.
            if iteration > 1 and cfg.sensing.redraw == "per_iteration":
                sensed = self.sense_hole(streams.noise)
                training.sensings.append(sensed)
            # 2. The DMP's goal: the sensed hole (one-level) or the outer level's (eq. 15–16).
            target = self.target(training, sensed)
            # 3. Rollouts W ~ N(W*, σ_W) (eq. 12) through the simulator, with their J_inn (eq. 11).
            batch = self.training_batch(training, target, sensed, first_sensed, streams.start)
            results = training.evaluate(rollouts, batch)
            # 4. Update W* (eq. 13) and what the outer level has explored.
            self.learn(training, iteration, batch, results, streams.observation)
            if progress:
                progress(training.report(iteration, cfg.iterations))
            if self._converged(training.recorder.best_costs):
                training.stop_reason = f"converged at iteration {iteration}"
                break
        return training

    def training_batch(
        self,
        training: Training,
        target: NDArray[np.float64],
        sensed: NDArray[np.float64],
        first_sensed: NDArray[np.float64],
        start_rng: np.random.Generator,
    ) -> list[Rollout]:
        """One iteration's rollouts: ``population_size`` samples of W, and with
        ``last_inserted_mean`` the mean W* itself last."""
        simulated = self.simulated_hole(sensed, first_sensed)
        std = self.config.train_start_std_m
        training.sigma, mean = training.optimizer.sigma, training.optimizer.mean
        training.samples = training.optimizer.ask()
        batch = [
            Rollout(self.offset_start(start_rng, std), target, w, sensed, simulated)
            for w in training.samples
        ]
        # Drawn under every deploy policy, so that the next training starts do not depend on it.
        mean_start = self.offset_start(start_rng, std)
        if training.evaluates_mean:
            batch.append(Rollout(mean_start, target, mean, sensed, simulated))
        return batch

    def learn(
        self,
        training: Training,
        iteration: int,
        batch: list[Rollout],
        results: list[tuple[Trace, CostTerms | None]],
        observation: np.random.Generator,
    ) -> None:
        """Step 4 of an iteration: W* from the samples' costs, the outer level from the
        observed tips, the rows of the record, and the mean's insertion (last_inserted_mean)."""
        n = len(training.samples)
        traces, terms = zip(*results[:n])
        costs = training.balance.totals(list(terms))
        training.optimizer.tell(training.samples, costs)
        k = self.cost_samples
        tips = [self.observed_tips(t.q_peg_bottom[k], observation) for t in traces]
        training.outer.observe(list(traces), k, tips)
        recorder = training.recorder
        recorder.add(Phase.TRAIN, iteration, batch[:n], traces, terms, costs, training.sigma)
        training.iterations = iteration
        if training.evaluates_mean:
            trace, term = results[-1]
            mean_costs = training.balance.totals([term])
            recorder.add(Phase.MEAN, iteration, batch[-1:], [trace], [term], mean_costs, 0.0)
            tip = self.observed_tips(trace.q_peg_bottom[-1], observation)
            if self.inserted(trace, batch[-1].sensed_hole, tip):
                training.inserted_mean, training.inserted_iteration = batch[-1].weights, iteration

    def deploy(self, rollouts: RolloutWorkers, training: Training, started: float) -> RunRecord:
        """The learned policy deployed ``deploy_trials`` times on the real hole (and with
        ``last_inserted_mean`` the final mean beside it, in the same situations); the run's
        record."""
        situations = self.deployment_trials(training)

        def trials(weights: NDArray[np.float64]) -> list[Rollout]:
            return [Rollout(start, target, weights, sensed) for start, target, sensed in situations]

        recorder, balance, iteration = training.recorder, training.balance, training.iterations
        final_mean = training.optimizer.mean
        policy = training.inserted_mean
        deployed = trials(final_mean if policy is None else policy)
        deployed_results = rollouts.evaluate(deployed)
        deploy_rate = recorder.add_deployment(
            Phase.DEPLOY, iteration, deployed, deployed_results, balance
        )
        final_mean_rate = deploy_rate
        if training.evaluates_mean:
            # The final mean in the same situations: the comparison policy, from the same
            # training. It is the deployed one when no evaluated mean inserted.
            final = trials(final_mean)
            final_mean_rate = recorder.add_deployment(
                Phase.DEPLOY_FINAL_MEAN,
                iteration,
                final,
                deployed_results if policy is None else rollouts.evaluate(final),
                balance,
            )
        rows, best_paths = recorder.tables()
        return RunRecord(
            rollouts=rows,
            best_paths=best_paths,
            success_iteration=recorder.success_iteration,
            deploy_success_rate=deploy_rate,
            deployed_iteration=training.inserted_iteration,
            final_mean_deploy_success_rate=final_mean_rate,
            stop_reason=training.stop_reason,
            seeds=self.seeds,
            cost_divisors=balance.divisors.tolist(),
            seconds=time.perf_counter() - started,
            rollout_seconds=training.rollout_seconds,
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

    def deployment_trials(self, training: Training) -> list[tuple[NDArray, NDArray, NDArray]]:
        """The (start, target, sensed hole) of each deployment trial: one-level aims at the
        freshly sensed hole, or with a stable goal at the mean of its training sensings (reading
        no fresh one); bilevel where its outer level puts the goal."""
        return [
            (start, self.target(training, sensed), sensed)
            for start, sensed in self.deployment_draws()
        ]

    def redeployment(
        self, recorded: pd.DataFrame, recorded_hole: NDArray[np.float64] | None = None
    ) -> list[Rollout]:
        """The deployment a run would have made with this planner's ``deploy_start_std_m`` and
        real scene: the recorded trials' policy, targets and sensed holes (rows of one
        deployment phase of its ``rollouts.parquet``, by trial), from the starts this deployment
        stream draws. The holes are drawn before the starts, so the stream must give the
        recorded holes back: a check that this planner has the run's seeds and trial count.

        When this scene's hole sits elsewhere than the run's (``recorded_hole``: model error),
        the camera sees it there: every sensed hole moves with it, and so does one-level's
        target (the sensed hole); bilevel keeps the goal its outer level learned."""
        rows = recorded.sort_values("rollout")
        draws = self.deployment_draws()
        if len(rows) != len(draws):
            raise ValueError(f"{len(rows)} recorded trials, deploy_trials is {len(draws)}")
        shift = np.zeros(3)
        if recorded_hole is not None:
            shift = self.scene.hole_pose - np.asarray(recorded_hole, float)
        trials = []
        for (_, row), (start, sensed) in zip(rows.iterrows(), draws):
            recorded_sensed = recorded_pose(row, "sensed_hole")
            if not np.allclose(sensed - shift, recorded_sensed, rtol=0.0, atol=1e-12):
                raise ValueError(
                    f"trial {row['rollout']}: the deployment stream senses the hole at {sensed}, "
                    f"not where the record does (not the run's seeds)"
                )
            target = recorded_pose(row, "target")
            if self.config.goal == ONE_LEVEL:
                target = target + shift
            weights = np.asarray(row["weights"], float)
            trials.append(Rollout(start, target, weights, sensed))
        return trials

    def redeploy(
        self,
        rollouts: pd.DataFrame,
        cost_divisors: list[float],
        workers: int = 1,
        recorded_hole: NDArray[np.float64] | None = None,
    ) -> pd.DataFrame:
        """The deployment phases of a run's ``rollouts.parquet`` (``deploy``, and
        ``deploy_final_mean`` if recorded) deployed again with this planner's
        ``deploy_start_std_m`` on its scene (:meth:`redeployment`; ``recorded_hole``: the
        run's hole pose when this scene's differs): rows in the same columns, J_inn balanced
        with the run's ``cost_divisors``, success judged on this scene's hole."""
        recorder = RunRecorder(self.scene.hole_pose, self.config.success_tolerance_m, self.scene)
        balance = CostBalance(self.config.costs, cost_divisors)
        done: dict[bytes, list[tuple[Trace, CostTerms | None]]] = {}
        with RolloutWorkers(self, workers) as pool:
            for phase in DEPLOYMENT_PHASES:
                recorded = phase_rows(rollouts, phase)
                if recorded.empty:
                    continue
                trials = self.redeployment(recorded, recorded_hole)
                # Both phases deploy one policy in the same situations when no mean inserted.
                policy = np.asarray(trials[0].weights).tobytes()
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


class RolloutWorkers:
    """Evaluates a planner's rollouts in this process, or in ``workers`` processes that each
    build the same scene once (one Drake diagram per process). Rollouts are deterministic
    given the :class:`Rollout`, and results come back in order, so the run does not depend on
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
            return [self.planner.evaluate_rollout(rollout) for rollout in rollouts]
        return list(self._pool.map(_evaluate_in_worker, rollouts))


_WORKER_PLANNER: Planner | None = None


def _start_worker(scene: SceneConfig, config: PlannerConfig) -> None:
    global _WORKER_PLANNER
    _WORKER_PLANNER = Planner(PegInHoleScene(scene), config)


def _evaluate_in_worker(rollout: Rollout) -> tuple[Trace, CostTerms | None]:
    assert _WORKER_PLANNER is not None
    return _WORKER_PLANNER.evaluate_rollout(rollout)
