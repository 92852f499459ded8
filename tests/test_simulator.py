"""The planner's own simulator (``planner.simulator``, issue 70): training rollouts run on a
scene whose contact model differs from the real one; deployment trials always on the real one."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from test_planner import COARSE, short_config

from pih.config import ConfigError, from_mapping, to_mapping
from pih.planning.config import PlannerConfig, SimulatorConfig, recorded_planner, replace
from pih.planning.planner import Planner
from pih.planning.run_record import recorded_rollout
from pih.study.points import is_method_key, seed_key

ROOT = Path(__file__).resolve().parents[1]
POINT = {"contact_model": "point", "point_stiffness_n_per_m": 1.0e7}


def planner_from(**simulator: object) -> PlannerConfig:
    """A planner config read from a mapping, as a config file's ``planner`` section is."""
    mapping = to_mapping(PlannerConfig())
    mapping["simulator"] = {**mapping["simulator"], **simulator}
    return from_mapping(PlannerConfig, mapping, "planner")


def test_a_simulator_setting_that_changes_nothing_is_refused_before_any_job():
    """A point stiffness for a hydroelastic training simulator, or the scene's own contact model,
    would label runs as trained elsewhere that trained on the real scene. The planner itself
    takes both: a point-trained run is redeployed on its simulator's own scene (a model error)."""
    from pih.study.config import check_study, load_config, study_points

    for simulator, key in (
        ({"point_stiffness_n_per_m": 1.0e7}, "point_stiffness_n_per_m"),
        ({"contact_model": "hydroelastic"}, "contact_model"),
    ):
        config = load_config([str(ROOT / "config" / "config.yaml")])
        config["planner"]["simulator"].update(simulator)
        with pytest.raises(ConfigError, match=rf"^planner\.simulator\.{key}: "):
            check_study(config, study_points(config))
    point_scene = COARSE.replace(
        solver__contact_model="point", material__point_stiffness_n_per_m=1.0e7
    )
    Planner.from_configs(point_scene, planner_from(**POINT))  # the simulator's own scene


def test_simulator_keys_are_checked_before_anything_runs():
    """A bad value, or a key that is no difference a training simulator may have (e.g. the
    peg's geometry, which would change what deployment measures), is refused naming the key."""
    assert planner_from(**POINT).simulator.scene_changes == {
        "solver__contact_model": "point",
        "material__point_stiffness_n_per_m": 1.0e7,
    }
    assert planner_from().simulator.scene_changes == {}  # null: the real scene's
    with pytest.raises(ConfigError, match=r"planner\.simulator\.contact_model: 'pointy'"):
        planner_from(contact_model="pointy")
    with pytest.raises(ConfigError, match=r"planner\.simulator\.point_stiffness_n_per_m"):
        planner_from(point_stiffness_n_per_m=-1.0)
    with pytest.raises(ConfigError, match=r"planner\.simulator: unknown key\(s\) \['peg'\]"):
        planner_from(peg={"width_m": 0.02})


def test_runs_recorded_before_the_simulator_read_as_training_on_the_real_scene():
    """A published run's planner section has no ``simulator``: it reads as the real scene's, so
    the run stays what today's config computes."""
    recorded = to_mapping(PlannerConfig())
    del recorded["simulator"]
    assert recorded_planner({"planner": recorded}).simulator == SimulatorConfig()


def test_simulator_keys_are_training_keys_that_share_the_points_draws():
    """Sweeping the training simulator pairs its runs with the real-scene ones by seed key."""
    assert is_method_key("planner.simulator.contact_model")
    point = {"planner.start_x_m": -0.04, "planner.seed": 0}
    assert seed_key({**point, "planner.simulator.contact_model": "point"}) == seed_key(point)


@pytest.fixture(scope="module")
def point_trained() -> tuple[PlannerConfig, pd.DataFrame, pd.DataFrame]:
    """One tiny run trained in point contact on the hydroelastic scene, and its twin on a scene
    that is point contact throughout."""
    config = short_config(iterations=2, population_size=2)  # last_inserted_mean: mean rollouts too
    simulator = replace(config, simulator=SimulatorConfig(**POINT))
    point_scene = COARSE.replace(
        solver__contact_model="point", material__point_stiffness_n_per_m=1.0e7
    )
    trained = Planner.from_configs(COARSE, simulator).run().rollouts
    everywhere = Planner.from_configs(point_scene, config).run().rollouts
    return simulator, trained, everywhere


def test_training_runs_in_the_simulator_and_deployment_on_the_real_scene(point_trained):
    config, trained, everywhere = point_trained
    train, twin = (
        rows[rows["phase"].isin(["train", "mean"])].reset_index(drop=True)
        for rows in (trained, everywhere)
    )
    assert set(train["phase"]) == {"train", "mean"}
    # Training is the point-contact scene's, rollout for rollout, with the same draws.
    pd.testing.assert_frame_equal(train, twin)
    # Deployment is the real (hydroelastic) scene's: the trials replay there, not in point contact.
    deploy = trained[trained["phase"].isin(["deploy", "deploy_final_mean"])]
    assert set(deploy["phase"]) == {"deploy", "deploy_final_mean"}
    real = Planner.from_configs(COARSE, dataclasses.replace(config, simulator=SimulatorConfig()))
    point = Planner.from_configs(COARSE, config)
    finals = {"real": [], "training": []}
    for _, row in deploy.iterrows():
        rollout = recorded_rollout(row)
        assert rollout.simulated_hole is None
        finals["real"].append(real.evaluate_rollout(rollout)[0].q_peg_bottom[-1])
        finals["training"].append(
            point.evaluate_rollout(rollout._replace(simulated_hole=real.scene.hole_pose))[
                0
            ].q_peg_bottom[-1]
        )
    recorded = deploy[["final_bottom_x_m", "final_bottom_y_m", "final_bottom_theta_rad"]]
    np.testing.assert_array_equal(np.array(finals["real"]), recorded.to_numpy())
    assert not np.array_equal(np.array(finals["training"]), recorded.to_numpy())


def test_a_training_rollout_in_the_simulator_replays_exactly(point_trained):
    config, trained, _ = point_trained
    planner = Planner.from_configs(COARSE, config)
    row = trained[trained["phase"] == "train"].iloc[-1]
    trace, _ = planner.evaluate_rollout(recorded_rollout(row))
    np.testing.assert_array_equal(
        trace.q_peg_bottom[-1],
        row[["final_bottom_x_m", "final_bottom_y_m", "final_bottom_theta_rad"]].to_numpy(float),
    )
    assert planner.training_scene_config.solver.contact_model == "point"
    assert planner.scene.config.solver.contact_model == "hydroelastic"


def recorded(**simulator: object) -> dict[str, object]:
    """A run's recorded config: the default scene (hydroelastic) and a planner trained in
    ``simulator``."""
    from pih.scene.config import SceneConfig

    return {"scene": to_mapping(SceneConfig()), "planner": to_mapping(planner_from(**simulator))}


def test_the_simulators_prediction_is_the_model_error_that_makes_reality_its_scene():
    """A deployment predicts what the simulator would see only on its own scene: for a run
    trained on the real scene that is the real scene; for a point-trained one, the model error
    that turns the real scene into the simulator (the stiffness too), not any other."""
    from pih.analysis.run_summary import on_simulator

    point_1e7 = {"solver.contact_model": "point", "material.point_stiffness_n_per_m": 1.0e7}
    point_1e6 = {**point_1e7, "material.point_stiffness_n_per_m": 1.0e6}
    assert on_simulator(recorded())
    assert not on_simulator(recorded(), point_1e7)
    assert not on_simulator(recorded(**POINT))
    assert on_simulator(recorded(**POINT), point_1e7)
    assert not on_simulator(recorded(**POINT), point_1e6)
    assert not on_simulator(recorded(**POINT), {**point_1e7, "material.friction": 0.3})
    assert not on_simulator(recorded(), {}, "friction_0_3")  # named, its settings not recorded


def deployments(rows: list[tuple]) -> pd.DataFrame:
    """Deployment rows as pooling makes them: (method, contact model, stiffness, seed, hole,
    model error, on its simulator, success), all at starts 1 mm off."""
    names = [
        "method",
        "planner.simulator.contact_model",
        "planner.simulator.point_stiffness_n_per_m",
        "planner.seed",
        "planner.simulated_hole",
        "model_error",
        "on_simulator",
        "deploy_success_rate",
    ]
    frame = pd.DataFrame(rows, columns=names).assign(start_std_m=0.001)
    return frame.assign(run=frame[names[:5]].agg("/".join, axis=1))  # a training: its levels


def test_point_trained_runs_are_compared_with_their_prediction_and_their_twins():
    """Each point-trained run is read on the real scene, against its simulator's prediction and
    against the run trained on the real scene's model at the same seed key; runs trained on a
    sensed hole and other model errors stay out."""
    from pih.analysis.training_model import REAL_SCENE, training_model_table

    keys = [
        "planner.goal",
        "planner.seed",
        "planner.simulator.contact_model",
        "planner.simulator.point_stiffness_n_per_m",
        "planner.simulated_hole",
    ]
    frame = deployments(
        [
            ("one_level", "None", "None", "0", "true_hole", "none", True, 0.5),
            ("one_level", "None", "None", "1", "true_hole", "none", True, 0.2),
            ("one_level", "None", "None", "1", "sensed_per_run", "none", True, 0.0),
            ("one_level", "None", "None", "0", "true_hole", "friction", False, 0.0),
            ("one_level", "point", "10000000.0", "0", "true_hole", "none", False, 0.3),
            ("one_level", "point", "10000000.0", "0", "true_hole", "point_1e7", True, 0.9),
            ("one_level", "point", "10000000.0", "0", "true_hole", "point_1e6", False, 0.0),
            ("one_level", "point", "10000000.0", "1", "true_hole", "none", False, 0.2),
            ("one_level", "point", "10000000.0", "1", "true_hole", "point_1e7", True, 0.2),
        ]
    )
    # A run's wall time rides on its own deployment's row (NaN on its redeployments').
    seconds = frame["planner.simulator.contact_model"].map({"None": 600.0, "point": 150.0})
    frame["run_seconds"] = seconds.where(frame["model_error"] == "none")
    table = training_model_table(frame, keys, 0.001).set_index("training_model")
    assert list(table.index) == [REAL_SCENE, "point, 1e+07 N/m"]
    real, point = table.loc[REAL_SCENE], table.loc["point, 1e+07 N/m"]
    assert real["runs"] == 2 and real["deploy_success_rate"] == pytest.approx(0.35)
    assert real["pairs"] == 0 and np.isnan(real["sign_test_p"])
    assert point["runs"] == 2 and point["deploy_success_rate"] == pytest.approx(0.25)
    assert point["predicted_success_rate"] == pytest.approx(0.55)
    assert point["runs_mispredicted"] == 1 and point["mean_gap"] == pytest.approx(-0.3)
    assert (point["pairs"], point["better"], point["worse"], point["tied"]) == (2, 0, 1, 1)
    assert (real["median_run_s"], point["median_run_s"]) == (600.0, 150.0)
    assert training_model_table(frame, ["planner.seed"], 0.001).empty
    # A run redeployed at its own deployment's std counts once.
    again = pd.concat([frame, frame.iloc[[4]]], ignore_index=True)
    assert training_model_table(again, keys, 0.001).equals(training_model_table(frame, keys, 0.001))
