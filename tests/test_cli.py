"""The command line: `pih show` and `pih provenance`, on good and bad files."""

import copy
import json
import subprocess
import sys
from pathlib import Path

import pandas as pd
import pytest

from pih.__main__ import main
from pih.records.outputs import read_provenance, write_table
from pih.records.provenance import record

ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture
def table(tmp_path):
    path = tmp_path / "t.parquet"
    frame = pd.DataFrame({"force_n": [1.0, 2.0], "label": ["a", "b"]})
    columns = {"force_n": ("N", "a force"), "label": ("", "a label")}
    write_table(frame, path, record("test", seeds={"noise": 7}), columns)
    return path


def test_show_prints_columns_with_units_rows_and_provenance(table, capsys):
    assert main(["show", str(table)]) == 0
    out = capsys.readouterr().out
    assert "2 rows, 2 columns" in out
    assert "force_n  [N]  a force" in out
    assert "seeds: noise=7" in out and "run id test" in out


@pytest.mark.parametrize("content", [b"", b"not parquet at all", b"PAR1garbagePAR1"])
def test_bad_files_give_one_line_and_a_failing_status(tmp_path, capsys, content, table):
    bad = tmp_path / "bad.rrd"
    bad.write_bytes(content)
    other = tmp_path / "bad.parquet"
    other.write_bytes(content)
    assert main(["show", str(other)]) == 1
    assert main(["provenance", str(bad), str(other), str(table)]) == 1
    captured = capsys.readouterr()
    assert "Traceback" not in captured.err
    assert len(captured.err.strip().splitlines()) == 3  # show + two bad provenance files
    assert f"# {table}" in captured.out  # the good file after the bad ones is still printed


def test_unknown_key_is_an_error_naming_the_keys(table, capsys):
    assert main(["provenance", str(table), "--key", "no_such_key"]) == 1
    err = capsys.readouterr().err
    assert "no key 'no_such_key'" in err and "seeds" in err
    assert main(["provenance", str(table), "--key", "seeds"]) == 0
    assert '"noise": 7' in capsys.readouterr().out


@pytest.fixture(scope="module")
def planning_run():
    """A two-iteration planning run (deploying its latest inserting mean and its final mean)
    with the provenance a plan job writes: its config, seed key and cost divisors."""
    from pih.config import to_mapping
    from pih.planning.config import PlannerConfig, replace
    from pih.planning.dmp import DmpConfig
    from pih.planning.optimizers import OptimizerConfig
    from pih.planning.planner import Planner
    from pih.scene.config import SceneConfig

    config = replace(
        PlannerConfig(),
        iterations=2,
        deploy_trials=2,
        deploy_policy="last_inserted_mean",  # the figure also draws the mean's rollouts
        settle_s=0.1,
        dmp=DmpConfig(duration_s=1.0),
        optimizer=OptimizerConfig(population_size=2),
    )
    scene = SceneConfig().replace(solver__time_step_s=0.002, solver__retry_time_step_s=0.001)
    run = Planner.from_configs(scene, config).run()
    provenance = record(
        "plan",
        config={"scene": to_mapping(scene), "planner": to_mapping(config)},
        extra={"seed_key": "", "result": {"cost_divisors": run.cost_divisors}},
    )
    return run, provenance


def write_run(directory, run, provenance):
    from pih.planning.run_record import PATH_COLUMNS, ROLLOUT_COLUMNS

    write_table(run.rollouts, directory / "rollouts.parquet", provenance, ROLLOUT_COLUMNS)
    write_table(run.best_paths, directory / "best_paths.parquet", provenance, PATH_COLUMNS)


def test_plot_draws_one_planning_run(tmp_path, capsys, planning_run):
    from pih.planning.run_record import ROLLOUT_COLUMNS

    run, provenance = planning_run
    write_run(tmp_path, run, provenance)
    assert main(["plot", str(tmp_path)]) == 0
    assert (tmp_path / "run.png").stat().st_size > 10_000
    assert main(["plot", str(tmp_path), "--output", str(tmp_path / "other.png")]) == 0
    assert (tmp_path / "other.png").stat().st_size > 10_000
    assert main(["plot", str(tmp_path / "missing")]) == 1
    assert "not a planning run directory" in capsys.readouterr().err

    # Any recorded rollout simulates again to the recorded end, as a Rerun recording, with one
    # machine-readable line per replayed rollout.
    assert main(["replay", str(tmp_path), "phase == 'deploy' and rollout == 0"]) == 0
    out = capsys.readouterr().out
    assert (tmp_path / "replay_deploy_2_0.rrd").stat().st_size > 1000
    lines = [line for line in out.splitlines() if line.startswith("phase=")]
    assert len(lines) == 1 and "same=1" in lines[0]
    fields = dict(item.split("=") for item in lines[0].split())
    assert fields["recorded_p2"] == fields["replayed_p2"]
    assert fields["recorded_inserted"] == fields["replayed_inserted"]
    elsewhere = tmp_path / "elsewhere" / "deploy.rrd"
    elsewhere.parent.mkdir()
    assert main(["replay", str(tmp_path), "phase == 'deploy'", "--output", str(elsewhere)]) == 0
    out = capsys.readouterr().out
    assert out.count("same=1") == 2 and elsewhere.stat().st_size > 1000
    # Under other physics (--set) the replay is the same motion at another step: it runs, says
    # whether it ends elsewhere, and is no error.
    setting = "scene.solver.time_step_s=0.001"  # the run was recorded at 2 ms
    assert (
        main(["replay", str(tmp_path), "phase == 'deploy' and rollout == 0", "--set", setting]) == 0
    )
    fields = dict(item.split("=") for item in capsys.readouterr().out.splitlines()[-1].split())
    assert fields["status"] == "ok" and fields["same"] == "0"
    for bad, key in [
        ("scene.solver.time_step_sec=0.001", "time_step_sec"),
        ("scene.solver.time_step_s=-1", "time_step_s"),
        ("solver.time_step_s=0.001", "scene."),
        ("scene.material.friction", "scene."),
    ]:
        assert main(["replay", str(tmp_path), "phase == 'deploy'", "--set", bad]) == 1
        err = capsys.readouterr().err
        assert key in err and len(err.strip().splitlines()) == 1
    # A run recorded before a key existed (here: without planner.train_start_std_m) replays.
    older = copy.deepcopy(provenance["config"])
    del older["planner"]["train_start_std_m"]
    write_table(
        run.rollouts, tmp_path / "rollouts.parquet", record("plan", config=older), ROLLOUT_COLUMNS
    )
    assert main(["replay", str(tmp_path), "phase == 'deploy' and rollout == 0"]) == 0
    assert "same=1" in capsys.readouterr().out
    moved = run.rollouts.assign(final_bottom_x_m=run.rollouts["final_bottom_x_m"] + 1e-9)
    write_table(moved, tmp_path / "rollouts.parquet", provenance, ROLLOUT_COLUMNS)
    assert main(["replay", str(tmp_path), "phase == 'deploy'"]) == 1
    assert "same=0" in capsys.readouterr().out
    assert main(["replay", str(tmp_path), "phase == 'no_such_phase'"]) == 1
    err = capsys.readouterr().err
    assert "no row matches" in err and "iteration 1–2" in err and "deploy" in err
    assert main(["replay", str(tmp_path), "phase ==="]) == 1
    assert "pih replay" in capsys.readouterr().err
    assert main(["replay", str(tmp_path), "rolout == 3"]) == 1
    err = capsys.readouterr().err
    assert "no column 'rolout'" in err and "rollout" in err


def test_replay_query_runs_no_code(tmp_path, capsys, planning_run):
    """The query is parsed, never evaluated: the payload that ran `id` through
    DataFrame.query's @-locals is refused and leaves no file."""
    run, provenance = planning_run
    write_run(tmp_path, run, provenance)
    marker = tmp_path / "pwned"
    for payload in [
        f"@Path.home.__globals__['os'].system('id > {marker}') == 0",
        f"phase == 'deploy' and __import__('os').system('id > {marker}') == 0",
        f"phase.__class__ == 1 or open('{marker}', 'w')",
    ]:
        assert main(["replay", str(tmp_path), payload]) == 1
        assert "pih replay" in capsys.readouterr().err
    assert not marker.exists()


def test_redeploy_deploys_the_policies_again_from_offset_starts(tmp_path, capsys, planning_run):
    run, provenance = planning_run
    write_run(tmp_path, run, provenance)
    output = tmp_path / "redeployed.parquet"
    # At the recorded start std (0), the redeployment is the recorded one, in both phases.
    assert main(["redeploy", str(tmp_path), "--start-std-m", "0", "--output", str(output)]) == 0
    again = pd.read_parquet(output)
    deploy = run.rollouts[run.rollouts["phase"].str.startswith("deploy")].reset_index(drop=True)
    pd.testing.assert_frame_equal(again.drop(columns="run"), deploy)
    assert (again["run"] == tmp_path.name).all()
    assert "1 runs: deployment success" in capsys.readouterr().out
    # Offset starts: same holes and targets, other starts (the run named by its rollouts file).
    rollouts = str(tmp_path / "rollouts.parquet")
    assert main(["redeploy", rollouts, "--start-std-m", "0.001", "--output", str(output)]) == 0
    offset = pd.read_parquet(output)
    for column in ("sensed_hole_x_m", "target_x_m", "weights"):
        assert offset[column].equals(again[column])
    assert not offset["start_x_m"].equals(again["start_x_m"])
    assert read_provenance(output)["config"] == {"planner": {"deploy_start_std_m": 0.001}}

    assert main(["redeploy", str(tmp_path), "--start-std-m", "-1"]) == 1
    assert "--start-std-m" in capsys.readouterr().err
    assert main(["redeploy", str(tmp_path / "missing"), "--start-std-m", "0"]) == 1
    assert "cannot redeploy" in capsys.readouterr().err
    write_run(tmp_path, run, {**provenance, "seed_key": "another point"})
    assert main(["redeploy", str(tmp_path), "--start-std-m", "0"]) == 1
    assert "not the run's seeds" in capsys.readouterr().err


def write_study_run(
    root, planning_run, study, *, inserted=None, seed_key="", variant=None, **planner
):
    """A planning run of study ``study`` under ``root``: the fixture's run with these planner
    settings, its deployments all inserted or not; with a variant, its name and overrides."""
    from pih.planning.run_record import ROLLOUT_COLUMNS

    run, provenance = planning_run
    config = copy.deepcopy(provenance["config"])
    config["planner"] |= planner
    goal = config["planner"]["goal"]
    point = {"planner.goal": goal, "planner.seed": 0, "planner.start_x_m": -0.035}
    extra = {"seed_key": seed_key, "result": provenance["result"]}
    directory = root / study / "results" / "planning" / f"{goal}_seed~0"
    if variant is not None:
        point["variant"], extra["variant_overrides"] = variant
        directory = directory.with_name(f"{goal}_variant~{variant[0]}_seed~0")
    rollouts = run.rollouts.copy()
    if inserted is not None:
        rollouts.loc[rollouts["phase"] == "deploy", "success"] = inserted
    record_ = record("plan", point=point, config=config, extra=extra)
    write_table(rollouts, directory / "rollouts.parquet", record_, ROLLOUT_COLUMNS)
    return directory


def test_aggregate_pools_studies_counting_each_training_once(tmp_path, capsys, planning_run):
    from pih.planning.run_record import ROLLOUT_COLUMNS

    def study_run(study, **settings):
        return write_study_run(tmp_path, planning_run, study, **settings)

    one_level = study_run("a", inserted=False, goal="sensed_hole")
    study_run("a", inserted=True, goal="explored_argmin")
    study_run("b", inserted=False, goal="sensed_hole")  # the same training again: counts once
    study_run("c", inserted=True, goal="sensed_hole", deploy_start_std_m=0.001)  # its twin
    redeployed = tmp_path / "redeployed.parquet"
    assert (
        main(["redeploy", str(one_level), "--start-std-m", "0.0005", "--output", str(redeployed)])
        == 0
    )
    capsys.readouterr()
    out = tmp_path / "pooled"
    studies = [str(tmp_path / s / "results") for s in "abc"]
    assert main(["aggregate", *studies, str(redeployed), "--output-dir", str(out)]) == 0
    assert "2 trainings" in capsys.readouterr().out
    success = pd.read_parquet(out / "success.parquet").query("dimension == 'all'")
    assert success.set_index("method")["runs"].to_dict() == {
        "bilevel/explored_argmin": 1,
        "one_level": 1,
    }
    robustness = pd.read_parquet(out / "robustness.parquet").query("method == 'one_level'")
    rates = robustness.set_index("start_std_m")["deploy_success_rate"]
    again = pd.read_parquet(redeployed).query("phase == 'deploy'")["success"].mean()
    assert rates.to_dict() == {0.0: 0.0, 0.0005: again, 0.001: 1.0}
    paired = pd.read_parquet(out / "paired.parquet").query("dimension == 'all'")
    assert paired[["pairs", "better", "worse"]].values.tolist() == [[1, 1, 0]]
    for figure in ("fig9_cost_bands.png", "fig9_cost_bands.pdf", "fig_deploy_success.png"):
        assert (out / figure).stat().st_size > 1000
    sources = pd.read_parquet(out / "sources.parquet")
    assert sorted(sources["role"]) == ["copy", "deployment", "redeployment", "summary", "summary"]
    # The arguments' order does not decide which copy heads a training.
    again = tmp_path / "pooled_again"
    assert main(["aggregate", str(redeployed), *studies[::-1], "--output-dir", str(again)]) == 0
    capsys.readouterr()
    for table in ("runs", "success", "robustness", "sources"):
        pd.testing.assert_frame_equal(
            pd.read_parquet(out / f"{table}.parquet"), pd.read_parquet(again / f"{table}.parquet")
        )

    # A one-level run ignores the outer level: recorded under other outer settings it is a copy.
    study_run("g", inserted=False, goal="sensed_hole", outer={"goal_tilt": "sensed"})
    assert main(["aggregate", *studies[:2], str(tmp_path / "g"), "--output-dir", str(out)]) == 0
    assert "2 trainings" in capsys.readouterr().out
    copies = pd.read_parquet(out / "sources.parquet").query("role == 'copy'")
    assert len(copies) == 2
    # ... and bilevel runs' outer settings (not swept) do not keep it from pooling with them.
    study_run("j", inserted=True, goal="explored_argmin", outer={"entry_depth_m": 0.002})
    assert (
        main(["aggregate", studies[0], str(tmp_path / "j" / "results"), "--output-dir", str(out)])
        == 1
    )
    assert "planner.outer.entry_depth_m" in capsys.readouterr().err  # two bilevel designs
    assert (
        main(["aggregate", studies[1], str(tmp_path / "j" / "results"), "--output-dir", str(out)])
        == 0
    )
    assert "2 trainings" in capsys.readouterr().out

    # What does not pool stops with one line naming the cause: runs that differ outside their
    # sweep levels; a copy that trained or deployed differently; two trainings at the same
    # levels; a pair that does not share its draws; no std every training was recorded at; a
    # file that is not a redeployment; a redeployment whose run is gone.
    def refused(*paths):
        assert main(["aggregate", *map(str, paths), "--output-dir", str(out)]) == 1
        return capsys.readouterr().err

    study_run("d", goal="sensed_hole", iterations=3)
    assert "planner.iterations: 2 in" in refused(studies[0], tmp_path / "d")
    retrained = study_run("h", goal="sensed_hole")
    rows = pd.read_parquet(retrained / "rollouts.parquet")
    rows.loc[rows["phase"] == "train", "cost"] *= 1 + 1e-12
    write_table(
        rows,
        retrained / "rollouts.parquet",
        read_provenance(one_level / "rollouts.parquet"),
        ROLLOUT_COLUMNS,
    )
    assert "different training rollouts" in refused(studies[0], retrained)
    study_run("k", inserted=True, goal="sensed_hole")  # a's training, deployed otherwise
    assert "different deployments" in refused(studies[0], tmp_path / "k")
    study_run("e", goal="sensed_hole", seed_key="another point")
    assert "the same method and sweep levels but different trainings" in refused(
        studies[0], tmp_path / "e"
    )
    study_run("f", goal="explored_argmin", seed_key="another point")
    assert "different random draws" in refused(studies[1], tmp_path / "f")
    study_run("i", goal="explored_argmin", deploy_start_std_m=0.001, seed_key="x")
    assert "no start std at which every pooled training" in refused(studies[1], tmp_path / "i")
    assert "not a redeploy output" in refused(studies[0], out / "success.parquet")
    assert "no such file" in refused(tmp_path / "missing")
    (one_level / "rollouts.parquet").unlink()  # the redeployed run is gone
    assert "neither among the pooled runs nor there" in refused(studies[2], redeployed)


def test_aggregate_pools_ablation_variants_only_where_their_overrides_differ(
    tmp_path, capsys, planning_run
):
    ours = ("tilt", {"planner.outer.goal_tilt": "sensed"})
    rule = {"outer": {"goal_tilt": "sensed"}}
    for goal in ("sensed_hole", "explored_argmin"):
        write_study_run(tmp_path, planning_run, "a", goal=goal, variant=("paper", {}))
    write_study_run(tmp_path, planning_run, "b", goal="explored_argmin", variant=ours, **rule)
    out = tmp_path / "pooled"

    def pooled(*studies):
        paths = [str(tmp_path / s / "results") for s in studies]
        return main(["aggregate", *paths, "--output-dir", str(out)])

    assert pooled("a", "b") == 0
    assert "3 trainings" in capsys.readouterr().out
    # Another study's variant with another budget: not what its name says.
    write_study_run(
        tmp_path, planning_run, "c", goal="explored_argmin", variant=ours, iterations=3, **rule
    )
    assert pooled("a", "c") == 1
    assert "planner.iterations: 2 in" in capsys.readouterr().err
    # A variant overriding the budget may differ in it.
    fewer = ("fewer", {"planner.iterations": 3})
    write_study_run(
        tmp_path, planning_run, "d", goal="explored_argmin", variant=fewer, iterations=3
    )
    assert pooled("a", "d") == 0
    capsys.readouterr()


def test_show_reads_every_output_type_with_its_provenance(tmp_path, capsys, table):
    """`pih show` on each type a study writes: what it holds and the record it carries."""
    import matplotlib.pyplot as plt
    from test_recordings import _insertion_trace

    from pih.records.outputs import markdown_table, write_text
    from pih.records.recordings import record_insertion
    from pih.reporting import plots
    from pih.scene.config import SceneConfig

    provenance = record("test", seeds={"noise": 7})
    figure, _ = plt.subplots(figsize=(2, 1))
    plots.save(figure, tmp_path / "f.png", tmp_path / "f.pdf", provenance=provenance)
    frame = pd.DataFrame({"force_n": [1.0, 2.0, 3.0], "label": ["a", "b", "c"]})
    write_text(tmp_path / "t.md", markdown_table(frame), provenance)
    frame.to_csv(tmp_path / "t.csv", index=False)  # beside its companion t.parquet (`table`)
    record_insertion(tmp_path / "r.rrd", _insertion_trace(0.001), SceneConfig(), "r", provenance)
    closing = (tmp_path / "t.md").read_text().rstrip().rsplit("\n", 1)[-1]  # a report page's
    (tmp_path / "t.html").write_text(f"<title>T</title><table></table>\n{closing}\n")
    expected = {
        "f.png": ["PNG figure, ", " px, "],
        "f.pdf": ["PDF figure, 1 page", f"provenance (in {tmp_path / 'f.png'})"],
        "t.md": ["Markdown, 5 lines", "| force_n | label |", "| 3 | c |"],
        "t.csv": ["CSV, 3 rows, 2 columns", "force_n  [N]  a force", f"(in {table})"],
        "t.html": ["HTML page 'T', 1 table"],
        "r.rrd": ["Rerun recording 'r'", "timelines: sim_time", "/world/scene/peg"],
    }
    for name, texts in expected.items():
        assert main(["show", str(tmp_path / name)]) == 0, name
        out = capsys.readouterr().out
        for text in [*texts, "run id test", "seeds: noise=7"]:
            assert text in out, (name, text, out)
    # A figure not written by pih still shows, and says it carries no record.
    plt.subplots(figsize=(2, 1))[0].savefig(tmp_path / "other.png")
    assert main(["show", str(tmp_path / "other.png")]) == 0
    assert "provenance: none" in capsys.readouterr().out


def test_show_names_a_missing_file_and_the_closest_one(tmp_path, capsys, table):
    (tmp_path / "runs" / "start_x_m~-0.035").mkdir(parents=True)
    write_table(
        pd.DataFrame({"x": [1]}),
        tmp_path / "runs" / "start_x_m~-0.035" / "rollouts.parquet",
        record("test"),
        {"x": ("m", "x")},
    )
    for typo, closest in [
        (tmp_path / "t.parqet", table),
        (
            tmp_path / "runs" / "start_x_m~-0.035" / "rolouts.parquet",
            tmp_path / "runs" / "start_x_m~-0.035" / "rollouts.parquet",
        ),
        (
            tmp_path / "run" / "start_x_m~-0.036" / "rollouts.parquet",
            tmp_path / "runs" / "start_x_m~-0.035" / "rollouts.parquet",
        ),
    ]:
        assert main(["show", str(typo)]) == 1
        err = capsys.readouterr().err
        assert err == f"pih show: no such file: {typo}; did you mean {closest}?\n"
    nothing = tmp_path / "nothing_like_it.csv"
    assert main(["show", str(nothing)]) == 1
    assert capsys.readouterr().err == f"pih show: no such file: {nothing}\n"
    for path, text in [(tmp_path / "runs", "is a directory"), (tmp_path, "is a directory")]:
        assert main(["show", str(path)]) == 1
        err = capsys.readouterr().err
        assert text in err and "rollouts.parquet" in err and len(err.splitlines()) == 1
    (tmp_path / "notes.txt").write_text("hello")
    assert main(["show", str(tmp_path / "notes.txt")]) == 1
    assert "not a type pih writes" in capsys.readouterr().err


def test_run_figure_titles_every_panel_counts_whole_iterations_and_names_only_what_it_draws(
    planning_run,
):
    from pih.reporting import plots
    from pih.scene.config import SceneConfig

    run, _ = planning_run
    # No mean rollout inserted: the legend must not name "mean inserted".
    rollouts = run.rollouts.assign(
        success=run.rollouts["success"] & (run.rollouts["phase"] != "mean")
    )
    figure = plots.run_figure(rollouts, run.best_paths, SceneConfig().hole, "run")
    figure.draw_without_rendering()
    for ax in figure.axes:
        assert ax.get_title(), "every panel titled"
        legend = ax.get_legend()
        drawn = {line.get_label() for line in ax.get_lines() if len(line.get_xdata())}
        assert {t.get_text() for t in legend.get_texts()} <= drawn
        if ax.get_xlabel() == "iteration":
            ticks = [t for t in ax.get_xticks() if ax.get_xlim()[0] <= t <= ax.get_xlim()[1]]
            assert ticks and all(float(t).is_integer() for t in ticks), ticks
        assert "(" in ax.get_ylabel()  # a unit, or "dimensionless"


def test_help_is_a_short_list_of_commands(capsys):
    with pytest.raises(SystemExit) as exited:
        main(["--help"])
    assert exited.value.code == 0
    out = capsys.readouterr().out
    assert "``" not in out and len(out.splitlines()) <= 40
    for command in ("show", "replay", "compare", "publish", "status", "aggregate"):
        assert f"    {command} " in out


def test_a_reader_that_stops_early_ends_the_command_quietly():
    """``pih provenance F... | head -1``: the pipe closes before the output is written (here
    hundreds of kB, more than a pipe holds), and pih ends with 0 and nothing on stderr, as cat
    does, not with "Broken pipe"."""
    files = sorted((ROOT / "published" / "paper" / "planning" / "summary").glob("*.parquet"))
    process = subprocess.Popen(
        [sys.executable, "-m", "pih", "provenance", *map(str, files)],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    assert process.stdout.readline()
    process.stdout.close()
    assert process.wait(timeout=120) == 0
    assert process.stderr.read() == b""


def test_readmes_picture_is_the_default_studys_scene(tmp_path):
    """README's picture (docs/scene.png, ``pih scene``) records the scene and start it drew:
    today's default study's, or it is stale. ``pih scene`` draws another study's too, and a
    missing config file is one line."""
    from pih.records.outputs import read_output_provenance
    from pih.study.config import load_config

    config = load_config([str(ROOT / "config" / "config.yaml")])

    drawn = read_output_provenance(ROOT / "docs" / "scene.png")["config"]
    assert drawn["scene"] == json.loads(json.dumps(config["scene"]))
    assert drawn["planner"] == {k: config["planner"][k] for k in ("start_x_m", "start_height_m")}
    output = tmp_path / "scene.png"
    configs = [str(ROOT / "config" / "config.yaml"), str(ROOT / "config" / "smoke.yaml")]
    assert main(["scene", "--configfile", *configs, "--output", str(output)]) == 0
    assert output.read_bytes().startswith(b"\x89PNG")
    assert main(["scene", "--configfile", str(tmp_path / "nosuch.yaml")]) == 1


def test_every_command_and_argument_says_what_it_is(capsys):
    """``pih COMMAND --help`` opens with what the command does, and every positional argument
    has its help (a newcomer's first look at each command)."""
    with pytest.raises(SystemExit):
        main(["--help"])
    listing = capsys.readouterr().out
    commands = sorted(set(listing.split("{", 1)[1].split("}", 1)[0].split(",")))
    assert "publish" in commands and "scene" in commands
    for command in commands:
        with pytest.raises(SystemExit):
            main([command, "--help"])
        text = capsys.readouterr().out
        description = text.split("\n\n")[1]
        assert description.strip() and not description.startswith(("positional", "options")), (
            command
        )
        positional = text.split("positional arguments:\n", 1)
        if len(positional) > 1:
            for line in positional[1].split("\n\n", 1)[0].splitlines():
                if line.startswith("  ") and not line.startswith("   "):
                    name, *about = line.split(maxsplit=1)
                    assert about or name.startswith("{"), f"pih {command}: {name} has no help"
