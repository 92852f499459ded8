"""`pih status`: a study's progress from fake logs, outputs and benchmarks in a tmp dir; and the
console lines of the `pih` Snakemake logger plugin."""

import logging
import os
import time
from pathlib import Path

import pytest

from pih.__main__ import main
from pih.study.config import load_config
from pih.workflow.console import JobLines, duration, short_reason
from pih.workflow.status import (
    Run,
    logged_configfiles,
    planning_names,
    run_state,
    study_status,
    summary_line,
    time_left,
    validation_names,
)

ROOT = Path(__file__).resolve().parents[1]
CONFIGS = [str(ROOT / "config" / "config.yaml"), str(ROOT / "config" / "smoke.yaml")]
PROGRESS = (
    "iteration {i}/14: best J_inn 2.155e+05 (so far 2.155e+05); iterations with a successful "
    "best rollout: 0; elapsed {e} s, about {left} s left\n"
)


@pytest.fixture(scope="module")
def smoke():
    return load_config(CONFIGS)


def write(path: Path, text: str = "") -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text)
    return path


def finished_plan(study: Path, name: str, seconds: float | None, log_seconds: float = 99.0):
    write(study / "results" / "planning" / name / "rollouts.parquet", "data")
    write(
        study / "logs" / "planning" / f"{name}.log",
        PROGRESS.format(i=14, e=90, left=0)
        + f"deployment success 50% (last_inserted_mean; the final mean 0%); first successful "
        f"iteration 3; iteration budget (14); {log_seconds} s\n",
    )
    if seconds is not None:
        write(
            study / "benchmarks" / "planning" / f"{name}.tsv",
            f"s\th:m:s\tmax_rss\tcpu_time\n{seconds}\t0:00:00\t372.5\t5.9\n",
        )


def lock(study: Path) -> None:
    write(study / ".snakemake" / "locks" / "0.input.lock", "")


def test_run_names_are_the_workflows(smoke):
    names = planning_names(smoke)
    assert len(names) == 6  # 2 starts x 3 goals
    assert "start_x_m~-0.035_goal~explored_argmin_seed~0" in names
    assert "start_x_m~-0.031_goal~sensed_hole_seed~0" in names
    assert validation_names(smoke) == ["hydroelastic/offset_m~0.001", "point/offset_m~0.001"]


def test_states_from_outputs_logs_and_the_lock(tmp_path):
    out, log, bench = tmp_path / "out.parquet", tmp_path / "run.log", tmp_path / "run.tsv"
    assert run_state("r", out, log, bench).state == "pending"
    write(log, "")
    assert run_state("r", out, log, bench, reports_progress=True).progress == "starting"
    assert run_state("r", out, log, bench, running=False).state == "stopped"
    write(log, PROGRESS.format(i=7, e=78, left=78))
    now = log.stat().st_mtime + 8  # 8 s after the last progress line
    run = run_state("r", out, log, bench, now=now)
    assert (run.state, run.progress, run.left_s, run.total_s) == (
        "running",
        "iteration 7/14",
        70.0,
        156.0,
    )
    write(log, "Traceback (most recent call last):\nRuntimeError: boom\n")
    assert run_state("r", out, log, bench).state == "failed"
    write(out, "data")
    write(log, "deployment success 0% (...); iteration budget (3); 132.9 s\n")
    assert run_state("r", out, log, bench) == Run("r", "done", seconds=132.9)  # from the log
    write(bench, "s\th:m:s\tcpu_time\n140.5\t0:02:20\t130.0\n")
    assert run_state("r", out, log, bench).seconds == 140.5  # the benchmark's wall clock


def test_time_left_fills_the_first_free_job_slot():
    assert time_left([], 0, 100.0, 2) == 0
    assert time_left([30.0, 60.0], 0, 100.0, 2) == 60.0
    # Slots free at 30 and 60 s: pending runs start at 30, 60, 130 -> the last ends at 230 s.
    assert time_left([30.0, 60.0], 3, 100.0, 2) == 230.0
    assert time_left([], 4, 100.0, 2) == 200.0
    assert time_left([], 4, 100.0, 1) == 400.0
    assert time_left([10.0, 10.0, 10.0], 0, 100.0, 2) == 10.0  # more running than slots


def test_summary_line_names_counts_progress_and_time_left():
    runs = [
        *(Run(f"d{i}", "done", seconds=s) for i, s in enumerate([300.0, 352.0, 400.0])),
        Run("a", "running", progress="iteration 31/50", left_s=200.0, total_s=500.0),
        Run("b", "running", progress="iteration 17/50", left_s=700.0, total_s=1000.0),
        *(Run(f"p{i}", "pending") for i in range(4)),
    ]
    line = summary_line("planning", runs, 2)
    assert line.startswith(
        "planning 3 of 9 runs done, 2 running (iteration 31/50, 17/50), 4 pending; "
    )
    # Slots free at 200 and 700 s, 4 runs of 352 s each on the first free: 200 -> 552 -> 904
    # -> 1256 s and 700 -> 1052 s.
    assert line.endswith("≈ 20 min 56 s left at 2 jobs in parallel (median 5 min 52 s per run)")
    assert summary_line("planning", runs[:3], 2) == (
        "planning 3 of 3 runs done (median 5 min 52 s per run)"
    )
    unknown = summary_line("validation", [Run("x", "pending")], 2)
    assert unknown.endswith("time left unknown until a run finishes or reports progress")
    projected = summary_line("planning", [runs[3], Run("p", "pending")], 2)
    assert "projected 8 min 20 s per run" in projected  # elapsed + left of the running run
    stopped = summary_line("planning", [Run("s", "stopped"), Run("f", "failed")], 2)
    assert "1 failed" in stopped and "1 stopped (Snakemake is not running" in stopped


def test_study_status_reads_a_running_study(tmp_path, smoke):
    names = planning_names(smoke)
    for name, seconds in zip(names[:3], [300.0, 352.0, None]):
        finished_plan(tmp_path, name, seconds, log_seconds=400.0)
    write(tmp_path / "logs" / "planning" / f"{names[3]}.log", PROGRESS.format(i=7, e=78, left=78))
    write(tmp_path / "logs" / "planning" / f"{names[4]}.log", "")
    validation = validation_names(smoke)
    write(tmp_path / "results" / "validation" / f"{validation[0]}.parquet", "data")
    write(tmp_path / "benchmarks" / "validation" / f"{validation[0]}.tsv", "s\tcpu_time\n31\t30\n")
    lock(tmp_path)
    study_line, planning_line, validation_line = study_status(tmp_path, CONFIGS)
    assumed = (
        "; time left at 2 jobs in parallel, assumed (the runs running now, at least 2; --jobs N "
        "to say)"
    )
    assert study_line.endswith(f"config/smoke.yaml): Snakemake running{assumed}")
    assert study_status(tmp_path, CONFIGS, jobs=3)[0].endswith("Snakemake running")
    assert planning_line.startswith(
        "planning 3 of 6 runs done, 2 running (iteration 7/14, starting), 1 pending; ≈ "
    )
    assert "at 2 jobs in parallel (median 5 min 52 s per run)" in planning_line
    assert validation_line.startswith("validation 1 of 2 runs done, 1 pending; ≈ 31 s left")
    # Without Snakemake's lock the runs with a log and no output were interrupted.
    (tmp_path / ".snakemake" / "locks" / "0.input.lock").unlink()
    lines = study_status(tmp_path, CONFIGS)
    assert lines[0].endswith(f"no Snakemake running there{assumed}") and "2 stopped" in lines[1]


def test_cli_prints_the_lines_and_names_a_missing_directory(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(ROOT)
    assert main(["status", str(tmp_path), "--configfile", CONFIGS[1]]) == 0
    out = capsys.readouterr().out.splitlines()
    assert out[0] == (
        f"study in {tmp_path} (config config/config.yaml, config/smoke.yaml): "
        "no Snakemake running there; time left at 2 jobs in parallel, assumed (the runs running "
        "now, at least 2; --jobs N to say)"
    )
    assert out[1].startswith("planning 0 of 6 runs done, 6 pending")
    assert out[2].startswith("validation 0 of 2 runs done, 2 pending")
    assert len(out) == 3
    assert main(["status", str(tmp_path / "nope")]) == 1
    assert capsys.readouterr().err.strip() == f"pih status: no such directory: {tmp_path}/nope"


def test_cli_without_configfile_takes_the_latest_runs_config_files(tmp_path, capsys):
    """Snakemake's own log of a run names its config files; a report's log names none."""
    logs = tmp_path / ".snakemake" / "log"
    write(
        logs / "2026-12-02T194031.868447.snakemake.log",
        "Config file /repo/config/config.yaml is extended by additional config specified via "
        "the command line.\n\nSNAKEMAKE\n=========\n"
        f"  Config file(s): [PosixPath('{CONFIGS[1]}'), '{CONFIGS[0]}']\n",
    )
    write(logs / "2026-12-02T194303.092338.snakemake.log", "Building DAG of jobs...\n")
    assert main(["status", str(tmp_path)]) == 0
    assert "planning 0 of 6 runs done" in capsys.readouterr().out  # the smoke study's 6 runs
    write(logs / "2026-12-02T200000.000000.snakemake.log", "  Config file(s): ['config.yaml']\n")
    assert logged_configfiles(tmp_path) == [str(tmp_path / "config.yaml")]  # relative: the study's
    assert logged_configfiles(tmp_path / "none") is None


def test_cli_finds_the_default_config_in_pihs_checkout_else_says_where_to_run(
    tmp_path, capsys, monkeypatch
):
    import pih.cli.status

    monkeypatch.chdir(tmp_path)  # a study's own directory: no config/ here
    assert main(["status", "."]) == 0
    assert f"(config {ROOT / 'config' / 'config.yaml'})" in capsys.readouterr().out
    fake = tmp_path / "src" / "pih" / "cli" / "status.py"
    monkeypatch.setattr(pih.cli.status, "__file__", str(fake))
    assert main(["status", "."]) == 1
    err = capsys.readouterr().err
    assert err.startswith("pih status: no config/config.yaml here") and len(err.splitlines()) == 1


def record(event: str | None, **fields) -> logging.LogRecord:
    item = logging.LogRecord("snakemake", logging.INFO, "", 0, fields.pop("msg", ""), None, None)
    item.__dict__.update(event=event, **fields)
    return item


def job_info(jobid: int = 8) -> logging.LogRecord:
    return record(
        "job_info",
        jobid=jobid,
        rule_name="plan",
        log=["logs/planning/start_x_m~-0.035_seed~0.log"],
        wildcards={"start_x_m": "-0.035", "seed": "0"},
        reason="Missing output files: a.parquet, b.parquet; Code has changed since last execution",
    )


def test_console_prints_one_line_per_job_start_and_end(monkeypatch):
    lines = JobLines(quiet=set(), show_failed_logs=True, dryrun=False)
    clock = iter([1000.0, 1245.0])
    monkeypatch.setattr(time, "monotonic", lambda: next(clock))
    start = lines.format(job_info())
    assert start.endswith("] start plan (job 8): logs/planning/start_x_m~-0.035_seed~0.log")
    assert "\n" not in start
    done = lines.format(record("job_finished", job_id=8, msg="Finished jobid: 8 (Rule: plan)"))
    assert done.endswith(
        "] done  plan (job 8) in 4 min 05 s: logs/planning/start_x_m~-0.035_seed~0.log"
    )
    assert lines.format(record("shellcmd", shellcmd=None, msg="Shell command: None")) == ""
    assert lines.format(record("progress", done=3, total=89)) == "3 of 89 steps (3%) done"
    assert lines.format(record(None, msg="Select jobs to execute...")) == ""
    assert lines.format(record(None, msg="Nothing to be done.")) == "Nothing to be done."


def test_console_dry_run_says_why_in_one_line():
    lines = JobLines(quiet=set(), show_failed_logs=False, dryrun=True)
    assert lines.format(job_info()) == (
        "would run plan (job 8; missing output files, code has changed since last execution): "
        "logs/planning/start_x_m~-0.035_seed~0.log"
    )
    assert short_reason("Forced execution") == "forced execution"
    assert duration(59.6) == "1 min 00 s" and duration(3900) == "1 h 05 min"


def test_console_keeps_snakemakes_error_block_and_failed_log(tmp_path):
    log = write(tmp_path / "job.log", "the job's own words\n")
    lines = JobLines(quiet=set(), show_failed_logs=True, dryrun=False)
    error = record(
        "job_error",
        rule_name="plan",
        rule_msg=None,
        msg=None,
        jobid=8,
        input=[],
        output=["results/x.parquet"],
        log=[str(log)],
        conda_env=None,
        shellcmd=None,
        aux={},
        indent=False,
    )
    text = lines.format(error)
    assert "Error in rule plan:" in text and "the job's own words" in text


def test_the_profile_uses_the_plugin_and_snakemake_finds_it():
    from snakemake_interface_logger_plugins.registry import LoggerPluginRegistry

    profile = (ROOT / "profiles" / "default" / "config.yaml").read_text()
    assert "logger: [pih]" in profile and "printshellcmds" not in profile
    assert "pih" in LoggerPluginRegistry().get_registered_plugins()
    assert os.path.isdir(ROOT / "src" / "snakemake_logger_plugin_pih")
