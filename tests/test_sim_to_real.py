"""Planning on the sensed hole (``planner.simulated_hole``) and noise on the sensed y_H, θ_H:
training rollouts run where the robot sensed the hole, deployment trials on the real one."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from test_planner import COARSE, short_config

ROOT = Path(__file__).resolve().parents[1]

from pih.config import ConfigError, from_mapping, to_mapping
from pih.planning.config import PlannerConfig, SensingConfig, replace
from pih.planning.planner import Planner
from pih.planning.run_record import Rollout, recorded_pose, recorded_rollout
from pih.study.points import seed_key


def planner_from(simulated_hole: object = "true_hole", **sensing: object) -> PlannerConfig:
    """A planner config read from a mapping, as a config file's ``planner`` section is."""
    mapping = to_mapping(PlannerConfig())
    mapping["simulated_hole"] = simulated_hole
    mapping["sensing"].update(sensing)
    return from_mapping(PlannerConfig, mapping, "planner")


def test_simulated_hole_and_sensing_noise_are_checked_before_anything_runs():
    assert planner_from("sensed_per_iteration", y_std_m=0.001).simulated_hole == (
        "sensed_per_iteration"
    )
    with pytest.raises(ConfigError, match=r"planner\.simulated_hole.*'sensed_per_run'"):
        planner_from(True)  # YAML's unquoted true
    with pytest.raises(ConfigError, match=r"planner\.sensing\.y_std_m"):
        planner_from(y_std_m=-0.001)
    with pytest.raises(ConfigError, match=r"planner\.sensing\.theta_std_rad"):
        planner_from(theta_std_rad=float("nan"))
    # A tilted sensed hole cannot be simulated: the scene's hole is upright.
    with pytest.raises(ConfigError, match=r"planner\.sensing\.theta_std_rad.*cannot tilt"):
        planner_from("sensed_per_run", theta_std_rad=0.01)


def test_noise_on_y_and_theta_is_drawn_only_when_asked_and_keeps_the_x_draw():
    exact = Planner.from_configs(COARSE, replace(PlannerConfig(), iterations=1))
    noisy_config = replace(
        PlannerConfig(), iterations=1, sensing=SensingConfig(y_std_m=0.001, theta_std_rad=0.01)
    )
    noisy = Planner(exact.scene, noisy_config)
    truth = exact.scene.hole_pose
    exact_draws = np.array([exact.sense_hole(np.random.default_rng(s)) for s in range(300)])
    noisy_draws = np.array([noisy.sense_hole(np.random.default_rng(s)) for s in range(300)])
    assert np.all(exact_draws[:, 1:] == truth[1:])
    assert np.array_equal(noisy_draws[:, 0], exact_draws[:, 0])
    assert noisy_draws[:, 1].std() == pytest.approx(0.001, rel=0.2)
    assert noisy_draws[:, 2].std() == pytest.approx(0.01, rel=0.2)
    assert abs(noisy_draws[:, 1].mean() - truth[1]) < 0.0003


def test_a_simulated_hole_moves_the_scene_and_the_contact():
    planner = Planner.from_configs(COARSE, short_config(iterations=1, population_size=2))
    truth = planner.scene.hole_pose
    assert planner.scene_for(None) is planner.scene
    assert planner.scene_for(truth.copy()) is planner.scene
    shifted = truth + [0.003, 0.0, 0.0]
    model = planner.scene_for(shifted)
    assert np.array_equal(model.hole_pose, shifted)
    assert planner.scene_for(shifted.copy()) is model  # kept while the pose does not change
    start = np.array([truth[0], COARSE.hole.top_y_m + 0.005, 0.0])
    weights = np.zeros(3 * planner.config.dmp.n_basis)
    rollout = Rollout(start, truth.copy(), weights, truth.copy())
    real, _ = planner.evaluate_rollout(rollout)
    simulated, _ = planner.evaluate_rollout(rollout._replace(simulated_hole=shifted))
    # Straight down into the real hole; on the top surface beside a hole 3 mm to the right.
    assert real.q_peg_bottom[-1][1] < COARSE.hole.top_y_m - 0.005
    assert simulated.q_peg_bottom[-1][1] > COARSE.hole.top_y_m - 0.0005


@pytest.fixture(scope="module")
def runs_by_mode() -> dict[str, pd.DataFrame]:
    runs = {}
    for mode in ("true_hole", "sensed_per_run", "sensed_per_iteration"):
        config = short_config(
            iterations=2, population_size=3, deploy_policy="final_mean", simulated_hole=mode
        )
        runs[mode] = Planner.from_configs(COARSE, config).run().rollouts
    return runs


def test_training_runs_on_the_sensed_hole_and_deployment_on_the_real_one(runs_by_mode):
    truth = Planner.from_configs(COARSE, PlannerConfig()).scene.hole_pose
    for mode, rows in runs_by_mode.items():
        train, deploy = rows[rows["phase"] == "train"], rows[rows["phase"] == "deploy"]
        simulated = train[["simulated_hole_x_m", "simulated_hole_y_m"]].to_numpy()
        sensed = train[["sensed_hole_x_m", "sensed_hole_y_m"]].to_numpy()
        first = train[train["iteration"] == 1][["sensed_hole_x_m", "sensed_hole_y_m"]].iloc[0]
        if mode == "true_hole":
            assert np.all(simulated == truth[:2])
        elif mode == "sensed_per_run":
            assert np.all(simulated == first.to_numpy())
            assert len(np.unique(sensed[:, 0])) == 2  # the camera still senses every iteration
        else:
            assert np.array_equal(simulated, sensed)
        assert np.all(deploy[["simulated_hole_x_m", "simulated_hole_y_m"]] == truth[:2])
        # success is judged against the hole each rollout was simulated with
        error = np.hypot(
            train["final_bottom_x_m"] - train["simulated_hole_x_m"],
            train["final_bottom_y_m"] - train["simulated_hole_y_m"],
        )
        np.testing.assert_allclose(train["final_hole_error_m"], error)


def test_the_modes_share_their_draws_and_differ_only_in_the_simulator(runs_by_mode):
    rows = {mode: r.reset_index(drop=True) for mode, r in runs_by_mode.items()}
    for mode in ("sensed_per_run", "sensed_per_iteration"):
        for column in ("sensed_hole_x_m", "start_x_m"):
            assert np.array_equal(rows[mode][column], rows["true_hole"][column])
        train = rows[mode]["phase"] == "train"
        first = train & (rows[mode]["iteration"] == 1)
        # The same first-iteration rollouts (same W) end elsewhere on a hole 5 mm off.
        assert not np.array_equal(
            rows[mode].loc[first, "final_bottom_x_m"],
            rows["true_hole"].loc[first, "final_bottom_x_m"],
        )
    assert seed_key({"planner.simulated_hole": "sensed_per_run", "planner.seed": 0}) == seed_key(
        {"planner.simulated_hole": "true_hole", "planner.seed": 0}
    )


def test_a_training_rollout_on_the_sensed_hole_replays_exactly(runs_by_mode):
    rows = runs_by_mode["sensed_per_iteration"]
    config = short_config(
        iterations=2,
        population_size=3,
        deploy_policy="final_mean",
        simulated_hole="sensed_per_iteration",
    )
    planner = Planner.from_configs(COARSE, config)
    row = rows[(rows["phase"] == "train") & (rows["iteration"] == 2)].iloc[0]
    rollout = recorded_rollout(row)
    assert np.array_equal(rollout.simulated_hole, recorded_pose(row, "simulated_hole"))
    trace, _ = planner.evaluate_rollout(rollout)
    assert np.array_equal(trace.q_peg_bottom[-1], recorded_pose(row, "final_bottom"))


# -- deployment under model error (robustness.model_error) ------------------------------------


@pytest.mark.slow  # simulates for more than 5 s
def test_a_run_redeployed_on_a_moved_hole_senses_it_there(runs_by_mode):
    """The hole moved 0.5 mm after training: the camera sees it there (every sensed hole and
    one-level's targets move), bilevel keeps its learned goal, success is judged on the moved
    hole; friction alone changes only the physics."""
    shift = 0.0005
    for goal in ("explored_argmin", "sensed_hole"):
        config = short_config(
            iterations=2, population_size=3, deploy_policy="final_mean", goal=goal
        )
        if goal == "explored_argmin":
            rows = runs_by_mode["true_hole"]
        else:
            rows = Planner.from_configs(COARSE, config).run().rollouts
        moved = Planner.from_configs(COARSE.replace(hole__x_m=shift), config)
        again = moved.redeploy(rows, [1.0, 1.0, 1.0], recorded_hole=np.array([0.0, -0.01, 0.0]))
        before = rows[rows["phase"] == "deploy"].reset_index(drop=True)
        np.testing.assert_allclose(again["sensed_hole_x_m"], before["sensed_hole_x_m"] + shift)
        target_shift = again["target_x_m"] - before["target_x_m"]
        expected = shift if config.goal == "sensed_hole" else 0.0
        np.testing.assert_allclose(target_shift, expected, atol=1e-15)
        assert np.all(again["simulated_hole_x_m"] == shift)
        error = np.hypot(again["final_bottom_x_m"] - shift, again["final_bottom_y_m"] + 0.01)
        np.testing.assert_allclose(again["final_hole_error_m"], error)
        # Without the move the recorded deployment comes back to the bit.
        same = Planner.from_configs(COARSE, config).redeploy(rows, [1.0, 1.0, 1.0])
        pd.testing.assert_frame_equal(
            same.drop(columns=[c for c in same if c.startswith("simulated_hole")]),
            before.drop(columns=[c for c in before if c.startswith("simulated_hole")]),
        )


def test_model_errors_are_checked_before_any_job():
    import yaml

    from pih.study.config import check_study, study_points

    config = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    config["robustness"]["model_error"] = {"friction_low": {"material.friction": 0.5}}
    check_study(config, study_points(config)[:1])
    for errors, match in (
        ({"friction_low": {"material.fricton": 0.5}}, r"robustness\.model_error\.friction_low"),
        ({"friction_low": {"material.friction": -1.0}}, r"robustness\.model_error\.friction_low"),
        ({"Friction low": {"material.friction": 0.5}}, r"robustness\.model_error: 'Friction low'"),
        ({"none_at_all": {}}, r"robustness\.model_error\.none_at_all"),
    ):
        config["robustness"]["model_error"] = errors
        with pytest.raises(ConfigError, match=match):
            check_study(config, study_points(config)[:1])


def test_model_errors_get_their_own_rows_and_pairs_and_leave_the_headline_alone():
    from pih.analysis.aggregate import robustness_pairs, robustness_table
    from pih.reporting.summary import model_error_rows, on_training_scene

    keys = ["planner.start_x_m", "planner.goal"]
    rows = []
    for start, ours, theirs in (("-0.04", 1.0, 0.2), ("-0.035", 0.9, 0.1), ("-0.03", 0.8, 0.3)):
        for method, rate in (("bilevel/deepest_explored", ours), ("one_level", theirs)):
            run = f"{start}_{method}"
            common = {"method": method, "run": run, "planner.start_x_m": start}
            rows += [
                {**common, "start_std_m": 0.0, "deploy_success_rate": rate},  # the run's own
                {
                    **common,
                    "start_std_m": 0.001,
                    "model_error": "none",
                    "deploy_success_rate": rate,
                },
                {
                    **common,
                    "start_std_m": 0.001,
                    "model_error": "friction_0_5",
                    "deploy_success_rate": rate / 2 if method == "one_level" else 0.0,
                },
            ]
    deployments = pd.DataFrame(rows)
    table = robustness_table(deployments, keys)
    assert list(table["model_error"]) == ["none"] * 4 + ["friction_0_5"] * 2
    exact = on_training_scene(table)
    assert len(exact) == 4 and set(exact["start_std_m"]) == {0.0, 0.001}
    pairs = robustness_pairs(deployments, keys)
    under_error = pairs[pairs["dimension"] == "model_error"].iloc[0]
    # Under friction 0.5 ours inserts nowhere, one-level at every start: 0 better, 3 worse.
    assert (under_error["level"], under_error["better"], under_error["worse"]) == (
        "friction_0_5",
        0,
        3,
    )
    assert set(pairs[pairs["dimension"] == "start_std_m"]["level"]) == {"0.0", "0.001"}
    errors = model_error_rows(table, pairs)
    ours = errors[errors["method"] == "bilevel/deepest_explored"].iloc[0]
    assert ours["model error"] == "friction_0_5" and ours["deployed"].startswith("0.00")
    assert ours["without it"].startswith("0.90")
    assert ours["vs one-level: better / worse / tied"] == "0 / 3 / 0"


def test_observation_noise_on_the_tip_reaches_the_outer_level_only_when_asked(runs_by_mode):
    config = short_config(iterations=2, population_size=3, deploy_policy="final_mean")
    exact = Planner.from_configs(COARSE, config)
    poses = np.array([[0.001, -0.009, 0.0], [0.002, -0.008, 0.01]])
    rng = np.random.default_rng(0)
    assert np.array_equal(exact.observed_tips(poses, rng), poses)
    assert rng.bit_generator.state == np.random.default_rng(0).bit_generator.state  # no draw
    noisy = Planner(
        exact.scene, replace(config, sensing=SensingConfig(tip_std_m=0.0005)), seed_key=""
    )
    observed = noisy.observed_tips(np.zeros((2000, 3)), np.random.default_rng(1))
    assert observed[:, :2].std() == pytest.approx(0.0005, rel=0.1)
    assert np.all(observed[:, 2] == 0.0)  # θ is not blurred
    # A run with tip noise explores the same rollouts in iteration 1 but aims elsewhere after.
    rows = noisy.run().rollouts
    reference = runs_by_mode["true_hole"]
    first = (rows["phase"] == "train") & (rows["iteration"] == 1)
    assert np.array_equal(
        rows.loc[first, "final_bottom_x_m"], reference.loc[first, "final_bottom_x_m"]
    )
    second = (rows["phase"] == "train") & (rows["iteration"] == 2)
    assert not np.array_equal(rows.loc[second, "target_x_m"], reference.loc[second, "target_x_m"])


def test_offset_start_pairs_are_split_by_the_simulator_mode_and_lead_the_summary():
    """From offset starts, one-level and bilevel are paired within each simulator mode (the
    modes are different designs: their points do not pool), and the summary quotes those."""
    from pih.analysis.aggregate import robustness_pairs, robustness_table
    from pih.reporting.summary import perturbed_pairs

    keys = ["planner.start_x_m", "planner.goal", "planner.simulated_hole"]
    # (start, mode) -> (ours, one-level) from offset starts: ours wins on the true hole,
    # loses once and ties once on the sensed one.
    rates = {
        ("-0.04", "true_hole"): (1.0, 0.1),
        ("-0.03", "true_hole"): (0.9, 0.2),
        ("-0.04", "sensed_per_run"): (0.1, 0.3),
        ("-0.03", "sensed_per_run"): (0.2, 0.2),
    }
    rows = []
    for (start, mode), pair in rates.items():
        for method, rate in zip(("bilevel/deepest_explored", "one_level"), pair, strict=True):
            common = {
                "method": method,
                "run": f"{start}_{mode}_{method}",
                "planner.start_x_m": start,
                "planner.simulated_hole": mode,
            }
            rows += [
                {**common, "start_std_m": 0.0, "deploy_success_rate": 1.0},
                {**common, "start_std_m": 0.001, "deploy_success_rate": rate},
            ]
    deployments = pd.DataFrame(rows)
    pairs = robustness_pairs(deployments, keys).set_index(["dimension", "level"])
    sensed = pairs.loc[("planner.simulated_hole", "sensed_per_run, starts 0.001 m off")]
    true = pairs.loc[("planner.simulated_hole", "true_hole, starts 0.001 m off")]
    assert (sensed["better"], sensed["worse"], sensed["tied"]) == (0, 1, 1)
    assert (true["better"], true["worse"]) == (2, 0)
    assert true["mean_difference"] == pytest.approx(0.8)
    pooled = pairs.loc[("start_std_m", "0.001")]
    assert pooled["pairs"] == 4 and pooled["better"] == 2
    # No per-mode rows for the training start: those are the nominal pairs' (paired_table).
    assert not any(level.startswith("true_hole, starts 0 ") for _, level in pairs.index)
    quoted = perturbed_pairs(pairs.reset_index(), robustness_table(deployments, keys))
    assert quoted[["dimension", "level", "better"]].values.tolist() == [
        ["planner.simulated_hole", "sensed_per_run", 0],
        ["planner.simulated_hole", "true_hole", 2],
    ]


def test_expected_success_at_the_sensings_own_rate():
    """Runs that inserted sensed nearer than those that did not: the threshold lies between, and
    the expected success weights the close runs by how often a sensing lands that close."""
    from scipy import stats

    from pih.analysis.sensing import close_probability, expected_at_sensing_rate

    # N(5 mm, (5 mm)^2) within 1.4 mm of 0: the 13.6 %.
    assert close_probability(0.0014, 0.005, 0.005) == pytest.approx(
        stats.norm.cdf(-0.72) - stats.norm.cdf(-1.28)
    )
    assert close_probability(0.001, 0.0, 0.0) == 1.0 and close_probability(0.001, 0.002, 0.0) == 0
    runs = pd.DataFrame(
        {
            "method": ["bilevel"] * 4 + ["one_level"] * 3,
            "first_sensing_dx_m": [0.001, -0.0005, 0.003, -0.006, 0.001, 0.003, 0.006],
            "offset_deploy_success_rate": [1.0, 0.8, 0.0, 0.1, 0.2, 0.6, 0.3],
        }
    )
    rate = expected_at_sensing_rate(runs, 0.005, 0.005).set_index("method")
    bilevel = rate.loc["bilevel"]
    assert (bilevel["farthest_close_m"], bilevel["nearest_far_m"]) == (0.001, 0.003)
    low, high = close_probability(0.001, 0.005, 0.005), close_probability(0.003, 0.005, 0.005)
    assert bilevel["expected_low"] == pytest.approx(low * 0.9 + (1 - low) * 0.05)
    assert bilevel["expected_high"] == pytest.approx(high * 0.9 + (1 - high) * 0.05)
    assert bilevel["measured"] == pytest.approx(0.475)
    # One-level's outcome does not split by distance (its close run sensed farthest): no rate.
    assert np.isnan(rate.loc["one_level", "expected_low"])
