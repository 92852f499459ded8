"""The Snakemake study: config schema, sweeps from config, and an end-to-end smoke run.

Each workflow test runs in a copy of the workflow in a temporary directory, so the checkout's
own results/ are never touched.
"""

from __future__ import annotations

import importlib.metadata
import json
import math
import os
import re
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pandas as pd
import pytest
import yaml

from pih.records.outputs import read_output_provenance, read_provenance
from pih.records.provenance import stable
from pih.study.schema import config_schema
from pih.workflow.jobs import recorded_outputs, unfinished_outputs

ROOT = Path(__file__).resolve().parents[1]
SMOKE = yaml.safe_load((ROOT / "config" / "smoke.yaml").read_text())


def copy_workflow(target: Path) -> Path:
    for name in ("Snakefile", "workflow", "config", "profiles"):
        source = ROOT / name
        if source.is_dir():
            shutil.copytree(source, target / name)
        else:
            shutil.copy(source, target / name)
    return target


def snakemake(
    workdir: Path, *args: str, config: dict | None = None, check: bool = True
) -> subprocess.CompletedProcess:
    command = ["snakemake", "--cores", "2"]
    if config is not None:
        (workdir / "test-config.yaml").write_text(yaml.safe_dump(config))
        command += ["--configfile", "test-config.yaml"]
    env = {**os.environ, "OMP_NUM_THREADS": "1", "OPENBLAS_NUM_THREADS": "1"}
    result = subprocess.run(
        command + list(args), cwd=workdir, capture_output=True, text=True, env=env, check=False
    )
    if check and result.returncode != 0:
        raise AssertionError(
            f"snakemake {' '.join(args)} failed:\n{result.stdout[-3000:]}\n{result.stderr[-5000:]}"
        )
    return result


def planned_jobs(result: subprocess.CompletedProcess) -> dict[str, int]:
    """Job counts per rule from a dry run's stats table."""
    counts, table = {}, False
    for line in (result.stdout + result.stderr).splitlines():
        parts = line.split()
        if parts[:2] == ["job", "count"]:
            table = True
        elif table and len(parts) == 2 and parts[1].isdigit():
            counts[parts[0]] = int(parts[1])
        elif table and counts and not parts:
            break
    return counts


def test_committed_schema_matches_the_code():
    committed = json.loads((ROOT / "workflow" / "schemas" / "config.schema.json").read_text())
    assert committed == config_schema(), (
        "run `python -m pih schema > workflow/schemas/config.schema.json`"
    )


def test_the_conda_env_asks_for_the_pythons_the_package_supports():
    """``--sdm conda`` builds workflow/envs/pih.yaml, which installs this package: its Python
    must be one pyproject's requires-python admits, the ones CI tests (3.12 and 3.13)."""
    import tomllib

    import yaml
    from packaging.specifiers import SpecifierSet

    env = yaml.safe_load((ROOT / "workflow" / "envs" / "pih.yaml").read_text())
    (python,) = [d for d in env["dependencies"] if isinstance(d, str) and d.startswith("python")]
    conda = SpecifierSet(python.removeprefix("python"))
    project = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["requires-python"]
    for version in ("3.12", "3.13"):
        assert version in conda and version in SpecifierSet(project)
    for version in ("3.10", "3.11"):
        assert version not in conda, f"{python}: the package requires {project}"


@pytest.mark.slow
def test_default_config_dry_run_lists_the_full_study(tmp_path):
    work = copy_workflow(tmp_path)
    jobs = planned_jobs(snakemake(work, "-n"))
    config = yaml.safe_load((ROOT / "config" / "config.yaml").read_text())
    n_points = math.prod(len(levels) for levels in config["sweep"].values())
    # Two of the paper's 11 starts x 3 goals x 2 seeds: 12 runs, each redeployed once per
    # robustness level.
    assert n_points == 2 * 3 * 2
    assert jobs["plan"] == 2 * 3 * 2
    assert jobs["redeploy"] == jobs["plan"] * len(config["robustness"]["start_std_m"])
    assert jobs["validation_run"] == 4 * len(config["validation"]["variants"]) == 12
    assert jobs["whitney_curve"] == 4
    assert jobs["validation_variants"] == jobs["validation_compare"] == 1


@pytest.mark.slow
def test_new_sweep_dimension_is_a_config_edit(tmp_path):
    work = copy_workflow(tmp_path)
    config = json.loads(json.dumps(SMOKE))
    config["sweep"]["planner.sensing.bias_m"] = [0.0, 0.005]
    result = snakemake(work, "-n", config=config)
    base = planned_jobs(snakemake(work, "-n", config=SMOKE))["plan"]
    assert planned_jobs(result)["plan"] == 2 * base
    assert "bias_m~0.0" in result.stdout and "bias_m~0.005" in result.stdout


@pytest.mark.slow
def test_repeated_yaml_key_stops_naming_file_and_line(tmp_path):
    work = copy_workflow(tmp_path)
    text = (work / "config" / "smoke.yaml").read_text()
    (work / "dup.yaml").write_text(text + "planner:\n  iterations: 1\n")
    result = snakemake(work, "-n", "--configfile", "dup.yaml", check=False)
    assert result.returncode != 0
    assert "dup.yaml, line" in result.stderr + result.stdout
    assert "key 'planner' appears twice" in result.stderr + result.stdout


@pytest.mark.slow
def test_default_config_with_a_yaml_syntax_error_stops_naming_file_and_line(tmp_path):
    work = copy_workflow(tmp_path)
    config = work / "config" / "config.yaml"
    text = config.read_text()
    peg_line = text.splitlines().index("  peg:") + 1
    config.write_text(text.replace("  peg:\n", "  peg: {\n", 1))
    result = snakemake(work, "--dry-run", check=False)
    assert result.returncode != 0
    output = result.stdout + result.stderr
    # The flow mapping opened at `peg:` breaks at its second key, two lines further down.
    assert f"config/config.yaml, line {peg_line + 2}, column 5: not valid YAML" in output
    assert "Traceback" not in output and len(output.splitlines()) <= 20


@pytest.mark.slow
def test_own_config_file_defines_its_own_sweep(tmp_path):
    work = copy_workflow(tmp_path)
    # Only a sweep: the default's figure point (start and seed) is not one of its points, so
    # Fig. 8 falls back to the first point, and says so.
    own = {"sweep": {"planner.goal": ["sensed_hole", "deepest_explored"]}}
    result = snakemake(work, "-n", config=own)
    jobs = planned_jobs(result)
    assert jobs["plan"] == 2  # not 2 x the default's starts and seeds
    assert "Fig. 8 shows the first sweep point" in result.stdout + result.stderr
    default = planned_jobs(snakemake(work, "-n"))
    assert default["plan"] == 2 * 3 * 2  # 2 of the paper's starts x 3 methods x 2 seeds
    paper = planned_jobs(snakemake(work, "-n", "--configfile", "config/paper.yaml"))
    assert paper["plan"] == 11 * 3  # all of the paper's starts
    full = planned_jobs(snakemake(work, "-n", "--configfile", "config/full.yaml"))
    assert full["plan"] == 11 * 3 * 5
    ablations = planned_jobs(snakemake(work, "-n", "--configfile", "config/ablations.yaml"))
    # 3 starts x (7 variants x 2 outer rules + 6 one-level: sensed_tilt, which changes only the
    # outer rules' settings, is skipped for one-level)
    assert ablations["plan"] == 3 * (7 * 2 + 6)
    start_error = planned_jobs(snakemake(work, "-n", "--configfile", "config/start_error.yaml"))
    assert start_error["plan"] == 4 * 3 * 2


@pytest.mark.slow
@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda c: c["scene"]["material"].update(friction=-0.1), "scene.material.friction"),
        (lambda c: c["planner"]["optimizer"].update(name="simplex"), "planner.optimizer.name"),
        (lambda c: c["planner"].update(iterations=0), "planner.iterations"),
        (
            lambda c: c["planner"]["sensing"].update(hole_std=[0.005, 0.0, 0.1]),
            "planner.sensing.hole_std",
        ),
        (lambda c: c["planner"].update(goal="two_level"), "two_level"),
        (lambda c: c["sweep"].update({"planner.no_such_key": [1, 2]}), "planner.no_such_key"),
        (lambda c: c["scene"]["spring"].pop("damping_ratio"), "damping_ratio"),
        (lambda c: c["sweep"].update({"planner.seed": [0, 0]}), "sweep.planner.seed: repeated"),
        (
            lambda c: c["sweep"].update({"planner.optimizer.seed": [0, 1]}),
            "both end in 'seed'",
        ),
        (lambda c: c["planner"].update(deploy_trials=0), "planner.deploy_trials"),
        (lambda c: c["planner"]["outer"].update(goal_tilt="newton"), "newton"),
        (lambda c: c["sweep"].update(variant=["undefined"]), "sweep.variant"),
        (
            lambda c: c["validation"]["variants"].update(soft={"material.no_such_key": 1}),
            "validation.variants.soft",
        ),
        (lambda c: c["validation"].update(figure_variants=["nope"]), "validation.figure_variants"),
        (lambda c: c["robustness"].update(start_std_m=[0.01]), "robustness.start_std_m"),
        (lambda c: c["robustness"].update(start_std_m=[0.001, 0.001]), "robustness.start_std_m"),
        (lambda c: c.pop("robustness"), "robustness"),
    ],
)
def test_bad_config_stops_before_any_job_naming_the_key(tmp_path, edit, message):
    work = copy_workflow(tmp_path)
    (work / "results").mkdir()
    (work / "results" / "keep.parquet").write_text("existing result")
    config = json.loads(json.dumps(SMOKE))
    edit(config)
    # Edit the default config file itself (--configfile would merge over it, hiding a missing key).
    (work / "config" / "config.yaml").write_text(yaml.safe_dump(config))
    result = snakemake(work, "-n", check=False)
    assert result.returncode != 0
    assert message in result.stdout + result.stderr
    assert (work / "results" / "keep.parquet").read_text() == "existing result"
    assert not (work / "logs").exists()


@pytest.fixture(scope="module")
def smoke_run(tmp_path_factory) -> Path:
    work = copy_workflow(tmp_path_factory.mktemp("smoke"))
    snakemake(work, config=SMOKE)
    return work


@pytest.mark.slow
def test_smoke_study_outputs_carry_provenance(smoke_run):
    results = smoke_run / "results"
    parquet = sorted(results.rglob("*.parquet"))
    assert len(parquet) >= 10
    for path in parquet:
        record = read_provenance(path)
        assert (
            record["library_sha256"]
            and record["config_sha256"]
            and record["packages"]["drake"] == importlib.metadata.version("drake")
            and record["machine"]["cpu"]
        )
    rollouts = sorted(results.glob("planning/*/rollouts.parquet"))
    assert len(rollouts) == 2 * (1 + 2)  # starts x (one-level + bilevel with two outer rules)
    record = read_provenance(rollouts[0])
    assert set(record["sweep_point"]) == set(SMOKE["sweep"])
    assert record["seeds"]["planner.seed"] == record["sweep_point"]["planner.seed"]
    assert {"noise", "exploration", "deployment"} <= set(record["seeds"])
    assert record["seed_key"] and "planner.goal" not in record["seed_key"]
    # The planner's provenance records the scene it ran on: the smoke config's.
    solver = SMOKE["scene"]["solver"]["discrete_contact_approximation"]
    assert record["simulator"]["discrete_contact_approximation"] == solver == "lagged"
    table = pd.read_parquet(results / "validation" / "comparison.parquet")
    assert set(table["contact_model"]) == {"hydroelastic", "point"}
    for figure in (
        "fig4_fx_vs_depth",
        "figA1_fz_vs_depth",
        "figA2_angle_vs_depth",
        "fig5_sim_vs_theory",
    ):
        assert (results / "validation" / f"{figure}.png").stat().st_size > 10_000
    # provenance.md lists every other output, each with a record it carries or shares.
    index = pd.DataFrame(
        [
            line.split(" | ")[:3]
            for line in (results / "provenance.md").read_text().splitlines()
            if line.startswith("| results/")
        ],
        columns=["file", "record_in", "run_id"],
    )
    index["file"] = index["file"].str.removeprefix("| ")
    outputs = {str(p.relative_to(smoke_run)) for p in results.rglob("*") if p.is_file()} - {
        "results/provenance.md"
    }
    assert set(index["file"]) == outputs
    assert set(index[index["record_in"] != "itself"]["file"].str.rsplit(".", n=1).str[1]) == {
        "csv",
        "pdf",
        "html",  # the report's table pages share their markdown table's record
    }
    assert read_output_provenance(results / "provenance.md")["step"] == "provenance_index"
    summary = (results / "summary.md").read_text()
    assert "from the training start" in summary and "0.9954" in summary
    assert "Study: `config/config.yaml`, `test-config.yaml`; budget 3 iterations × 4" in summary
    assert "Not the default study" in summary
    success = pd.read_parquet(results / "planning" / "summary" / "success.parquet")
    assert set(success[success["dimension"] == "all"]["method"]) == {
        "one_level",
        "bilevel/explored_argmin",
        "bilevel/deepest_explored",
    }
    paired = pd.read_parquet(results / "planning" / "summary" / "paired.parquet")
    # 3 method pairs at 2 starts: over the runs' own deployments, then per start std (the
    # runs' own, 0.5 mm, and their redeployments at 1 mm), then under the model error
    assert paired["dimension"].tolist() == ["all"] * 3 + ["start_std_m"] * 6 + ["model_error"] * 3
    assert (paired["pairs"] == 2).all()
    robustness = pd.read_parquet(results / "planning" / "summary" / "robustness.parquet")
    assert robustness["start_std_m"].tolist() == [0.0005, 0.001] * 3 + [0.001] * 3
    assert robustness["model_error"].tolist() == ["none"] * 6 + ["friction_0_5"] * 3
    assert (robustness["runs"] == 2).all()
    assert "friction_0_5" in summary  # deployed under model error, beside the same without
    assert "| one_level |" in summary  # the pairs against one-level
    assert (results / "planning" / "summary" / "fig_deploy_success.png").stat().st_size > 10_000
    bands = pd.read_parquet(results / "planning" / "summary" / "cost_bands.parquet")
    per_start = bands[bands["dimension"] == "planner.start_x_m"]
    assert per_start.groupby("level")["method"].nunique().tolist() == [3, 3]
    aligned = pd.read_parquet(results / "validation" / "aligned_curves.parquet")
    assert set(aligned["variant"]) == {"hydroelastic", "point"}
    variants = pd.read_parquet(results / "validation" / "variants.parquet")
    pooled = variants[variants["offset"] == "pooled"]
    assert set(pooled["variant"]) == {"hydroelastic", "point"}
    assert pooled["r_f_x"].notna().all() and pooled["complete"].notna().all()
    assert pooled.groupby("contact_model")["chosen"].sum().le(1).all()
    assert "Selection rule" in (results / "validation" / "variants.md").read_text()


@pytest.mark.slow
def test_every_recording_verifies(smoke_run):
    recordings = sorted((smoke_run / "results").rglob("*.rrd"))
    assert len(recordings) == 6 + 2  # planning runs + validation runs
    result = subprocess.run(
        ["rerun", "rrd", "verify", *map(str, recordings)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert result.returncode == 0, result.stderr


@pytest.mark.slow
def test_rerun_is_a_no_op_and_a_forced_rerun_gives_the_same_data(smoke_run):
    dry = snakemake(smoke_run, "-n", config=SMOKE)
    assert "Nothing to be done" in dry.stdout + dry.stderr
    # A new validation variant or start position plans its own runs only.
    more = json.loads(json.dumps(SMOKE))
    more["validation"]["variants"]["stiff"] = {
        "solver.contact_model": "point",
        "material.point_stiffness_n_per_m": 1e7,
    }
    more["sweep"]["planner.start_x_m"].append(-0.033)
    jobs = planned_jobs(snakemake(smoke_run, "-n", config=more))
    assert jobs["validation_run"] == len(SMOKE["validation"]["offsets_m"])
    assert jobs["plan"] == 1 + 2  # one-level and two bilevel rules at the new start
    target = min(
        (smoke_run / "results" / "planning").glob("*goal~deepest_explored*/rollouts.parquet")
    )
    before, before_record = pd.read_parquet(target), read_provenance(target)
    written = target.stat().st_mtime_ns
    snakemake(smoke_run, "--forcerun", "plan", "--until", "plan", config=SMOKE)
    after, after_record = pd.read_parquet(target), read_provenance(target)
    assert target.stat().st_mtime_ns > written, "the forced re-run did not rewrite the file"
    pd.testing.assert_frame_equal(before, after)
    assert stable(before_record) == stable(after_record)


@pytest.mark.slow
def test_killed_run_resumes_without_corrupt_outputs(tmp_path):
    work = copy_workflow(tmp_path)
    (work / "test-config.yaml").write_text(yaml.safe_dump(SMOKE))
    env = {**os.environ, "OMP_NUM_THREADS": "1"}
    process = subprocess.Popen(
        ["snakemake", "--cores", "1", "--configfile", "test-config.yaml"],
        cwd=work,
        stdout=subprocess.DEVNULL,
        stderr=subprocess.DEVNULL,
        env=env,
        start_new_session=True,
    )
    # Kill once a job has finished (recorded by Snakemake) while a later one is running.
    deadline = time.time() + 300
    while time.time() < deadline and not (
        any(p.suffix == ".parquet" for p in recorded_outputs(work)) and unfinished_outputs(work)
    ):
        time.sleep(0.05)
    # A job's outputs are recorded one by one as it finishes; while its incomplete marker
    # remains it has not finished, and the rerun rightly redoes it.
    finished = recorded_outputs(work) - unfinished_outputs(work)
    finished_before = {p: p.stat().st_mtime_ns for p in finished if p.suffix == ".parquet"}
    os.killpg(process.pid, signal.SIGTERM)  # `kill`: Snakemake and the running job are stopped
    process.wait(timeout=60)
    assert finished_before, "no job finished within the deadline"
    snakemake(work, config=SMOKE)
    for path in (work / "results").rglob("*.parquet"):
        pd.read_parquet(path)  # every output is complete
        read_provenance(path)
    redone = [p for p, t in finished_before.items() if p.stat().st_mtime_ns != t]
    assert not redone, f"finished jobs were redone: {redone}"


@pytest.mark.slow
def test_a_workflow_script_runs_outside_snakemake_for_debugging(tmp_path):
    """`pih job TARGET` builds the job's snakemake object from the Snakefile and config and runs
    its script in-process: the output's data equal what the workflow made."""
    workdir = copy_workflow(tmp_path)
    target = "results/whitney/offset_m~0.001.parquet"
    snakemake(workdir, target)
    made = pd.read_parquet(workdir / target)
    (workdir / target).unlink()
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    run = subprocess.run(
        ["python", "-m", "pih", "job", target],
        cwd=workdir,
        capture_output=True,
        text=True,
        env=env,
        check=False,
    )
    assert run.returncode == 0, run.stderr[-3000:]
    assert "whitney_curve.py" in run.stdout
    pd.testing.assert_frame_equal(pd.read_parquet(workdir / target), made)
    assert read_provenance(workdir / target)["step"] == "whitney_curve"
    missing = subprocess.run(
        ["python", "-m", "pih", "job", "results/no_such_output.parquet"],
        cwd=workdir,
        capture_output=True,
        text=True,
        env=env,
        check=False,
    )
    assert missing.returncode == 1
    assert "no rule with a script makes this file" in missing.stderr


def test_a_job_depends_on_the_library_modules_its_script_reaches():
    """A library edit re-runs the jobs whose code it reaches: planning runs do not depend on the
    aggregates, figures or summary, which the aggregate jobs do, nor on the validation
    experiment (an hour of planning is not redone for a validation edit)."""
    from pih.records.provenance import imported_library_modules, script_library_hash

    scripts = ROOT / "workflow" / "scripts"
    plan = imported_library_modules(scripts / "plan.py")
    reached = {"planning.planner", "scene.simulation", "planning.dmp", "records.outputs"}
    assert reached | {"planning.__init__", "scene.__init__"} <= set(plan)
    assert not {
        "analysis.aggregate",
        "reporting.plots",
        "reporting.summary",
        "analysis.pooling",
    } & set(plan)
    assert not {"validation.experiment", "validation.config"} & set(plan)
    assert {"analysis.aggregate", "reporting.plots"} <= set(
        imported_library_modules(scripts / "planning_aggregate.py")
    )
    assert "planning.planner" not in imported_library_modules(scripts / "whitney_curve.py")
    hashes = {script_library_hash(scripts / f"{name}.py") for name in ("plan", "whitney_curve")}
    assert len(hashes) == 2


def test_a_reworded_comment_or_docstring_re_runs_no_job(tmp_path, monkeypatch):
    """A job's library hash is over what its modules compute: rewording a comment or docstring
    in a module the planning runs reach (the planner's config) leaves the hash as it was, and
    adding a definition does not."""
    from pih.records import provenance

    library = tmp_path / "pih"
    shutil.copytree(provenance.LIBRARY_ROOT, library, ignore=shutil.ignore_patterns("__pycache__"))
    monkeypatch.setattr(provenance, "LIBRARY_ROOT", library)
    plan = ROOT / "workflow" / "scripts" / "plan.py"
    module = library / "planning" / "config.py"
    assert "planning.config" in provenance.imported_library_modules(plan)

    def plan_hash() -> str:
        provenance.script_library_hash.cache_clear()
        return provenance.script_library_hash(plan)

    before = plan_hash()
    source = module.read_text()
    docstring_end = source.index('"""', 3) + 3
    reworded = f'"""Reworded."""\n# A new comment.{source[docstring_end:]}'
    module.write_text(reworded)
    assert plan_hash() == before
    module.write_text(f"{source}\nEXTRA_SETTING_S = 0.0003\n")
    assert plan_hash() != before
    provenance.script_library_hash.cache_clear()


@pytest.mark.slow
def test_pih_aggregate_reproduces_the_workflows_tables(smoke_run, tmp_path):
    """`pih aggregate results` pools the study's own runs and redeployments into the same
    success and robustness numbers as the workflow (each redeployment attached to its run,
    even where two runs hold identical data)."""
    out = tmp_path / "pooled"
    subprocess.run(
        [sys.executable, "-m", "pih", "aggregate", "results", "--output-dir", str(out)],
        cwd=smoke_run,
        check=True,
        capture_output=True,
    )
    summary = smoke_run / "results" / "planning" / "summary"
    for name, keys in (("robustness", ["method", "start_std_m"]), ("success", ["method"])):
        workflow = pd.read_parquet(summary / f"{name}.parquet")
        pooled = pd.read_parquet(out / f"{name}.parquet")
        if name == "success":
            workflow, pooled = (t[t["dimension"] == "all"] for t in (workflow, pooled))
        columns = [*keys, "runs", "deploy_success_rate"]
        expected = workflow[columns].sort_values(keys).reset_index(drop=True)
        assert pooled[columns].sort_values(keys).reset_index(drop=True).equals(expected), name


@pytest.mark.slow
def test_a_study_published_in_parts_gets_the_workflows_tables(smoke_run, tmp_path):
    """Runs published from two results trees (two sessions) make the same headline as the one
    tree they came from; a tree is refused whole when a run it holds is published already with
    other rollouts, and a run published twice with the same rollouts is kept once."""
    import pyarrow as pa
    import pyarrow.parquet as pq

    from pih.publishing.pages import results_block
    from pih.publishing.published import Part, PublishedStudy, publish_part

    study = PublishedStudy(
        "smoke",
        ("config/config.yaml", "config/smoke.yaml"),
        "smoke study",
        ("planning/*/rollouts.parquet", "planning/*/redeploy_*.parquet"),
        in_parts=True,
    )
    runs = sorted((smoke_run / "results" / "planning").glob("*/rollouts.parquet"))
    parts = {
        name: [r.parent for r in runs if f"start_x_m~{start}" in r.parent.name]
        for name, start in (("a", "-0.035"), ("b", "-0.031"))
    }
    for name, dirs in parts.items():
        for run in dirs:
            shutil.copytree(run, tmp_path / name / "planning" / run.name)
    assert publish_part(tmp_path / "a", study, root=smoke_run) == Part(3, 0, 3)
    published = smoke_run / study.directory
    assert "3 of its 6 runs so far" in " ".join(results_block(published, study).split())
    assert not (published / "planning" / "summary").exists()
    assert publish_part(tmp_path / "a", study, root=smoke_run) == Part(0, 0, 3)

    other = tmp_path / "c" / "planning" / parts["a"][0].name
    shutil.copytree(parts["a"][0], other)
    path = other / "rollouts.parquet"
    table = pq.read_table(path)  # the first rollout's outcome flipped, metadata kept
    index = table.schema.get_field_index("success")
    flipped = pa.array([not table["success"][0].as_py(), *table["success"].to_pylist()[1:]])
    pq.write_table(table.set_column(index, table.schema.field(index), flipped), path)
    assert pq.read_schema(path).metadata == table.schema.metadata
    with pytest.raises(ValueError, match="published already, with other rollouts"):
        publish_part(tmp_path / "c", study, root=smoke_run)

    assert publish_part(tmp_path / "b", study, root=smoke_run) == Part(3, 0, 0)
    workflow = pd.read_parquet(smoke_run / "results" / "planning" / "summary" / "success.parquet")
    assembled = pd.read_parquet(published / "planning" / "summary" / "success.parquet")
    columns = ["method", "runs", "deploy_success_rate", "deploy_ci_low", "deploy_ci_high"]
    workflow, assembled = (t[t["dimension"] == "all"][columns] for t in (workflow, assembled))
    assert (
        assembled.sort_values("method")
        .reset_index(drop=True)
        .equals(workflow.sort_values("method").reset_index(drop=True))
    )
    block = " ".join(results_block(published, study).split())
    assert "| one_level |" in block
    assert re.search(r"runs made at `[^`]+` on [^,]+, [-\d]+ \(6 runs\); tables at code", block), (
        block
    )


@pytest.mark.slow
def test_a_published_run_redeployed_in_place_is_the_workflows_redeployment(smoke_run, tmp_path):
    """``pih publish --redeploy``: a model error the published runs lack is made beside each run,
    in parts, with the rows and provenance fields the workflow's redeploy job gave it; the runs'
    own files stay as they were, and the tables come once every run has every redeployment."""
    from pih.publishing.redeploy import Redeployed, redeploy_published

    study, published = _published_smoke_study(smoke_run, tmp_path)
    made_by_workflow = smoke_run / "results" / "planning"
    before = {path: path.read_bytes() for path in published.rglob("*.parquet")}
    assert redeploy_published(study, root=tmp_path, limit=2) == Redeployed(2, 4, False)
    assert not (published / "summary").exists()
    assert redeploy_published(study, root=tmp_path, workers=2) == Redeployed(4, 0, True)
    assert redeploy_published(study, root=tmp_path) == Redeployed(0, 0, False)  # nothing to do
    assert all(path.read_bytes() == data for path, data in before.items())
    name = "redeploy_model_error~friction_0_5.parquet"
    for path in sorted(published.glob(f"*/{name}")):
        theirs = made_by_workflow / path.parent.name / name
        assert pd.read_parquet(path).equals(pd.read_parquet(theirs))
        ours, workflow = read_provenance(path), read_provenance(theirs)
        for field in ("sweep_point", "seeds", "config", "simulator", "seed_key", "model_error"):
            assert ours[field] == workflow[field], field
    assert len(list(published.glob(f"*/{name}"))) == 6
    robustness = pd.read_parquet(published / "summary" / "robustness.parquet")
    assert "friction_0_5" in set(robustness["model_error"])


def _published_smoke_study(smoke_run: Path, root: Path) -> tuple:
    """The smoke study's runs published under ``root`` as a study in parts (each run's record
    and its offset redeployment, no model error), and its planning directory."""
    from pih.publishing.published import RUN_GLOBS, PublishedStudy

    shutil.copytree(smoke_run / "config", root / "config")
    shutil.copy2(smoke_run / "test-config.yaml", root)
    study = PublishedStudy(
        "smoke", ("config/config.yaml", "test-config.yaml"), "smoke study", RUN_GLOBS, True
    )
    published = root / study.directory / "planning"
    for run in sorted((smoke_run / "results" / "planning").glob("*/rollouts.parquet")):
        for name in ("rollouts.parquet", "redeploy_start_std_m~0.001.parquet"):
            (published / run.parent.name).mkdir(parents=True, exist_ok=True)
            shutil.copy2(run.parent / name, published / run.parent.name / name)
    return study, published


@pytest.mark.slow
def test_published_deployment_trials_replayed_at_their_own_step_are_the_recorded_ones(
    smoke_run, tmp_path
):
    """``pih publish --replay-step``: every deployment trial of each published run (both
    policies, from the training start and from offset starts), replayed at the run's own step,
    ends exactly as recorded: the path that replays them at the reference step changes nothing
    but the step. In parts; a part of other rollout code is refused, never mixed in."""
    from pih.publishing import reference_step
    from pih.study import replay_record

    study, published = _published_smoke_study(smoke_run, tmp_path)
    step = SMOKE["scene"]["solver"]["time_step_s"]
    name = replay_record.replay_name(step)
    done = reference_step.replay_published(study, step, root=tmp_path, limit=4, workers=2)
    assert done == reference_step.Replayed(4, 2, False)
    assert reference_step.replay_published(study, step, root=tmp_path) == reference_step.Replayed(
        2, 0, True
    )
    # The tables gain the trials at the replay's step: here the runs' own, so the same rates.
    summary = published / "summary"
    at_step = pd.read_parquet(summary / "time_step.parquet")
    robustness = pd.read_parquet(summary / "robustness.parquet").set_index(
        ["method", "start_std_m"]
    )
    deployed = at_step[at_step["phase"] == "deploy"].set_index(["method", "start_std_m"])
    assert (deployed["time_step_s"] == step).all() and (deployed["flipped_trials"] == 0).all()
    pd.testing.assert_series_equal(
        deployed["deploy_success_rate"],
        robustness.loc[deployed.index, "deploy_success_rate"],
    )
    deploy_trials = SMOKE["planner"]["deploy_trials"]
    for path in sorted(published.glob(f"*/{name}")):
        table = pd.read_parquet(path)
        assert len(table) == 2 * 2 * deploy_trials  # 2 policies x (training start, offset starts)
        assert set(table["source"]) == {"training start", "start_std_m~0.001"}
        assert not table["flipped"].any() and (table["dp2_m"] == 0).all()
        assert read_provenance(path)["simulator"]["time_step_s"] == step
    assert len(list(published.glob(f"*/{name}"))) == 6
    # A part replayed elsewhere by another Drake (or other rollout code) is never mixed in.
    from pih.records.outputs import write_table

    elsewhere = read_provenance(path)
    elsewhere["packages"]["drake"] = "0.0.0"
    write_table(pd.read_parquet(path), path, elsewhere, replay_record.COLUMNS)
    with pytest.raises(ValueError, match=r"replayed by Drake 0\.0\.0, not"):
        reference_step.replay_published(study, step, root=tmp_path)
    elsewhere["packages"]["drake"] = importlib.metadata.version("drake")
    elsewhere["rollout_code_sha256"] = "0" * 64
    write_table(pd.read_parquet(path), path, elsewhere, replay_record.COLUMNS)
    with pytest.raises(ValueError, match="replayed by other rollout code"):
        reference_step.replay_published(study, step, root=tmp_path)
