"""How far a study has come, from its files: ``pih status [DIR]``, one line per kind of run.

A study's working directory ``DIR`` (where ``snakemake`` runs: ``results/``, ``logs/``,
``benchmarks/``, ``.snakemake/``) and its config say which runs there are: the planning runs of
its sweep (:func:`pih.study.config.study_points`, named as the workflow names them) and the
validation runs (every variant at every offset). A run is

- *done* when its output exists (``results/planning/<point>/rollouts.parquet``,
  ``results/validation/<variant>/offset_m~<offset>.parquet``);
- *failed* when its log holds a traceback and there is no output;
- *running* when its log exists without either, while Snakemake runs in ``DIR`` (its lock in
  ``.snakemake/locks/``), else *stopped* (interrupted: the next ``snakemake`` redoes it);
- *pending* otherwise.

How long a run takes is the median of the finished runs' wall-clock seconds (their benchmark
TSV's ``s``, else a planning log's closing ``...; 132.9 s``), or else what the running runs'
logs project (``elapsed 78 s, about 78 s left``). The time left assumes as many jobs in parallel
as are running now (at least 2, or ``jobs``): the running runs' time left, then the pending runs
handed to whichever job slot frees first. It counts plan and validation runs only; redeployments
and aggregates take seconds to a minute more.
"""

from __future__ import annotations

import heapq
import re
import statistics
import time
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from pih.workflow.console import duration

ITERATION = re.compile(
    r"^iteration (\d+)/(\d+):.*elapsed ([0-9.]+) s, about ([0-9.]+) s left", re.MULTILINE
)
"""A planning job's progress line (:class:`pih.planning.run_record.IterationReport`)."""

PLAN_SECONDS = re.compile(r"^deployment success .*; ([0-9.]+) s$", re.MULTILINE)
"""A planning job's closing line (workflow/scripts/plan.py): its duration."""

DEFAULT_JOBS = 2


@dataclass(frozen=True)
class Run:
    """One run of the study and what its files say about it."""

    name: str
    state: str  # done, running, failed, stopped, pending
    seconds: float | None = None  # done: how long it took
    progress: str | None = None  # running: "iteration 7/14"
    left_s: float | None = None  # running: its own estimate of the time left
    total_s: float | None = None  # running: elapsed + left, a duration before any run is done
    age_s: float | None = None  # running without progress lines: seconds since its log began


def planning_names(config: Mapping[str, Any]) -> list[str]:
    """The planning runs' directory names, as ``workflow/rules/common.smk`` makes them
    (``start_x_m~-0.035_goal~explored_argmin_seed~0``)."""
    import pandas as pd
    from snakemake.utils import Paramspace

    from pih.study.config import study_points

    points = study_points(config)
    columns = [path.rsplit(".", 1)[-1] for path in config["sweep"]]
    frame = pd.DataFrame([[p[path] for path in config["sweep"]] for p in points], columns=columns)
    return list(Paramspace(frame, filename_params="*", param_sep="~").instance_patterns)


def validation_names(config: Mapping[str, Any]) -> list[str]:
    """The validation runs, ``<variant>/offset_m~<offset>``, as ``validation.smk`` names them."""
    validation = config["validation"]
    return [
        f"{variant}/offset_m~{offset}"
        for variant in validation["variants"]
        for offset in validation["offsets_m"]
    ]


def snakemake_running(study: Path) -> bool:
    """Whether a Snakemake process holds the lock of the study's working directory."""
    locks = study / ".snakemake" / "locks"
    return locks.is_dir() and any(locks.iterdir())


def logged_configfiles(study: Path) -> list[str] | None:
    """The config files of the latest Snakemake run in ``study``, from its log
    (``.snakemake/log/*.snakemake.log``: "Config file(s): [...]", the default config named by
    "Config file X is extended ..."), the default first; relative paths are the study's. None
    without such a log (a dry run or a report writes none with them)."""
    logs = sorted((study / ".snakemake" / "log").glob("*.snakemake.log"), reverse=True)
    for log in logs:
        text = _read(log) or ""
        listed = re.search(r"^\s*Config file\(s\): \[(.*)\]$", text, re.MULTILINE)
        if not listed:
            continue
        files = [str(study / f) for f in re.findall(r"'([^']+)'", listed[1])]
        extended = r"^Config file (.+) is extended by additional config"
        default = re.search(extended, text, re.MULTILINE)
        if default and str(study / default[1]) in files:
            first = str(study / default[1])
            files = [first, *(f for f in files if f != first)]
        elif len(files) > 1:  # the directive's file comes last, after the command line's
            files = [files[-1], *files[:-1]]
        return files or None
    return None


def benchmark_seconds(path: Path) -> float | None:
    """Wall-clock seconds (column ``s``) of a Snakemake benchmark TSV, or None."""
    try:
        header, values, *_ = path.read_text().splitlines()
        return float(dict(zip(header.split("\t"), values.split("\t")))["s"])
    except (OSError, ValueError, KeyError):
        return None


def run_state(
    name: str,
    output: Path,
    log: Path,
    benchmark: Path,
    running: bool = True,
    now: float | None = None,
    reports_progress: bool = False,
) -> Run:
    """What a run's output, log and benchmark say (module docstring). ``running``: whether
    Snakemake runs in the study's directory; ``reports_progress``: whether the run's log has
    progress lines (planning runs), so that a log without one is a run "starting"."""
    text = _read(log)
    if output.exists():
        seconds = benchmark_seconds(benchmark)
        if seconds is None and (final := PLAN_SECONDS.findall(text or "")):
            seconds = float(final[-1])
        return Run(name, "done", seconds=seconds)
    if text is None:
        return Run(name, "pending")
    if "Traceback (most recent call last)" in text:
        return Run(name, "failed")
    if not running:
        return Run(name, "stopped")
    # Seconds since the log was last written: since the last progress line, or since the start
    # of a run that writes none until it ends (a validation run).
    since = max(0.0, (time.time() if now is None else now) - log.stat().st_mtime)
    reports = ITERATION.findall(text)
    if not reports:
        return Run(name, "running", progress="starting" if reports_progress else None, age_s=since)
    iteration, iterations, elapsed, left = reports[-1]
    return Run(
        name,
        "running",
        progress=f"iteration {iteration}/{iterations}",
        left_s=max(0.0, float(left) - since),
        total_s=float(elapsed) + float(left),
    )


def _read(path: Path) -> str | None:
    try:
        return path.read_text(errors="replace")
    except OSError:
        return None


def planning_runs(study: Path, config: Mapping[str, Any], running: bool = True) -> list[Run]:
    return [
        run_state(
            name,
            study / "results" / "planning" / name / "rollouts.parquet",
            study / "logs" / "planning" / f"{name}.log",
            study / "benchmarks" / "planning" / f"{name}.tsv",
            running,
            reports_progress=True,
        )
        for name in planning_names(config)
    ]


def validation_runs(study: Path, config: Mapping[str, Any], running: bool = True) -> list[Run]:
    return [
        run_state(
            name,
            study / "results" / "validation" / f"{name}.parquet",
            study / "logs" / "validation" / f"{name}.log",
            study / "benchmarks" / "validation" / f"{name}.tsv",
            running,
        )
        for name in validation_names(config)
    ]


def per_run_seconds(runs: Sequence[Run]) -> float | None:
    """The median duration of the finished runs, else of the running runs' projections."""
    done = [r.seconds for r in runs if r.state == "done" and r.seconds is not None]
    projected = [r.total_s for r in runs if r.state == "running" and r.total_s is not None]
    return statistics.median(done or projected) if done or projected else None


def time_left(running_left: Sequence[float], pending: int, per_run: float, jobs: int) -> float:
    """Seconds until the last run ends: ``jobs`` slots (at least one per running run), each busy
    with a running run for its time left or free, each pending run taking ``per_run`` on the
    first slot to free."""
    slots = [*running_left, *[0.0] * max(0, jobs - len(running_left))]
    heapq.heapify(slots)
    for _ in range(pending):
        heapq.heappush(slots, heapq.heappop(slots) + per_run)
    return max(slots, default=0.0)


def progress_note(runs: Sequence[Run]) -> str:
    """`` (iteration 31/50, 17/50, starting)`` for the running runs that report progress."""
    shown = [r.progress for r in runs if r.state == "running" and r.progress]
    iterations = [p.removeprefix("iteration ") for p in shown if p.startswith("iteration ")]
    others = [p for p in shown if not p.startswith("iteration ")]
    words = [f"iteration {', '.join(iterations)}"] if iterations else []
    return f" ({', '.join(words + others)})" if shown else ""


def summary_line(kind: str, runs: Sequence[Run], jobs: int) -> str:
    """``planning 12 of 33 runs done, 2 running (iteration 31/50, 17/50), 19 pending; ≈ 1 h 05
    min left at 2 jobs in parallel (median 352 s per run)``."""
    counts = {s: sum(r.state == s for r in runs) for s in ("running", "failed", "stopped")}
    done = sum(r.state == "done" for r in runs)
    pending = sum(r.state == "pending" for r in runs)
    parts = [f"{kind} {done} of {len(runs)} runs done"]
    if counts["running"]:
        parts.append(f"{counts['running']} running{progress_note(runs)}")
    if counts["failed"]:
        parts.append(f"{counts['failed']} failed (see their logs)")
    if counts["stopped"]:
        parts.append(f"{counts['stopped']} stopped (Snakemake is not running; rerun it)")
    if pending:
        parts.append(f"{pending} pending")
    line = ", ".join(parts)
    per_run = per_run_seconds(runs)
    todo = pending + counts["stopped"]
    if not counts["running"] and not todo:
        return line + (f" (median {duration(per_run)} per run)" if per_run is not None else "")
    if per_run is None:
        return line + "; time left unknown until a run finishes or reports progress"
    left = [
        r.left_s if r.left_s is not None else max(0.0, per_run - (r.age_s or 0.0))
        for r in runs
        if r.state == "running"
    ]
    eta = time_left(left, todo, per_run, jobs)
    basis = "median" if any(r.state == "done" and r.seconds for r in runs) else "projected"
    return (
        f"{line}; ≈ {duration(eta)} left at {jobs} job{'s' * (jobs != 1)} in parallel "
        f"({basis} {duration(per_run)} per run)"
    )


def study_status(study: Path, configfiles: Sequence[str], jobs: int | None = None) -> list[str]:
    """What :func:`summary_line` says of the planning runs and of the validation runs of the
    study in the working directory ``study`` whose config is ``configfiles`` (the default config
    first, the others merged onto it as ``--configfile`` does), after a line naming the study."""
    from pih.study.config import load_config

    if not study.is_dir():
        raise FileNotFoundError(f"{study}: no such study directory")
    config = load_config(list(configfiles))
    running = snakemake_running(study)
    planning = planning_runs(study, config, running)
    validation = validation_runs(study, config, running)
    active = sum(r.state == "running" for r in [*planning, *validation])
    slots = jobs or max(active, DEFAULT_JOBS)
    names = ", ".join(_shown(Path(f)) for f in configfiles)
    place = _shown(study)
    where = f"study in {Path.cwd() if place == '.' else place} (config {names}): "
    assumed = (
        ""
        if jobs
        else f"; time left at {slots} jobs in parallel, assumed (the runs running now, at least "
        f"{DEFAULT_JOBS}; --jobs N to say)"
    )
    return [
        where + ("Snakemake running" if running else "no Snakemake running there") + assumed,
        summary_line("planning", planning, slots),
        summary_line("validation", validation, slots),
    ]


def _shown(path: Path) -> str:
    """``path`` relative to the working directory when below it."""
    try:
        return str(path.resolve().relative_to(Path.cwd().resolve())) or "."
    except ValueError:
        return str(path)
