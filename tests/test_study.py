"""Sweep overrides and the aggregates of the study."""

import math
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from scipy import stats

from pih.analysis.aggregate import (
    ablation_table,
    cost_bands,
    figure_bands,
    paired_table,
    robustness_pairs,
    robustness_table,
    success_table,
)
from pih.analysis.run_summary import final_success_fraction
from pih.analysis.statistics import sign_test_p, wilson_interval
from pih.config import ConfigError, to_mapping
from pih.planning.config import PlannerConfig
from pih.scene.config import SceneConfig
from pih.study.config import override, resolve, sweep_points
from pih.study.points import seed_key, variant_overrides


def base_config() -> dict:
    return {"scene": to_mapping(SceneConfig()), "planner": to_mapping(PlannerConfig())}


def test_override_sets_dotted_paths_and_rejects_unknown_keys():
    scene, planner = resolve(
        base_config(), {"planner.sensing.bias_m": 0.0, "scene.material.friction": 0.3}
    )
    assert planner.sensing.bias_m == 0.0 and scene.material.friction == 0.3
    with pytest.raises(ConfigError, match="planner.sensing.bias"):
        override(base_config(), {"planner.sensing.bias": 0.0})


def test_wilson_interval_known_values():
    low, high = wilson_interval(11, 11)
    assert high == 1.0 and low == pytest.approx(0.7412, abs=1e-4)
    low, high = wilson_interval(0, 11)
    assert low == pytest.approx(0.0, abs=1e-12) and high == pytest.approx(0.2588, abs=1e-4)
    assert all(math.isnan(v) for v in wilson_interval(0, 0))
    # Every rate lies inside its interval, exactly at the ends (a figure's error bars need it).
    for trials in range(1, 60):
        for successes in range(trials + 1):
            low, high = wilson_interval(successes, trials)
            assert low <= successes / trials <= high
    assert wilson_interval(6, 6)[1] == 1.0 and wilson_interval(0, 11)[0] == 0.0


def test_bands_and_success_table_per_method_and_dimension():
    runs = pd.DataFrame(
        {
            "method": ["a", "a", "b", "b"],
            "iteration": [1, 1, 1, 1],
            "cost": [1.0, 3.0, 10.0, 12.0],
            "planner.seed": ["0", "1", "0", "1"],
        }
    )
    bands = cost_bands(runs, ["planner.goal", "planner.seed"])
    overall = bands[(bands["dimension"] == "all") & (bands["method"] == "a")].iloc[0]
    assert (overall["mean"], overall["var"], overall["count"]) == (2.0, 2.0, 2)
    per_seed = bands[(bands["dimension"] == "planner.seed") & (bands["method"] == "b")]
    assert per_seed.set_index("level")["mean"].to_dict() == {"0": 10.0, "1": 12.0}
    # Fig. 9 draws the overall bands; an ablation's variants (other designs, other cost scales)
    # one band each.
    assert figure_bands(bands).equals(bands[bands["dimension"] == "all"])
    variants = cost_bands(runs.assign(variant=["p", "q", "p", "q"]), ["planner.goal", "variant"])
    drawn = figure_bands(variants).set_index("method")["mean"].to_dict()
    assert drawn == {
        "a, variant p": 1.0,
        "a, variant q": 3.0,
        "b, variant p": 10.0,
        "b, variant q": 12.0,
    }
    summaries = pd.DataFrame(
        {
            "method": ["a", "a", "b"],
            "planner.seed": ["0", "1", "0"],
            "deploy_success_rate": [1.0, 0.5, 0.0],
            "final_mean_deploy_success_rate": [0.5, 0.5, math.nan],
            "final_iteration_success": [True, False, False],
            "first_success_iteration": [4, None, None],
            "goal_iteration": [3, None, 10],
            "final_success_fraction": [1.0, 0.0, 0.5],
            "mean_policy_last10_success": [0.8, 0.4, math.nan],
            "diverged_fraction": [0.1, 0.0, 0.2],
            "retried_fraction": [0.04, 0.02, 0.0],
            "deploy_diverged_fraction": [0.0, 0.5, 1.0],
            "deploy_repeats_training": [True, True, False],
        }
    )
    table = success_table(summaries, ["planner.goal", "planner.seed"])
    overall = table[table["dimension"] == "all"].set_index("method")
    assert overall.loc["a", "deploy_success_rate"] == 0.75
    assert (overall.loc["a", "deploy_ci_low"], overall.loc["a", "deploy_ci_high"]) == pytest.approx(
        wilson_interval(1.5, 2)
    )
    assert overall.loc["a", "final_mean_deploy_success_rate"] == 0.5
    assert overall.loc["a", "final_mean_deploy_ci_high"] == pytest.approx(wilson_interval(1, 2)[1])
    assert math.isnan(overall.loc["b", "final_mean_deploy_ci_low"])
    # A run without a final-mean deployment (NaN) is no observation of its interval.
    pooled = success_table(summaries.assign(method="a"), ["planner.goal", "planner.seed"])
    pooled = pooled[pooled["dimension"] == "all"].iloc[0]
    assert pooled["runs"] == 3 and pooled["final_mean_deploy_success_rate"] == 0.5
    assert (pooled["final_mean_deploy_ci_low"], pooled["final_mean_deploy_ci_high"]) == (
        pytest.approx(wilson_interval(1, 2))
    )
    # One of two runs never reached success: the median is "never" (NaN), not the other run's.
    assert math.isnan(overall.loc["a", "median_first_success_iteration"])
    assert overall.loc["b", "median_goal_iteration"] == 10
    assert overall.loc["b", "mean_last10_success_fraction"] == 0.5
    assert overall.loc["a", "mean_policy_last10_success_fraction"] == pytest.approx(0.6)
    assert math.isnan(overall.loc["b", "mean_policy_last10_success_fraction"])
    assert overall.loc["a", "deploy_diverged_fraction"] == 0.25
    assert overall.loc["a", "retried_rollout_fraction"] == pytest.approx(0.03)
    assert overall.loc["a", "first_success_rate"] == 0.5
    assert overall.loc["a", "runs_repeating_training"] == 2
    assert overall.loc["b", "runs_repeating_training"] == 0
    seed_one = table[(table["dimension"] == "planner.seed") & (table["level"] == "1")]
    assert seed_one["method"].tolist() == ["a"] and seed_one["runs"].tolist() == [1]
    # A dimension with one level would only repeat the overall rows: it gets none.
    one_seed = summaries.assign(**{"planner.seed": "0"})
    dimensions = success_table(one_seed, ["planner.goal", "planner.seed"])["dimension"]
    assert set(dimensions) == {"all"}
    # The ablation table pools the replicates (seeds, starts) and keeps the compared dimensions.
    dims = pd.DataFrame({"dimension": ["all", "planner.seed", "variant", "planner.start_x_m"]})
    assert ablation_table(dims)["dimension"].tolist() == ["all", "variant"]


def test_sign_test_known_values():
    assert sign_test_p(12, 0) == pytest.approx(2 / 2**12)  # 0.00049, README's 12 of 12
    assert sign_test_p(10, 0) == pytest.approx(2 / 2**10)
    assert sign_test_p(3, 3) == 1.0 and sign_test_p(0, 0) == 1.0
    assert sign_test_p(5, 2) == sign_test_p(2, 5) == pytest.approx(2 * (1 + 7 + 21) / 2**7)


def test_pair_statistics_say_what_the_pairs_could_show():
    from pih.analysis.statistics import (
        detectable_difference,
        least_sign_test_p,
        pair_counts,
        paired_difference_interval,
    )

    t_975 = stats.t.ppf(0.975, 10)
    # 11 pairs, 10 of them both at 10 of 10 and one a trial worse: the ceiling hides any gain,
    # and the interval, its spread floored at one trial in ten, reaches both ways.
    ceiling = pd.Series([1.0] * 11)
    one_worse = pd.Series([1.0] * 10 + [0.9])
    counts = pair_counts(one_worse, ceiling)
    assert (counts["better"], counts["worse"], counts["tied"]) == (0, 1, 10)
    assert (counts["tied_at_ceiling"], counts["tied_at_floor"]) == (10, 0)
    assert counts["least_possible_p"] == 1.0 and counts["sign_test_p"] == 1.0
    half = t_975 * 0.1 / np.sqrt(11)
    assert counts["difference_ci_low"] == pytest.approx(-0.1 / 11 - half)
    assert counts["difference_ci_high"] == pytest.approx(-0.1 / 11 + half)
    assert counts["difference_ci_high"] > 0
    # All pairs alike are no point interval: a rerun would spread them.
    assert paired_difference_interval(ceiling, ceiling) == pytest.approx((-half, half))
    assert paired_difference_interval(ceiling, ceiling * 0) == pytest.approx((1 - half, 1.0))
    # The t-interval of the pairs (ours against mean_sensed_hole): it holds 0.
    ours = np.array([0.3, 0, 0, -0.1, 0.3, 0.1, 0, 0, 0.2, 0, 0])
    low, high = paired_difference_interval(ours, np.zeros(11))
    assert (round(low, 2), round(high, 2)) == (-0.02, 0.16)
    t_sum = t_975 + stats.t.ppf(0.8, 10)
    assert detectable_difference(np.zeros(11)) == pytest.approx(t_sum * 0.1 / np.sqrt(11))
    spread = np.array([0.0, 0.5, -0.5, 1.0, 0.0, 0.2, 0.3, -0.2, 0.0, 0.1, 0.4])
    assert detectable_difference(spread) == pytest.approx(t_sum * spread.std(ddof=1) / np.sqrt(11))
    # Too few pairs for the sign test to reach 0.05, or nothing in [-1, 1] detectable: none.
    assert np.isnan(detectable_difference(np.zeros(5)))
    assert not np.isnan(detectable_difference(np.zeros(6)))
    assert np.isnan(detectable_difference(np.array([1.0, -1.0] * 3)))
    # 2^(1-k): 5 untied pairs cannot reach 0.05, 6 can.
    assert least_sign_test_p(5) == 0.0625 and least_sign_test_p(6) == 0.03125
    assert least_sign_test_p(0) == 1.0
    # A clear difference: the interval holds the mean and excludes 0.
    a = pd.Series([1.0, 0.9, 1.0, 0.8, 1.0, 1.0, 0.7, 1.0])
    b = pd.Series([0.2, 0.4, 0.0, 0.3, 0.5, 0.1, 0.0, 0.6])
    low, high = paired_difference_interval(a, b)
    assert 0 < low < (a - b).mean() < high <= 1
    # A point one method lacks is no pair; both at 0 of 10 is a tie at the floor.
    assert pair_counts(a, b.iloc[:5])["pairs"] == 5
    assert pair_counts(ceiling * 0, ceiling * 0)["tied_at_floor"] == 11


def test_paired_table_compares_methods_at_the_points_both_ran():
    keys = ["planner.goal", "variant", "planner.seed"]
    summaries = pd.DataFrame(
        {
            "method": ["bilevel", "one_level"] * 4 + ["bilevel"],
            "variant": ["paper"] * 4 + ["other"] * 4 + ["paper"],
            "planner.seed": ["0", "0", "1", "1", "0", "0", "1", "1", "2"],
            "deploy_success_rate": [1.0, 0.2, 0.5, 0.5, 0.9, 0.0, 0.0, 0.3, 1.0],
        }
    )
    table = paired_table(summaries, keys)
    # Seed 2 ran one method only: no pair. Seeds are replicates: no per-seed rows.
    assert table["dimension"].tolist() == ["all", "variant", "variant"]
    overall = table.iloc[0]
    assert (overall["method"], overall["versus"]) == ("bilevel", "one_level")
    assert (overall["pairs"], overall["better"], overall["worse"], overall["tied"]) == (4, 2, 1, 1)
    assert overall["mean_difference"] == pytest.approx((0.8 + 0.0 + 0.9 - 0.3) / 4)
    assert overall["sign_test_p"] == pytest.approx(sign_test_p(2, 1))
    paper = table[table["level"] == "paper"].iloc[0]
    assert (paper["pairs"], paper["better"], paper["tied"]) == (2, 1, 1)
    with pytest.raises(ValueError):  # two runs of one method at one point cannot be paired
        paired_table(pd.concat([summaries, summaries.iloc[:1]]), keys)


def test_variant_pairs_compare_each_variant_with_the_reference_per_method():
    from pih.analysis.aggregate import variant_pairs

    keys = ["planner.goal", "variant", "planner.seed"]
    summaries = pd.DataFrame(
        {
            "method": ["bilevel/explored_argmin", "one_level"] * 2
            + ["bilevel/explored_argmin"] * 2
            + ["bilevel/explored_argmin", "one_level"] * 2,
            "variant": ["paper"] * 4 + ["tilt"] * 2 + ["per_run"] * 4,
            "planner.seed": ["0", "0", "1", "1", "0", "1", "0", "0", "1", "1"],
            "deploy_success_rate": [0.2, 0.1, 0.5, 0.0, 1.0, 1.0, 0.2, 0.3, 0.1, 0.0],
        }
    )
    table = variant_pairs(summaries, keys, reference="paper").set_index(["level", "method"])
    # tilt has no one-level runs (they would be paper's): one row; per_run: one per method.
    assert sorted(table.index) == [
        ("per_run", "bilevel/explored_argmin"),
        ("per_run", "one_level"),
        ("tilt", "bilevel/explored_argmin"),
    ]
    tilt = table.loc[("tilt", "bilevel/explored_argmin")]
    assert tilt["versus"] == "bilevel/explored_argmin at variant paper"
    assert (tilt["pairs"], tilt["better"], tilt["worse"]) == (2, 2, 0)
    assert tilt["mean_difference"] == pytest.approx((0.8 + 0.5) / 2)
    one_level = table.loc[("per_run", "one_level")]
    assert (one_level["better"], one_level["worse"], one_level["tied"]) == (1, 0, 1)
    assert variant_pairs(summaries, ["planner.goal", "planner.seed"], "paper").empty


def test_robustness_table_per_method_and_start_std_counts_each_run_once():
    deployments = pd.DataFrame(
        {
            "method": ["bilevel", "one_level"] * 2 + ["bilevel", "one_level"] * 2,
            "run": ["b0", "o0", "b1", "o1"] * 2,
            "planner.seed": ["0", "0", "1", "1"] * 2,
            "start_std_m": [0.0] * 4 + [0.001] * 4,
            "deploy_success_rate": [1.0, 0.1, 1.0, 0.0, 0.8, 0.2, 1.0, 0.0],
        }
    )
    again = deployments.iloc[:1]  # a redeployment at the run's own std, identical by design
    table = robustness_table(pd.concat([deployments, again]), ["planner.goal", "planner.seed"])
    bilevel = table[table["method"] == "bilevel"].set_index("start_std_m")
    assert bilevel["runs"].tolist() == [2, 2]
    assert bilevel.loc[0.001, "deploy_success_rate"] == pytest.approx(0.9)
    assert bilevel["runs_all_inserted"].tolist() == [2, 1]
    low, high = wilson_interval(1.8, 2)
    assert (bilevel.loc[0.001, "deploy_ci_low"], bilevel.loc[0.001, "deploy_ci_high"]) == (
        low,
        high,
    )
    pairs = robustness_pairs(deployments, ["planner.goal", "planner.seed"])
    assert pairs["level"].tolist() == ["0.0", "0.001"] and (pairs["better"] == 2).all()
    # A compared dimension (an ablation's variant) splits the table; the replicates do not.
    variants = deployments.assign(variant=["a", "a", "b", "b"] * 2)
    split = robustness_table(variants, ["planner.goal", "variant", "planner.seed"])
    assert list(split.columns[:3]) == ["method", "variant", "start_std_m"]
    assert len(split) == 2 * 2 * 2 and (split["runs"] == 1).all()


def test_sweep_points_skip_repeated_one_level_runs_and_reject_bad_sweeps():
    sweep = {
        "planner.start_x_m": [-0.04, -0.03],
        "planner.goal": ["sensed_hole", "explored_argmin", "deepest_explored"],
        "planner.outer.goal_tilt": ["explored", "sensed"],
    }
    points = sweep_points(sweep)
    # One-level ignores the outer rules' settings: one run per start, bilevel one per setting.
    assert len(points) == 2 * (1 + 2 * 2)
    one_level = [p for p in points if p["planner.goal"] == "sensed_hole"]
    assert {p["planner.outer.goal_tilt"] for p in one_level} == {"explored"}
    # So do the stable-goal one-level variants (issue 69): one run each per start.
    stable = sweep_points({**sweep, "planner.goal": ["mean_sensed_hole", "explored_argmin"]})
    assert len(stable) == 2 * (1 + 2)
    # One-level depends on which weights it deploys: one run per deploy policy.
    policies = sweep_points(
        {
            "planner.goal": ["sensed_hole", "explored_argmin"],
            "planner.deploy_policy": ["final_mean", "last_inserted_mean"],
        }
    )
    assert len(policies) == 4
    # A study whose config fixes the goal to the sensed hole makes one run per start, whatever
    # the outer settings it sweeps; a bilevel goal makes one per setting.
    tilts = {"planner.start_x_m": [-0.04, -0.03], "planner.outer.goal_tilt": ["explored", "sensed"]}
    assert len(sweep_points(tilts, goal="sensed_hole")) == 2
    assert len(sweep_points(tilts, goal="explored_argmin")) == 4
    with pytest.raises(ConfigError, match=r"sweep\.planner\.seed: repeated level"):
        sweep_points({"planner.seed": [0, 0]})
    with pytest.raises(ConfigError, match="planner.seed.*planner.optimizer.seed"):
        sweep_points({"planner.seed": [0], "planner.optimizer.seed": [1]})


def test_final_success_fraction_uses_the_last_best_rollouts():
    rollouts = pd.DataFrame(
        {
            "phase": ["train"] * 6 + ["deploy"],
            "iteration": [1, 1, 2, 2, 3, 3, 3],
            "is_best": [True, False, False, True, True, False, False],
            "success": [True, False, False, False, True, True, False],
        }
    )
    assert final_success_fraction(rollouts, last=2) == 0.5
    assert final_success_fraction(rollouts, last=3) == pytest.approx(2 / 3)


def test_variants_are_named_overrides_swept_like_a_dimension():
    variants = {
        "paper": {},
        "tilt": {"planner.outer.goal_tilt": "sensed"},
        "once": {"planner.sensing.redraw": "per_run"},
    }
    sweep = {"planner.goal": ["sensed_hole", "deepest_explored"], "variant": list(variants)}
    points = sweep_points(sweep, variants)
    # One-level ignores "tilt" (an outer-level change) but not "once".
    assert [(p["planner.goal"], p["variant"]) for p in points] == [
        ("sensed_hole", "paper"),
        ("sensed_hole", "once"),
        ("deepest_explored", "paper"),
        ("deepest_explored", "tilt"),
        ("deepest_explored", "once"),
    ]
    config = {**base_config(), "variants": variants}
    _, planner = resolve(config, {"variant": "tilt", "planner.goal": "deepest_explored"})
    assert planner.outer.goal_tilt == "sensed" and planner.goal == "deepest_explored"
    # Variants and methods share their random draws; other levels do not.
    assert seed_key({"variant": "tilt", "planner.seed": 1}) == seed_key({"planner.seed": 1})
    with pytest.raises(ConfigError, match="sweep.variant.*'nope'"):
        sweep_points({"variant": ["nope"]}, variants)
    with pytest.raises(ConfigError, match="variant 'nope'"):
        resolve(config, {"variant": "nope"})
    # What a run records its variant as standing for (pooling checks it).
    assert variant_overrides(config, {"variant": "tilt"}) == variants["tilt"]
    assert variant_overrides(config, {"planner.seed": 1}) == {}


def test_validation_variants_apply_over_the_validation_scene_and_name_bad_keys():
    from pih.config import from_mapping
    from pih.study.config import ValidationSection

    section = ValidationSection(
        scene_overrides={"material.margin_m": 0.0, "hole.fillet_radius_m": 1e-4},
        variants={"base": {}, "sap": {"solver.discrete_contact_approximation": "sap"}},
        figure_variants=("base",),
    )
    scene = to_mapping(SceneConfig())
    base, sap = section.scene(scene, "base"), section.scene(scene, "sap")
    assert base.material.margin_m == sap.material.margin_m == 0.0  # shared overrides
    assert sap.hole.fillet_radius_m == 1e-4
    assert (
        base.solver.discrete_contact_approximation,
        sap.solver.discrete_contact_approximation,
    ) == (
        SceneConfig().solver.discrete_contact_approximation,
        "sap",
    )
    assert base.hole.depth_m == section.experiment.hole_depth_m  # deep validation hole
    removed = ValidationSection(
        variants={"t": {"solver.discrete_contact_approximation": "tamsi"}}, figure_variants=("t",)
    )
    with pytest.raises(ConfigError, match=r"discrete_contact_approximation: 'tamsi' is no longer"):
        removed.scene(scene, "t")
    bad = ValidationSection(variants={"x": {"material.no_such_key": 1.0}}, figure_variants=("x",))
    with pytest.raises(
        ConfigError, match=r"^validation\.variants\.x\.material\.no_such_key: no config key"
    ):
        bad.scene(scene, "x")
    data = to_mapping(section)
    for edit, key in (
        (lambda d: d.update(figure_variants=["nope"]), "figure_variants"),
        (lambda d: d.update(variants={"Bad Name": {}}), "variants"),
        (lambda d: d.update(variants={}), "variants"),
        (lambda d: d["variants"].update(base=3), r"validation\.variants\.base"),
    ):
        broken = to_mapping(section)
        edit(broken)
        with pytest.raises(ConfigError, match=key):
            from_mapping(ValidationSection, broken, "validation")
    assert from_mapping(ValidationSection, data, "validation") == section


def test_a_command_line_config_file_replaces_the_validation_variants_whole(tmp_path):
    from pih.study.config import read_config_files

    config = {
        "validation": {"offsets_m": [0.001], "variants": {"a": {}, "b": {}, "c": {}}},
        "sweep": {"planner.seed": [0, 1]},
    }
    own = tmp_path / "own.yaml"
    own.write_text("validation:\n  variants: {b: {material.margin_m: 0.0}}\n")
    read_config_files(config, [], [str(own)])
    assert config["validation"]["variants"] == {"b": {"material.margin_m": 0.0}}
    assert config["validation"]["offsets_m"] == [0.001]  # other keys merge as Snakemake does
    assert config["sweep"] == {"planner.seed": [0, 1]}  # a file without a sweep keeps it


def test_an_empty_scene_overrides_in_a_config_file_clears_the_defaults():
    """config/quasi_static.yaml and config/smoke.yaml set ``validation.scene_overrides: {}`` to
    run the validation scene without the default study's stiction tolerance: merged key by key,
    an empty mapping would keep it."""
    from pih.study.config import load_config

    root = Path(__file__).resolve().parents[1]
    default = load_config([str(root / "config" / "config.yaml")])["validation"]
    assert default["scene_overrides"] == {"solver.stiction_tolerance_m_per_s": 1.0e-5}
    for overlay in ("quasi_static.yaml", "smoke.yaml"):
        files = [str(root / "config" / name) for name in ("config.yaml", overlay)]
        assert load_config(files)["validation"]["scene_overrides"] == {}, overlay


def test_deployments_that_only_repeat_a_training_rollout_are_recognised():
    from pih.analysis.run_summary import repeats_training

    def rows(phase, *poses):
        return pd.DataFrame(
            {
                "phase": phase,
                "final_bottom_x_m": [p[0] for p in poses],
                "final_bottom_y_m": [p[1] for p in poses],
                "final_bottom_theta_rad": [p[2] for p in poses],
            }
        )

    means = rows("mean", (0.01, -0.01, 0.0), (0.0, -0.0099, 0.001))
    same = rows("deploy", (0.0, -0.0099, 0.001), (0.0, -0.0099, 0.001))
    assert repeats_training(pd.concat([means, same]))
    # One trial that ended elsewhere (a fresh sensing or an offset start) is a real deployment.
    other = rows("deploy", (0.0, -0.0099, 0.001), (0.0, -0.0099, 0.0010001))
    assert not repeats_training(pd.concat([means, other]))
    assert not repeats_training(means) and not repeats_training(same)


def test_each_runs_first_sensing_sits_beside_its_outcome():
    """The per-run table: the first training iteration's sensed hole relative to the real one,
    and each run's deployments from the training start and from the headline's offset starts on
    the training scene (not under a model error); by method, then sensing error."""
    from pih.analysis.aggregate import per_run_table
    from pih.analysis.run_summary import first_sensing_error

    rollouts = pd.DataFrame(
        {
            "phase": ["train", "train", "train", "deploy"],
            "iteration": [2, 1, 1, 1],
            "rollout": [0, 1, 0, 0],
            "sensed_hole_x_m": [0.009, 0.005, 0.003, 0.0],
            "sensed_hole_y_m": [-0.010, -0.010, -0.006, -0.010],
        }
    )
    assert first_sensing_error(rollouts, (0.0, -0.01)) == pytest.approx(
        {"first_sensing_dx_m": 0.003, "first_sensing_dy_m": 0.004, "first_sensing_error_m": 0.005}
    )

    summaries = pd.DataFrame(
        {
            "method": ["one_level", "one_level", "bilevel/deepest_explored"],
            "run": ["a", "b", "c"],
            "planner.start_x_m": ["-0.04", "-0.03", "-0.04"],
            "first_sensing_dx_m": [0.004, -0.001, 0.004],
            "first_sensing_dy_m": [0.0, 0.0, 0.0],
            "first_sensing_error_m": [0.004, 0.001, 0.004],
            "goal_iteration": [None, 3, 5],
            "deploy_success_rate": [0.1, 0.5, 1.0],
            "start_std_m": [0.0, 0.0, 0.0],
            "model_error": ["none"] * 3,
        }
    )
    redeployed = pd.DataFrame(
        {
            "method": ["one_level", "one_level", "bilevel/deepest_explored", "one_level"],
            "run": ["a", "b", "c", "a"],
            "start_std_m": [0.001, 0.001, 0.001, 0.001],
            "model_error": ["none", "none", "none", "friction_0.3"],
            "deploy_success_rate": [0.2, 0.6, 0.9, 0.0],
        }
    )
    deployments = pd.concat([summaries, redeployed], ignore_index=True)
    table = per_run_table(summaries, deployments, ["planner.goal", "planner.start_x_m"])
    assert list(table["run"]) == ["c", "b", "a"]
    assert list(table["offset_deploy_success_rate"]) == [0.9, 0.6, 0.2]
    assert set(table["offset_start_std_m"]) == {0.001}
    assert list(table.columns[:3]) == ["method", "planner.start_x_m", "run"]


def test_a_redeployment_records_the_simulator_of_the_scene_it_deployed_on():
    """Under a model error the redeployment's record names the real scene's settings, not the
    training run's (which the run's own record keeps)."""
    from pih.planning.run_record import RecordedRun
    from pih.study.redeployment_record import redeployment_fields

    root = Path(__file__).resolve().parents[1]
    rollouts = next((root / "published" / "default" / "planning").glob("*/rollouts.parquet"))
    run = RecordedRun.read(rollouts)
    fields = redeployment_fields(
        run, 0.001, {"name": "slippery", "settings": {"material.friction": 0.5}}
    )
    assert fields["simulator"]["friction"] == 0.5 != run.record["simulator"]["friction"]
    assert fields["config"]["scene"]["material"]["friction"] == 0.5
    assert redeployment_fields(run, 0.001, {})["simulator"] == run.record["simulator"]
