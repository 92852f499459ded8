"""pih compare: whether a study reproduced another, at the level of its conclusions and of its
data, and what the provenance says about why the data differ."""

import shutil
from pathlib import Path

import pandas as pd
import pytest

from pih.__main__ import main
from pih.publishing.compare import compare
from pih.publishing.scope import run_directories

ROOT = Path(__file__).resolve().parents[1]


def tree(root):
    """A small results tree: the robustness and paired tables and two runs' data."""
    summary = root / "planning" / "summary"
    summary.mkdir(parents=True)
    pd.DataFrame(
        {
            "method": ["bilevel/deepest_explored", "one_level"],
            "start_std_m": [0.001, 0.001],
            "runs": [11, 11],
            "deploy_success_rate": [0.8, 0.2],
            "deploy_ci_low": [0.5, 0.05],
            "deploy_ci_high": [0.94, 0.5],
            "runs_all_inserted": [6, 0],
        }
    ).to_parquet(summary / "robustness.parquet")
    pd.DataFrame(
        {
            "method": ["bilevel/deepest_explored"],
            "versus": ["one_level"],
            "dimension": ["all"],
            "level": ["all"],
            "pairs": [11],
            "better": [9],
            "worse": [0],
            "tied": [2],
            "mean_difference": [0.6],
            "sign_test_p": [0.0039],
        }
    ).to_parquet(summary / "paired.parquet")
    for start in (-0.04, -0.03):
        run_file(root / "planning" / f"start~{start}_seed~0" / "rollouts.parquet", start)
    return root


def run_file(path, start, success=True, point=None, config=None, **columns):
    """A run's ``rollouts.parquet`` with the provenance that names its sweep point (and, where
    given, the config it recorded)."""
    from pih.records.outputs import write_table
    from pih.records.provenance import record

    point = point or {"planner.start_x_m": start, "planner.goal": "deepest_explored"}
    rows = pd.DataFrame({"phase": ["deploy"], "success": [success], **columns})
    units = {c: ("1", c) for c in rows.columns}
    path.parent.mkdir(parents=True, exist_ok=True)
    write_table(rows, path, record("plan", point=point, config=config), units)


def validation_table(path, r_f_x):
    pd.DataFrame(
        {"variant": ["hydroelastic"], "alignment": ["chamfer_start"], "offset": ["1 mm"]}
        | {"r_f_x": [r_f_x], "r_f_z": [0.9]}
        | {c: [5.0] for c in ("rel_err_initial_f_x_pct", "rel_err_final_f_x_pct")}
        | {c: [5.0] for c in ("rel_err_initial_f_z_pct", "rel_err_final_f_z_pct")}
        | {"rel_err_final_theta_pct": [1.0]}
    ).to_parquet(path)


def copy(old, new):
    shutil.copytree(old, new)
    return new


def test_identical_trees_reproduce_at_both_levels(tmp_path, capsys):
    old = tree(tmp_path / "old")
    new = copy(old, tmp_path / "new")
    result = compare(old, new)
    assert result.differences == [] and result.items == 2 * 5 + 6 + 2
    assert result.conclusions_hold and len(result.checks) == 2 + 1 and result.causes == []
    assert main(["compare", str(old), str(new)]) == 0
    out = capsys.readouterr().out.splitlines()
    # The answer first, in one line; the closing lines as before.
    assert out[0] == (
        f"pih compare: {new} reproduced {old}: 3 of 3 conclusions hold, 0 of 18 data items differ"
    )
    assert out[1] == "data: 0 of 18 items differ: the same (within --rtol 1e-09)"
    assert out[2].startswith("conclusions: 3 of 3 hold") and out[2].endswith(
        "reproduced " + str(old)
    )


def test_changed_data_with_the_same_conclusions_reproduce(tmp_path, capsys):
    old = tree(tmp_path / "old")
    new = copy(old, tmp_path / "new")
    robustness = new / "planning" / "summary" / "robustness.parquet"
    pd.read_parquet(robustness).assign(deploy_success_rate=[0.7, 0.2]).to_parquet(robustness)
    run_file(new / "planning" / "start~-0.03_seed~0" / "rollouts.parquet", -0.03, success=False)
    (new / "planning" / "start~-0.04_seed~0" / "rollouts.parquet").unlink()
    assert main(["compare", str(old), str(new)]) == 0  # 0.7 is inside [0.5, 0.94]
    out = capsys.readouterr().out.splitlines()[1:]
    assert out[:3] == [
        (
            "planning/summary/robustness.parquet: method=bilevel/deepest_explored, "
            "start_std_m=0.001, model_error=none: deploy_success_rate: 0.8 -> 0.7"
        ),
        "planning/start~-0.03_seed~0/rollouts.parquet: data: one table -> another",
        "planning/start~-0.04_seed~0/rollouts.parquet: run file: present -> missing",
    ]
    assert out[3] == "data: 3 of 18 items differ: NOT the same (within --rtol 1e-09)"
    assert out[-1].startswith("conclusions: 3 of 3 hold")
    # A tolerance admits a small difference in numbers (not in run data).
    pd.read_parquet(robustness).assign(deploy_success_rate=[0.8 + 1e-12, 0.2]).to_parquet(
        robustness
    )
    assert all("robustness" not in d.where for d in compare(old, new).differences)


def test_a_rate_outside_the_interval_or_a_flipped_pair_is_not_reproduced(tmp_path, capsys):
    old = tree(tmp_path / "old")
    new = copy(old, tmp_path / "new")
    robustness = new / "planning" / "summary" / "robustness.parquet"
    pd.read_parquet(robustness).assign(deploy_success_rate=[0.3, 0.2]).to_parquet(robustness)
    paired = new / "planning" / "summary" / "paired.parquet"
    pd.read_parquet(paired).assign(better=[1], worse=[3]).to_parquet(paired)
    assert main(["compare", str(old), str(new)]) == 1
    out = capsys.readouterr().out.splitlines()
    assert (
        "FAILS: planning/summary/robustness.parquet: method=bilevel/deepest_explored, "
        "start_std_m=0.001, model_error=none: deployment success 0.3 inside [0.5, 0.94]" in out
    )
    assert any(
        line.startswith("FAILS: planning/summary/paired.parquet")
        and line.endswith("sign (pairs better/worse) + (9/0) -> - (1/3)")
        for line in out
    )
    assert out[-1].startswith("conclusions: 1 of 3 hold") and "NOT reproduced" in out[-1]
    assert out[0].startswith(f"pih compare: {new} NOT reproduced {old}: 1 of 3 conclusions hold")


def test_a_missing_row_counts_every_number_it_holds(tmp_path):
    old = tree(tmp_path / "old")
    new = copy(old, tmp_path / "new")
    robustness = new / "planning" / "summary" / "robustness.parquet"
    pd.read_parquet(robustness).iloc[:1].to_parquet(robustness)
    result = compare(old, new)
    assert result.differing_items() == 5 <= result.items == 18
    assert not result.conclusions_hold  # the row's rate is missing: its check fails


def test_validation_r_holds_within_its_tolerance(tmp_path):
    old = tree(tmp_path / "old")
    (old / "validation").mkdir()
    validation_table(old / "validation" / "comparison.parquet", 0.95)
    new = copy(old, tmp_path / "new")
    validation_table(new / "validation" / "comparison.parquet", 0.96)
    assert compare(old, new).conclusions_hold
    assert not compare(old, new, r_tolerance=0.005).conclusions_hold
    validation_table(new / "validation" / "comparison.parquet", 0.90)
    failed = [c for c in compare(old, new).checks if not c.holds]
    assert [c.what for c in failed] == ["r_f_x 0.9500 -> 0.9000 (within 0.02)"]


def test_the_likely_cause_of_a_data_difference_comes_from_the_provenance(tmp_path, capsys):
    from pih.records.outputs import read_provenance, write_table
    from pih.records.provenance import record

    new = tree(tmp_path / "new")
    old = copy(new, tmp_path / "old")
    now = read_provenance(new / "planning" / "start~-0.04_seed~0" / "rollouts.parquet")
    for start, success in ((-0.04, False), (-0.03, True)):
        point = {"planner.start_x_m": start, "planner.goal": "deepest_explored"}
        made = record("plan", point=point)
        made["packages"]["drake"] = "1.51.1"
        del made["machine"]  # as before 0.5.0
        rows = pd.DataFrame({"phase": ["deploy"], "success": [success]})
        path = old / "planning" / f"start~{start}_seed~0" / "rollouts.parquet"
        write_table(rows, path, made, {c: ("1", c) for c in rows.columns})
    main(["compare", str(old), str(new)])
    out = capsys.readouterr().out.splitlines()
    causes = next(line for line in out if line.startswith("data: likely causes"))
    assert f"another Drake (1.51.1 -> {now['packages']['drake']})" in causes
    assert f"another CPU (not recorded -> {now['machine']['cpu']})" in causes
    assert "rollout code" not in causes and "another config" not in causes
    # Runs made with other settings (another study's config): said first, in the first line.
    for start in (-0.04, -0.03):
        path = old / "planning" / f"start~{start}_seed~0" / "rollouts.parquet"
        point = {"planner.start_x_m": start, "planner.goal": "deepest_explored"}
        made = record("plan", point=point, config={"planner": {"iterations": 3}})
        write_table(pd.read_parquet(path), path, made, {"phase": ("", "p"), "success": ("1", "s")})
    main(["compare", str(old), str(new)])
    first = capsys.readouterr().out.splitlines()[0]
    assert (
        first.startswith("pih compare: ") and "likely causes: another config in 2 of the 2" in first
    )


def test_a_tree_of_an_older_version_reproduces_on_what_both_record(tmp_path, capsys):
    """0.3.0 named run directories ``method~…_rule~…`` and its points ``planner.method`` and
    ``planner.outer.rule``; its robustness table had no ``model_error`` key and its rollouts no
    ``simulated_hole_*`` columns. Compared with a 0.4.0 tree, the same runs are the same runs."""
    new = tree(tmp_path / "new")
    for start in (-0.04, -0.03):
        path = new / "planning" / f"start~{start}_seed~0" / "rollouts.parquet"
        run_file(path, start, simulated_hole_x_m=[0.0])
    robustness = new / "planning" / "summary" / "robustness.parquet"
    pd.read_parquet(robustness).assign(model_error="none").to_parquet(robustness)
    old = tree(tmp_path / "old")
    shutil.rmtree(old / "planning" / "start~-0.04_seed~0")
    shutil.rmtree(old / "planning" / "start~-0.03_seed~0")
    for start in (-0.04, -0.03):
        point = {
            "planner.start_x_m": start,
            "planner.method": "bilevel",
            "planner.outer.rule": "deepest_explored",
        }
        path = old / "planning" / f"start~{start}_method~bilevel_rule~x" / "rollouts.parquet"
        run_file(path, start, point=point, success=start < -0.035)
    main(["compare", str(old), str(new)])
    out = capsys.readouterr().out.splitlines()
    # Only the run whose shared columns differ (success at -0.03) is named, by its new path.
    assert [
        line for line in out if not line.startswith(("data:", "conclusions:", "pih compare:"))
    ] == ["planning/start~-0.03_seed~0/rollouts.parquet: data: one table -> another"]


def test_a_tree_that_is_not_one_is_one_line(tmp_path, capsys):
    assert main(["compare", str(tmp_path), str(tmp_path / "nope")]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "not a results tree" in err[0]


@pytest.mark.slow  # remakes studies' tables from published runs: ~10 s
def test_a_bigger_old_study_is_read_at_the_new_ones_sweep_points(tmp_path, capsys):
    """A fresh default run against the sim-to-real study, which holds its runs and more: OLD is
    read at NEW's sweep points, its tables remade from those runs, and reproduces bit for bit
    (here: the published default's runs at one start and seed against the whole published
    default)."""
    from pih.analysis.pooling import find_outputs, pool
    from pih.reporting.planning_summary import write_pooled_summary

    old = ROOT / "published" / "default"
    new = tmp_path / "new"
    shutil.copytree(old / "validation", new / "validation")
    for run in sorted((old / "planning").glob("start_x_m~-0.04_*_seed~0")):
        shutil.copytree(run, new / "planning" / run.name)
    write_pooled_summary(pool(*find_outputs([new / "planning"])), new / "planning" / "summary")

    result = compare(old, new)
    assert "holds 12 planning runs: read at the 3 sweep points" in result.scope
    assert result.data_identical and result.items == compare(new, new).items
    assert result.conclusions_hold
    # A study in parts holding just NEW's runs, without tables or validation of its own (the
    # paper-scale study before its last part): its tables are remade, only what it carries is
    # compared.
    parts = tmp_path / "parts"
    for run in sorted((new / "planning").glob("start_x_m~*")):
        shutil.copytree(run, parts / "planning" / run.name)
    in_parts = compare(parts, new)
    assert "holds 3 planning runs: read at the 3 sweep points" in in_parts.scope
    assert in_parts.data_identical and in_parts.conclusions_hold
    # A run lost from NEW (its tables count it): OLD is read whole, the run missing.
    shutil.rmtree(new / "planning" / "start_x_m~-0.04_goal~sensed_hole_seed~0")
    lost = compare(old, new)
    assert lost.scope == "" and not lost.conclusions_hold


@pytest.mark.slow  # remakes studies' tables from published runs: ~10 s
def test_two_studies_that_each_hold_runs_the_other_lacks_are_read_at_their_shared_points(
    tmp_path,
):
    """The paper-scale study (seed 0 only) against a fresh default run (seeds 0-1): both are
    read at the points they share, their tables remade, and reproduce bit for bit (here: the
    published default's runs at -40 mm against its seed-0 runs); not when NEW lost a run."""
    from pih.analysis.pooling import find_outputs, pool
    from pih.reporting.planning_summary import write_pooled_summary

    published = ROOT / "published" / "default"
    trees = {"old": "start_x_m~-0.04_*", "new": "start_x_m~*_seed~0"}
    for name, pattern in trees.items():
        for run in sorted((published / "planning").glob(pattern)):
            shutil.copytree(run, tmp_path / name / "planning" / run.name)
        planning = tmp_path / name / "planning"
        write_pooled_summary(pool(*find_outputs([planning])), planning / "summary")
    old, new = tmp_path / "old", tmp_path / "new"
    shutil.copytree(published / "validation", new / "validation")

    result = compare(old, new)
    assert "holds 6 planning runs and" in result.scope
    assert "both read at the 3 sweep points they share" in result.scope
    assert result.data_identical and result.conclusions_hold
    # A run lost from NEW (its tables count it): both read whole, the runs missing.
    shutil.rmtree(new / "planning" / "start_x_m~-0.04_goal~sensed_hole_seed~0")
    lost = compare(old, new)
    assert lost.scope == "" and not lost.data_identical


def test_a_default_run_meets_its_copy_in_a_study_that_sweeps_a_key_it_fixes(tmp_path):
    """The sim-to-real study sweeps planner.simulated_hole, which the default study fixes at
    true_hole: a default run is matched to the study's true_hole run at its point, by the
    level its recorded config sets, and not to the sensed_per_run run."""
    point = {"planner.start_x_m": -0.04, "planner.goal": "deepest_explored", "planner.seed": 1}
    for tree, simulated_hole, name in (
        ("old", "true_hole", "true"),
        ("old", "sensed_per_run", "sensed"),
        ("new", None, "default"),
    ):
        swept = point | ({"planner.simulated_hole": simulated_hole} if simulated_hole else {})
        config = {"planner": {"simulated_hole": simulated_hole or "true_hole"}}
        path = tmp_path / tree / "planning" / name / "rollouts.parquet"
        run_file(path, -0.04, point=swept, config=config)

    result = compare(tmp_path / "old", tmp_path / "new")
    assert [str(d) for d in result.differences] == [
        "planning/sensed/rollouts.parquet: run file: present -> missing"
    ]
    # A tree holding both (the default study, then the sim-to-real study, in one results/) keeps
    # the two runs apart: each at its own point.
    shutil.copytree(tmp_path / "old" / "planning" / "true", tmp_path / "new" / "planning" / "true")
    keys = {"planner.simulated_hole"}
    assert sorted(p.name for p in run_directories(tmp_path / "new", keys).values()) == [
        "default",
        "true",
    ]


def test_nothing_to_check_is_not_reproduced(tmp_path):
    """Two trees without a table in common give no conclusion to check: not "reproduced"."""
    for name in ("old", "new"):
        run_file(tmp_path / name / "planning" / "start~-0.04" / "rollouts.parquet", -0.04)
    result = compare(tmp_path / "old", tmp_path / "new")
    assert result.checks == [] and result.data_identical and not result.conclusions_hold


def test_robustness_rows_at_different_levels_of_a_compared_dimension_stay_apart(tmp_path):
    """A sim-to-real study's robustness rows are per level of its training simulator: each
    level's rate is compared with the same level's, none hides another."""
    from pih.publishing.compare import HEADLINE_TABLES, ROBUSTNESS, headline_differences

    def robustness(root, sensed_rate):
        table = root / ROBUSTNESS
        table.parent.mkdir(parents=True)
        pd.DataFrame(
            {
                "method": ["one_level", "one_level"],
                "planner.simulated_hole": ["true_hole", "sensed_per_run"],
                "start_std_m": [0.001, 0.001],
                "model_error": ["none", "none"],
                "runs": [4, 4],
                "deploy_success_rate": [0.5, sensed_rate],
                "deploy_ci_low": [0.2, 0.1],
                "deploy_ci_high": [0.8, 0.7],
                "runs_all_inserted": [0, 0],
            }
        ).to_parquet(table)
        return root

    old, new = robustness(tmp_path / "old", 0.3), robustness(tmp_path / "new", 0.4)
    tables = tuple(t for t in HEADLINE_TABLES if t[0] == ROBUSTNESS)
    differences, compared = headline_differences(old, new, 1e-9, tables)
    assert compared == 2 * 5
    assert [d.what for d in differences] == [
        (
            "method=one_level, planner.simulated_hole=sensed_per_run, start_std_m=0.001, "
            "model_error=none: deploy_success_rate"
        )
    ]


def test_the_pairs_at_a_replays_step_count_only_when_both_trees_hold_replays(tmp_path):
    """A workflow run makes no replays (``pih publish --replay-step`` makes them beside published
    runs), so a fresh run is not failed for lacking the pairs at the replay's step; two trees
    that both hold them are compared on them too."""
    from pih.publishing.compare import PAIRED, TIME_STEP, conclusion_checks, headline_differences

    pair = {"method": "a", "versus": "one_level", "pairs": 11, "tied": 0, "mean_difference": 0.7}
    rows = [
        {**pair, "dimension": "start_std_m", "level": "0.001", "better": 11, "worse": 0},
        {
            **pair,
            "dimension": "time_step_s",
            "level": "starts 0.001 m off at 6.25e-05 s",
            "better": 11,
            "worse": 0,
        },
    ]
    trees = {}
    for name, held in (("published", rows), ("fresh", rows[:1])):
        (tmp_path / name / "planning" / "summary").mkdir(parents=True)
        pd.DataFrame(held).assign(sign_test_p=0.001).to_parquet(tmp_path / name / PAIRED)
        trees[name] = tmp_path / name
    pd.DataFrame({"time_step_s": [6.25e-5]}).to_parquet(trees["published"] / TIME_STEP)
    checks = conclusion_checks(trees["published"], trees["fresh"])
    assert len(checks) == 1 and all(check.holds for check in checks)
    assert headline_differences(trees["published"], trees["fresh"], 1e-9)[0] == []
    # Both with replays: the pairs at the replay's step are a conclusion, and a lost one fails.
    flipped = pd.DataFrame([rows[0], {**rows[1], "better": 0, "worse": 11}])
    flipped.assign(sign_test_p=0.001).to_parquet(trees["fresh"] / PAIRED)
    pd.DataFrame({"time_step_s": [6.25e-5]}).to_parquet(trees["fresh"] / TIME_STEP)
    checks = conclusion_checks(trees["published"], trees["fresh"])
    assert [check.holds for check in checks] == [True, False]


CONTACT_MODEL = ROOT / "published" / "contact_model"
TWINS_FAIL = (
    "FAILS: planning/summary/training_model.parquet: method=bilevel/deepest_explored, "
    "training_model=point, 1e+07 N/m, start_std_m=0.001: sign (pairs better/worse) 0 (0/0) -> "
    "- (0/1)"
)


def contact_model_runs(new):
    """The published contact-model study's 48 planning runs (no tables) under ``new``."""
    for run in sorted((CONTACT_MODEL / "planning").glob("start_x_m~*")):
        shutil.copytree(run, new / "planning" / run.name)
    return new


def fail_deployment(redeployment):
    """Every trial of a redeployment file turned to a failure, its provenance kept."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pq.read_table(redeployment)
    column = table.schema.get_field_index("success")
    failed = pa.array([False] * len(table))
    pq.write_table(table.set_column(column, table.schema.field(column), failed), redeployment)


def test_the_published_contact_model_study_reproduces_its_training_model_conclusions(tmp_path):
    """A copy of the published contact-model study (its tables pooled with the sim-to-real
    study's runs, read as they are): the same data, and every training-model conclusion checked
    and holding."""
    new = copy(CONTACT_MODEL, tmp_path / "new")
    result = compare(CONTACT_MODEL, new)
    assert result.scope == "" and result.data_identical and result.conclusions_hold
    trained = [c for c in result.checks if "training_model.parquet" in c.where]
    # 9 real-scene successes, 6 predictions and 6 signs against the real-scene-trained twins.
    assert len(trained) == 9 + 6 + 6
    assert sum(c.what.startswith("sign (pairs better/worse) -") for c in trained) == 2


@pytest.mark.slow  # remakes a pooled study's tables from ~100 runs: 10-35 s
def test_a_point_trained_run_that_no_longer_deploys_changes_a_training_model_conclusion(
    tmp_path, capsys
):
    """One point-trained bilevel run's deployments from offset starts all fail, the study's
    tables remade as published (pooled with the sim-to-real study's runs): it deploys less often
    than its twin trained on the real scene's model, where none did, and compare says so."""
    from pih.publishing.published import PUBLISHED_STUDIES, pooled_planning, remake_tables

    new = copy(CONTACT_MODEL, tmp_path / "new")
    run = (
        "start_x_m~-0.04_goal~deepest_explored_contact_model~point_point_stiffness_n_per_m~"
        "10000000.0_seed~1"
    )
    fail_deployment(new / "planning" / run / "redeploy_start_std_m~0.001.parquet")
    remake_tables(new / "planning", pooled_planning(ROOT, PUBLISHED_STUDIES["contact_model"]))

    assert main(["compare", str(CONTACT_MODEL), str(new)]) == 1
    out = capsys.readouterr().out.splitlines()
    assert f"planning/{run}/redeploy_start_std_m~0.001.parquet: data: one table -> another" in out
    # Its rate, 7 of 8 runs, stays inside the interval and its prediction is unchanged; the sign
    # against its twins does not hold (nor some of the paired table's).
    failed = [line for line in out if line.startswith("FAILS")]
    assert [line for line in failed if "training_model.parquet" in line] == [TWINS_FAIL]
    assert "NOT reproduced" in out[-1]


@pytest.mark.slow  # remakes a pooled study's tables from ~100 runs: 10-35 s
def test_a_fresh_contact_model_run_is_pooled_with_the_sim_to_real_study(tmp_path, capsys):
    """A fresh contact-model run holds no twins trained on the real scene's model: its own
    tables pair nothing. Compare remakes them pooled with the published sim-to-real study's
    runs, as the published study's are, and the training-model conclusions hold (here: the
    published runs, so the data too)."""
    from pih.analysis.pooling import find_outputs, pool
    from pih.publishing.compare import TRAINING_MODEL, conclusion_checks
    from pih.reporting.planning_summary import write_pooled_summary

    new = contact_model_runs(tmp_path / "new")
    write_pooled_summary(pool(*find_outputs([new / "planning"])), new / "planning" / "summary")
    assert (pd.read_parquet(new / TRAINING_MODEL)["pairs"] == 0).all()
    assert not all(c.holds for c in conclusion_checks(CONTACT_MODEL, new))  # read as it is

    assert main(["compare", str(CONTACT_MODEL), str(new)]) == 0
    out = capsys.readouterr().out.splitlines()[1:]
    assert out[0] == (
        f"scope: {new} is a run of the contact-model study: the tables remade here pool the "
        "sim-to-real study's runs (published/sim_to_real), as the study's do"
    )
    assert out[1].startswith("data: 0 of ") and out[1].endswith(": the same (within --rtol 1e-09)")
    assert out[-1].startswith("conclusions: 168 of 168 hold")


def test_a_training_model_without_twins_keeps_no_sign(tmp_path):
    """Per training model, what is checked: the real-scene success of every row; the prediction
    of a row trained in another model (where there is one); the sign against the twins where OLD
    has pairs, which a row without twins (0 of 0 pairs: nothing paired) does not keep."""
    from pih.analysis.training_model import REAL_SCENE
    from pih.publishing.compare import TRAINING_MODEL, conclusion_checks

    def table(root, pairs):
        same = {"method": "one_level", "start_std_m": 0.001, "runs": 8, "better": 0, "worse": 0}
        same |= {"deploy_success_rate": 1.0, "deploy_ci_low": 0.68, "deploy_ci_high": 1.0}
        same |= {"predicted_ci_low": 0.68, "predicted_ci_high": 1.0}
        rows = [
            {"training_model": REAL_SCENE, "predicted_success_rate": 1.0, "pairs": 0, "tied": 0},
            {"training_model": "point, 1e+07 N/m", "predicted_success_rate": 1.0},
            {"training_model": "point, 1e+06 N/m", "predicted_success_rate": float("nan")},
        ]
        twinned = [rows[0], *({"pairs": pairs, "tied": pairs} | r for r in rows[1:])]
        (root / TRAINING_MODEL).parent.mkdir(parents=True)
        pd.DataFrame([same | r for r in twinned]).to_parquet(root / TRAINING_MODEL)
        return root

    old, twinless = table(tmp_path / "old", 8), table(tmp_path / "new", 0)
    assert [c.what for c in conclusion_checks(old, old)] == [
        "deployment success 1 inside [0.68, 1]",
        "deployment success 1 inside [0.68, 1]",
        "deployment success 1 inside [0.68, 1]",
        "predicted success 1 inside [0.68, 1]",
        "sign (pairs better/worse) 0 (0/0) -> 0 (0/0)",
        "sign (pairs better/worse) 0 (0/0) -> 0 (0/0)",
    ]
    assert all(c.holds for c in conclusion_checks(old, old))
    failed = [c.what for c in conclusion_checks(old, twinless) if not c.holds]
    assert failed == ["sign (pairs better/worse) 0 (0/0) -> no pairs"] * 2


@pytest.mark.slow  # remakes two studies' tables from published runs: 10-15 s
def test_a_fresh_run_is_judged_only_on_the_redeployments_its_config_asked_for(tmp_path):
    """The paper-scale study, redeployed under model errors and on the ladder, against a fresh
    default-like run at one of its points that made none of them: OLD's rows and files of those
    deployments are not NEW's to reproduce; a model error both made still counts."""
    from pih.analysis.pooling import find_outputs, pool
    from pih.reporting.planning_summary import write_pooled_summary

    old = ROOT / "published" / "paper"
    new = tmp_path / "new"
    for run in sorted((old / "planning").glob("start_x_m~-0.04_*_seed~0")):
        target = new / "planning" / run.name
        target.mkdir(parents=True)
        for name in ("rollouts.parquet", "redeploy_start_std_m~0.001.parquet"):
            shutil.copy(run / name, target / name)
    write_pooled_summary(pool(*find_outputs([new / "planning"])), new / "planning" / "summary")
    result = compare(old, new)
    assert result.conclusions_hold, [str(c) for c in result.checks if not c.holds]
    assert not any("model_error" in str(d) for d in result.differences)
    # NEW made one model error too: OLD's rows for it are checked, the others still not.
    for run in sorted((old / "planning").glob("start_x_m~-0.04_*_seed~0")):
        name = "redeploy_model_error~hole_right_0_5mm.parquet"
        shutil.copy(run / name, new / "planning" / run.name / name)
    write_pooled_summary(pool(*find_outputs([new / "planning"])), new / "planning" / "summary")
    checked = [str(c) for c in compare(old, new).checks]
    assert any("hole_right_0_5mm" in c for c in checked)
    assert not any("friction_0_5" in c for c in checked)
