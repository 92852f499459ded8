"""Costs (eq. 11, 15), the outer level, sensing, and Algorithm 1's bookkeeping."""

import dataclasses
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pih.config import ConfigError, from_mapping, to_mapping
from pih.planning.config import CostConfig, OuterConfig, PlannerConfig, SensingConfig, replace
from pih.planning.costs import CostBalance, CostTerms, hole_distance, inner_cost
from pih.planning.dmp import DmpConfig
from pih.planning.optimizers import OptimizerConfig
from pih.planning.outer import CLEAN_OVERLAP_M, OuterLevel, outer_goal
from pih.planning.planner import Planner, run_seeds
from pih.planning.run_record import recorded_rollout
from pih.scene.config import SceneConfig
from pih.study.points import seed_key

SENSING = SensingConfig(hole_std=(0.005, 0.001, 0.02))

# Algorithm 1's bookkeeping (seeds, records, workers, deployment) does not depend on the time
# step: these tests run on a 2 ms scene, 4× cheaper than the study's 0.5 ms.
COARSE = SceneConfig().replace(solver__time_step_s=0.002, solver__retry_time_step_s=0.001)


def test_inner_cost_terms_match_eq_11():
    weights = np.array([0.1, -0.2, 0.3])
    q_robot = np.array([[0.0, 0.05, 0.0], [0.01, 0.05, 0.0]])
    q_top = np.array([[0.0, 0.05, 0.0], [0.0, 0.049, 0.01]])
    q_bottom = np.array([[0.0, 0.005, 0.0], [0.002, -0.01, 0.0]])
    sensed = np.array([0.005, -0.01, 0.0])
    terms = inner_cost(
        weights, q_robot, q_top, q_bottom, sensed, (1000.0, 1000.0, 1.0), CostConfig(), SENSING
    )
    assert terms.regularization == pytest.approx(1e4 * 0.14)
    energy = 0.5 * (1000 * 0.01**2 + 1000 * 0.001**2 + 1.0 * 0.01**2)
    assert terms.spring_energy == pytest.approx(20 * energy)
    distance = ((0.005 / 0.005) ** 2 + (0.015 / 0.001) ** 2) + ((0.003 / 0.005) ** 2)
    assert terms.hole_distance == pytest.approx(10 * distance)


def test_outer_goal_is_the_explored_pose_nearest_the_sensed_hole():
    explored = np.array(
        [
            [0.005, 0.0, 0.0],  # beside the hole at the sensed x, on the surface
            [0.0, -0.009, 0.0],  # in the hole, 5 mm from the sensed x
            [0.0, -0.009, 0.3],  # in the hole but tilted
        ]
    )
    sensed = np.array([0.005, -0.01, 0.0])
    assert np.array_equal(outer_goal(explored, sensed, SENSING), explored[1])
    # With a loose depth belief the pose beside the hole would win: the choice of Σ_H matters.
    loose = SensingConfig(hole_std=(0.005, 0.05, 0.02))
    assert np.array_equal(outer_goal(explored, sensed, loose), explored[0])
    assert hole_distance(explored[1], sensed, SENSING) == pytest.approx(1.0 + 1.0)


def test_sensed_hole_is_seeded_and_biased():
    planner = Planner.from_configs(COARSE, replace(PlannerConfig(), iterations=1))
    draws = np.array([planner.sense_hole(np.random.default_rng(s)) for s in range(400)])
    assert np.all(draws[:, 1:] == planner.scene.hole_pose[1:])
    assert draws[:, 0].mean() == pytest.approx(0.005, abs=0.001)
    assert draws[:, 0].std() == pytest.approx(0.005, rel=0.15)
    again = planner.sense_hole(np.random.default_rng(3))
    assert np.array_equal(again, draws[3])


def short_config(iterations: int, population_size: int, **changes) -> PlannerConfig:
    """A planner config with 1.1 s rollouts, for fast end-to-end runs."""
    return replace(
        PlannerConfig(),
        iterations=iterations,
        dmp=DmpConfig(duration_s=1.0),
        optimizer=OptimizerConfig(population_size=population_size, sigma=0.3),
        settle_s=0.1,
        **changes,
    )


@pytest.fixture(scope="module")
def tiny_runs():
    config = short_config(iterations=2, population_size=3, deploy_policy="final_mean")
    scene = COARSE
    first = Planner.from_configs(scene, config).run()
    second = Planner.from_configs(scene, config).run()
    one_level = Planner.from_configs(scene, replace(config, goal="sensed_hole")).run()
    return first, second, one_level


def test_rollouts_in_worker_processes_give_the_same_run(tiny_runs):
    first, _, _ = tiny_runs
    config = short_config(iterations=2, population_size=3, deploy_policy="final_mean")
    parallel = Planner.from_configs(COARSE, config).run(workers=2)
    pd.testing.assert_frame_equal(parallel.rollouts, first.rollouts)
    pd.testing.assert_frame_equal(parallel.best_paths, first.best_paths)
    with pytest.raises(ConfigError, match="workers"):
        Planner.from_configs(COARSE, config).run(workers=0)


def test_run_record_is_complete_and_deterministic(tiny_runs):
    first, second, _ = tiny_runs
    rollouts = first.rollouts
    train = rollouts[rollouts["phase"] == "train"]
    assert len(train) == 2 * 3
    assert train.groupby("iteration")["is_best"].sum().tolist() == [1, 1]
    deploy = rollouts[rollouts["phase"] == "deploy"]
    assert len(deploy) == PlannerConfig().deploy_trials
    assert deploy["rollout"].tolist() == list(range(len(deploy)))
    assert not deploy["is_best"].any() and (deploy["sigma"] == 0).all()
    assert first.deploy_success_rate == pytest.approx(deploy["success"].mean())
    assert first.final_mean_deploy_success_rate == first.deploy_success_rate
    assert not rollouts["phase"].isin(["mean", "deploy_final_mean"]).any()
    ok = rollouts["status"] == "ok"
    assert np.allclose(
        rollouts.loc[ok, "cost"],
        rollouts.loc[ok, ["cost_regularization", "cost_spring_energy", "cost_hole_distance"]].sum(
            axis=1
        ),
    )
    assert set(first.best_paths["iteration"]) == {1, 2}
    assert first.rollouts.equals(second.rollouts)
    assert first.best_paths.equals(second.best_paths)


def test_first_iteration_goal_is_the_sensed_hole_for_both_methods(tiny_runs):
    bilevel, _, one_level = tiny_runs
    for record in (bilevel, one_level):
        first = record.rollouts[record.rollouts["iteration"] == 1].iloc[0]
        # q_R(T) is the P1 pose of an upright peg whose tip is at the sensed hole.
        assert first["goal_x_m"] == pytest.approx(first["sensed_hole_x_m"])
        assert first["goal_y_m"] == pytest.approx(first["sensed_hole_y_m"] + 0.045)
    # One-level keeps goal = sensed hole; bilevel moves it to an explored tip pose.
    for record in (bilevel, one_level):
        rows = record.rollouts
        assert np.allclose(
            rows["target_hole_error_m"], np.hypot(rows["target_x_m"], rows["target_y_m"] + 0.01)
        )
    later = one_level.rollouts[one_level.rollouts["iteration"] == 2].iloc[0]
    assert later["goal_x_m"] == pytest.approx(later["sensed_hole_x_m"])
    moved = bilevel.rollouts[bilevel.rollouts["iteration"] == 2].iloc[0]
    assert moved["goal_y_m"] != pytest.approx(moved["sensed_hole_y_m"] + 0.045)


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda c: c.update(goal="two_level"), r"planner\.goal"),
        (lambda c: c.update(iterations=0), r"planner\.iterations"),
        (lambda c: c["optimizer"].update(name="simplex"), r"planner\.optimizer\.name"),
        (lambda c: c["optimizer"].update(population_size=0), r"planner\.optimizer\.population"),
        (
            lambda c: c["optimizer"].update(elite_fraction=1.5),
            r"planner\.optimizer\.elite_fraction",
        ),
        (
            lambda c: c["optimizer"].update(elite_fraction=0.0),
            r"planner\.optimizer\.elite_fraction",
        ),
        (
            lambda c: c["sensing"].update(hole_std=[0.005, 0.0, 0.02]),
            r"planner\.sensing\.hole_std.*singular",
        ),
        (lambda c: c["dmp"].update(n_basis=0), r"planner\.dmp\.n_basis"),
        (lambda c: c["outer"].update(goal_tilt="level"), r"planner\.outer\.goal_tilt"),
        (lambda c: c["sensing"].update(redraw="never"), r"planner\.sensing\.redraw"),
        (lambda c: c.update(deploy_trials=0), r"planner\.deploy_trials"),
        (lambda c: c.update(deploy_policy="best_sample"), r"planner\.deploy_policy"),
        (lambda c: c.update(deploy_start_std_m=-0.001), r"planner\.deploy_start_std_m"),
        (lambda c: c.update(deploy_start_std_m=0.002), r"planner\.deploy_start_std_m.*above"),
        (lambda c: c.update(train_start_std_m=float("nan")), r"planner\.train_start_std_m"),
        (lambda c: c.update(train_start_std_m=0.002), r"planner\.train_start_std_m.*above"),
        (lambda c: c.update(start_height_m=0.5), r"planner\.start_height_m"),
        (lambda c: c.update(convergence_window=1), r"planner\.convergence_window.*>= 2"),
        (
            lambda c: c["costs"].update(balance="first_iteration_median", spring_energy=0.0),
            r"planner\.costs\.spring_energy.*median",
        ),
    ],
)
def test_bad_planner_config_is_rejected_before_simulation(edit, message):
    data = to_mapping(PlannerConfig())
    edit(data)
    with pytest.raises(ConfigError, match=message):
        from_mapping(PlannerConfig, data, "planner")


def test_the_study_config_and_the_python_defaults_are_the_same_table_4_values():
    import yaml

    from pih.study.config import resolve

    study = yaml.safe_load((Path(__file__).parents[1] / "config" / "config.yaml").read_text())
    scene, planner = resolve(study)
    # Table 4: α1–α3, μ_x, σ_x, r, iterations, k, μ; and the one source of truth for both.
    assert (planner.costs.regularization, planner.costs.spring_energy) == (1e4, 20.0)
    assert planner.costs.hole_distance == 10.0
    assert (planner.sensing.bias_m, planner.sensing.std_m) == (0.005, 0.005)
    assert (planner.optimizer.population_size, planner.iterations) == (10, 50)
    assert scene.spring.stiffness == (1000.0, 1000.0, 1.0) and scene.material.friction == 0.6
    assert planner == PlannerConfig()
    assert scene == SceneConfig()


def test_convergence_stop_ends_the_run_early_and_says_why():
    config = short_config(
        iterations=5,
        population_size=2,
        convergence_window=2,
        convergence_tolerance=10.0,  # any two finite best costs within 10x of their mean
    )
    record = Planner.from_configs(COARSE, config).run()
    assert record.stop_reason == "converged at iteration 2"
    assert record.rollouts["iteration"].max() == 2
    budget = Planner.from_configs(COARSE, replace(config, convergence_window=0)).run()
    assert budget.stop_reason == "iteration budget (5)"
    assert budget.rollouts["iteration"].max() == 5


def test_seeds_differ_between_sweep_points_and_are_shared_by_the_methods():
    config = PlannerConfig()
    start_a = seed_key(
        {"planner.start_x_m": -0.031, "planner.seed": 0, "planner.goal": "explored_argmin"}
    )
    start_b = seed_key(
        {"planner.start_x_m": -0.032, "planner.seed": 0, "planner.goal": "explored_argmin"}
    )
    one_level = seed_key(
        {"planner.start_x_m": -0.031, "planner.seed": 0, "planner.goal": "sensed_hole"}
    )
    other_rule = seed_key(
        {
            "planner.start_x_m": -0.031,
            "planner.seed": 0,
            "planner.goal": "deepest_explored",
        }
    )
    other_policy = seed_key(
        {
            "planner.start_x_m": -0.031,
            "planner.seed": 0,
            "planner.goal": "explored_argmin",
            "planner.deploy_policy": "last_inserted_mean",
            "planner.deploy_start_std_m": 0.001,
            "planner.train_start_std_m": 0.001,
        }
    )
    assert start_a == one_level == other_rule == other_policy != start_b
    seeds_a, seeds_b = run_seeds(config, start_a), run_seeds(config, start_b)
    assert set(seeds_a) == {"noise", "exploration", "deployment", "start", "observation"}
    assert len(set(seeds_a.values())) == 5
    assert not set(seeds_a.values()) & set(seeds_b.values())
    assert run_seeds(replace(config, seed=1), start_a) != seeds_a


def test_two_starts_draw_different_sensed_holes_and_both_methods_the_same():
    config = short_config(iterations=3, population_size=1, deploy_trials=1)
    scene = COARSE

    def sensed(start_x_m: float, goal: str) -> list[float]:
        point = {"planner.start_x_m": start_x_m, "planner.goal": goal}
        planner = Planner.from_configs(
            scene, replace(config, start_x_m=start_x_m, goal=goal), seed_key(point)
        )
        rows = planner.run().rollouts
        return rows.loc[rows["phase"] == "train", "sensed_hole_x_m"].tolist()

    bilevel = sensed(-0.031, "explored_argmin")
    assert bilevel == sensed(-0.031, "sensed_hole")
    assert len(set(bilevel[:3])) == 3  # redrawn every iteration (Algorithm 1)
    assert not set(bilevel) & set(sensed(-0.032, "explored_argmin"))


def test_per_run_redraw_senses_the_hole_once():
    config = short_config(iterations=3, population_size=1, deploy_trials=1)
    once = replace(config, sensing=dataclasses.replace(config.sensing, redraw="per_run"))
    rows = Planner.from_configs(COARSE, once).run().rollouts
    train = rows[rows["phase"] == "train"]
    assert train["sensed_hole_x_m"].nunique() == 1


def test_each_goal_names_its_method():
    """Tables label one-level, its stable-goal variants and bilevel's rules apart."""
    from pih.planning.config import GOALS, is_one_level, method_label

    assert [method_label(goal) for goal in GOALS] == [
        "one_level",
        "one_level/mean_sensed_hole",
        "one_level/calibrated_mean_sensed_hole",
        "bilevel/explored_argmin",
        "bilevel/deepest_explored",
    ]
    assert [is_one_level(goal) for goal in GOALS] == [True, True, True, False, False]


@pytest.mark.parametrize("bias_m", [0.005, 0.002])
def test_a_stable_goal_is_the_mean_of_the_runs_sensings_and_reads_no_fresh_one(bias_m):
    """One-level with a stable goal (issue 69): in training the goal is the mean of the run's
    sensings so far, in deployment the mean of all of them whatever the trial senses, less the
    config's own μ_x when calibrated; the sensings are one-level's, draw for draw."""
    config = short_config(iterations=3, population_size=1, deploy_trials=3)
    config = replace(config, sensing=dataclasses.replace(config.sensing, bias_m=bias_m))
    runs = {
        goal: Planner.from_configs(COARSE, replace(config, goal=goal)).run().rollouts
        for goal in ("sensed_hole", "mean_sensed_hole", "calibrated_mean_sensed_hole")
    }
    columns = ["sensed_hole_x_m", "sensed_hole_y_m", "sensed_hole_theta_rad"]
    for goal, rows in runs.items():
        pd.testing.assert_frame_equal(rows[columns], runs["sensed_hole"][columns])
        if goal == "sensed_hole":
            continue
        bias = bias_m if goal.startswith("calibrated") else 0.0
        train = rows[rows["phase"] == "train"]
        running = train["sensed_hole_x_m"].expanding().mean() - bias
        assert np.allclose(train["target_x_m"], running, rtol=0, atol=1e-15)
        assert np.allclose(train["target_y_m"], train["sensed_hole_y_m"])
        deployed = rows[rows["phase"] == "deploy"]
        assert deployed["sensed_hole_x_m"].nunique() == 3  # each trial senses anew ...
        final = train["sensed_hole_x_m"].mean() - bias
        assert np.allclose(deployed["target_x_m"], final, rtol=0, atol=1e-15)  # ... unread


@pytest.mark.parametrize("inserted_at", [set(), {1}, {1, 2}])
def test_last_inserted_mean_deploys_the_latest_mean_that_inserted(
    tiny_runs, monkeypatch, inserted_at
):
    config = short_config(iterations=2, population_size=3, deploy_policy="last_inserted_mean")
    planner = Planner.from_configs(COARSE, config)
    calls = iter([1, 2])
    monkeypatch.setattr(planner, "inserted", lambda trace, sensed, tip: next(calls) in inserted_at)
    record = planner.run()
    rows = record.rollouts
    train = rows[rows["phase"] == "train"].reset_index(drop=True)
    # Evaluating the mean draws nothing: training is the final_mean run's, rollout for rollout.
    reference = tiny_runs[0].rollouts
    pd.testing.assert_frame_equal(train, reference[reference["phase"] == "train"])
    means = rows[rows["phase"] == "mean"]
    assert means["iteration"].tolist() == [1, 2] and (means["sigma"] == 0).all()
    # The first mean is W* = 0; each later one is the previous update's.
    assert means["cost_regularization"].iloc[0] == 0.0
    deployed = rows[rows["phase"] == "deploy"]["cost_regularization"]
    assert record.deployed_iteration == (max(inserted_at) if inserted_at else None)
    if record.deployed_iteration is None:
        assert (
            deployed.iloc[0]
            == reference[reference["phase"] == "deploy"]["cost_regularization"].iloc[0]
        )
    else:
        chosen = means[means["iteration"] == record.deployed_iteration]
        assert np.allclose(deployed, chosen["cost_regularization"].iloc[0])
    # The final mean is deployed too, on the same sensed holes: the final_mean run's deployment.
    final = rows[rows["phase"] == "deploy_final_mean"].drop(columns="phase")
    expected = reference[reference["phase"] == "deploy"].drop(columns="phase")
    pd.testing.assert_frame_equal(final.reset_index(drop=True), expected.reset_index(drop=True))
    assert record.final_mean_deploy_success_rate == tiny_runs[0].deploy_success_rate


def tiny_run_with(**changes) -> tuple[Planner, pd.DataFrame]:
    """The planner and rollouts of ``tiny_runs[0]``'s config with ``changes``."""
    config = short_config(
        iterations=2, population_size=3, **{"deploy_policy": "final_mean", **changes}
    )
    planner = Planner.from_configs(COARSE, config)
    return planner, planner.run().rollouts


def assert_offset_starts(rows: pd.DataFrame, nominal_rows: pd.DataFrame, start: np.ndarray):
    """Every row starts at its own offset (≈ 1 mm std) from ``start`` in x and y, at its θ, and
    ends elsewhere than the same row started from ``start``."""
    offsets = rows[["start_x_m", "start_y_m"]].to_numpy() - start[:2]
    assert len(np.unique(offsets)) == offsets.size
    assert 0.0002 < offsets.std() < 0.003
    assert (rows["start_theta_rad"] == start[2]).all()
    assert not np.array_equal(rows["final_bottom_x_m"], nominal_rows["final_bottom_x_m"])


@pytest.fixture(scope="module")
def offset_deployment() -> tuple[Planner, pd.DataFrame]:
    return tiny_run_with(deploy_start_std_m=0.001)


def test_deployment_start_offsets_leave_training_and_sensings_alone(tiny_runs, offset_deployment):
    reference = tiny_runs[0].rollouts
    planner, rows = offset_deployment
    train = rows[rows["phase"] == "train"].reset_index(drop=True)
    pd.testing.assert_frame_equal(train, reference[reference["phase"] == "train"])
    deploy, before = rows[rows["phase"] == "deploy"], reference[reference["phase"] == "deploy"]
    assert np.array_equal(deploy["sensed_hole_x_m"], before["sensed_hole_x_m"])
    assert (before[["start_x_m", "start_y_m"]] == planner.start_bottom[:2]).all(axis=None)
    assert_offset_starts(deploy, before, planner.start_bottom)


def test_redeploying_a_run_gives_the_deployment_another_start_std_would_have(
    tiny_runs, offset_deployment
):
    reference = tiny_runs[0].rollouts
    planner, rows = offset_deployment
    nominal = Planner(planner.scene, replace(planner.config, deploy_start_std_m=0.0))
    for redeployer, run, twin in ((planner, reference, rows), (nominal, rows, reference)):
        again = redeployer.redeploy(run, [1.0, 1.0, 1.0])
        recorded = twin[twin["phase"] == "deploy"].reset_index(drop=True)
        pd.testing.assert_frame_equal(again, recorded)  # every column, to the bit
    with pytest.raises(ValueError, match="not the run's seeds"):
        Planner(planner.scene, planner.config, seed_key="another point").redeploy(rows, [1.0] * 3)
    with pytest.raises(ValueError, match="10 recorded trials"):
        Planner(planner.scene, replace(planner.config, deploy_trials=2)).redeploy(rows, [1.0] * 3)


def test_training_start_offsets_draw_their_own_stream(tiny_runs):
    reference = tiny_runs[0].rollouts
    planner, rows = tiny_run_with(train_start_std_m=0.001)
    train, before = (r[r["phase"] == "train"].reset_index(drop=True) for r in (rows, reference))
    # The sensed holes and the first iteration's exploration are the nominal run's ...
    assert np.array_equal(train["sensed_hole_x_m"], before["sensed_hole_x_m"])
    first = train["iteration"] == 1
    assert np.array_equal(np.stack(train["weights"][first]), np.stack(before["weights"][first]))
    # ... every training rollout starts at its own offset in x and y, the same θ ...
    assert_offset_starts(train, before, planner.start_bottom)
    # ... and deployment starts where training was meant to (deploy_start_std_m = 0).
    deploy = rows[rows["phase"] == "deploy"]
    assert (deploy[["start_x_m", "start_y_m"]] == planner.start_bottom[:2]).all(axis=None)
    # Which weights are deployed does not change where training rollouts start.
    _, other_policy = tiny_run_with(train_start_std_m=0.001, deploy_policy="last_inserted_mean")
    other = other_policy[other_policy["phase"] == "train"].reset_index(drop=True)
    assert np.array_equal(other[["start_x_m", "start_y_m"]], train[["start_x_m", "start_y_m"]])


def test_a_recorded_rollout_replays_exactly(tiny_runs):
    rows = tiny_runs[0].rollouts
    config = short_config(iterations=2, population_size=3, deploy_policy="final_mean")
    planner = Planner.from_configs(COARSE, config)
    for _, row in rows[rows["phase"].isin(["train", "deploy"])].iloc[[1, -1]].iterrows():
        rollout = recorded_rollout(row)
        assert rollout.weights.shape == (3 * config.dmp.n_basis,)
        trace, terms = planner.evaluate_rollout(rollout)
        assert np.array_equal(
            trace.q_peg_bottom[-1],
            row[["final_bottom_x_m", "final_bottom_y_m", "final_bottom_theta_rad"]].to_numpy(float),
        )
        assert terms.regularization == row["cost_regularization"]


def test_inserted_is_judged_by_the_sensed_depth_only():
    planner = Planner.from_configs(COARSE, replace(PlannerConfig(), iterations=1))
    hole = planner.scene.hole_pose
    sensed = np.array([hole[0] + 0.004, hole[1], hole[2]])
    at_depth = _trace_at([[0.0, 0.0, 0.0], [hole[0], hole[1] + 0.0009, 0.0]])
    assert planner.inserted(at_depth, sensed)
    assert not planner.inserted(
        _trace_at([[0.0, 0.0, 0.0], [hole[0], hole[1] + 0.0011, 0.0]]), sensed
    )
    on_surface = _trace_at([[0.0, 0.0, 0.0], [-0.03, hole[1] + 0.01, 0.0]])
    assert not planner.inserted(on_surface, sensed)
    assert not planner.inserted(dataclasses.replace(at_depth, status="diverged"), sensed)


def _trace_at(poses: np.ndarray, overlap: float = 0.0):
    from pih.scene.trace import Trace

    n = len(poses)
    zeros = np.zeros((n, 3))
    return Trace(
        time_s=np.arange(n, dtype=float),
        q_robot=zeros,
        q_peg=zeros,
        q_peg_top=zeros,
        q_peg_bottom=np.asarray(poses, dtype=float),
        contact_force=zeros,
        contact_patches=np.zeros(n, dtype=np.int64),
        spring_force=zeros,
        spring_energy_j=np.zeros(n),
        insertion_depth_m=np.zeros(n),
        penetration_m=np.full(n, overlap),
    )


def test_deepest_explored_aims_along_the_hole_axis_below_the_deepest_pose():
    config = replace(PlannerConfig(), goal="deepest_explored")
    outer = OuterLevel(config, hole_depth_m=0.01, hole_theta_rad=0.0)
    sensed = np.array([0.006, -0.01, 0.0])
    assert np.array_equal(outer.goal(sensed), sensed)  # nothing explored yet
    # On the surface only (top at y = 0): the paper's rule.
    outer.observe([_trace_at([[0.004, 0.0, 0.0], [-0.02, 0.0, 0.0]])], slice(None))
    assert np.array_equal(outer.goal(sensed), [0.004, 0.0, 0.0])
    # A near-upright pose 3 mm into the chamfer: aim at the sensed depth and tilt below it.
    outer.observe([_trace_at([[0.0012, -0.003, 0.01], [0.004, 0.0, 0.0]])], slice(None))
    assert np.allclose(outer.goal(sensed), [0.0012, -0.01, 0.0])
    # A later iteration that stays on the surface does not forget it...
    outer.observe([_trace_at([[0.004, 0.0, 0.0]])], slice(None))
    assert np.allclose(outer.goal(np.array([0.009, -0.01, 0.0])), [0.0012, -0.01, 0.0])
    # ...and neither a deeper solver overlap transient nor a steeply tilted peg dipping its tip
    # centre below the surface from beside the hole counts.
    outer.observe([_trace_at([[0.01, -0.008, 0.0]], overlap=2 * CLEAN_OVERLAP_M)], slice(None))
    outer.observe([_trace_at([[-0.0023, -0.009, -0.5566]])], slice(None))
    assert outer.deepest[0] == pytest.approx(0.0012)


def test_explored_argmin_is_the_papers_rule_on_the_previous_iteration():
    outer = OuterLevel(PlannerConfig(), hole_depth_m=0.01, hole_theta_rad=0.0)
    sensed = np.array([0.005, -0.01, 0.0])
    outer.observe([_trace_at([[0.0, -0.009, 0.0], [0.005, 0.0, 0.0]])], slice(None))
    assert np.array_equal(outer.goal(sensed), [0.0, -0.009, 0.0])
    outer.observe([_trace_at([[0.005, 0.0, 0.0]])], slice(None))  # Q_P is reset each iteration
    assert np.array_equal(outer.goal(sensed), [0.005, 0.0, 0.0])
    level = replace(PlannerConfig(), outer=OuterConfig(goal_tilt="sensed"))
    sensed_tilt = OuterLevel(level, hole_depth_m=0.01, hole_theta_rad=0.0)
    sensed_tilt.observe([_trace_at([[0.0, -0.009, 0.04]])], slice(None))
    assert np.array_equal(sensed_tilt.goal(sensed), [0.0, -0.009, 0.0])


def test_cost_balance_divides_each_term_by_its_first_iteration_median():
    balance = CostBalance(CostConfig(balance="first_iteration_median"))
    first = [CostTerms(2.0, 10.0, 100.0), CostTerms(4.0, 30.0, 300.0), None]
    totals = balance.totals(first)
    assert np.allclose(balance.divisors, [3.0, 20.0, 200.0])
    assert totals[0] == pytest.approx(2 / 3 + 0.5 + 0.5) and np.isnan(totals[2])
    # The divisors are fixed after the first iteration.
    assert balance.totals([CostTerms(3.0, 20.0, 200.0)])[0] == pytest.approx(3.0)
    unbalanced = CostBalance(CostConfig())
    assert unbalanced.totals(first)[1] == pytest.approx(334.0)
