"""Snakemake's console output for this workflow: one line per job (the ``pih`` logger plugin).

Snakemake's default prints a block of about ten lines per job (its output and log files, job id,
reason, wildcards, resources, and "Shell command: None" for a ``script:`` rule), and a dry run of
the default study one such block per job. ``logger: [pih]`` in ``profiles/default/config.yaml``
(``--logger pih``; the plugin is the package ``snakemake_logger_plugin_pih``, installed with pih)
prints instead::

    [19:31:38] start plan (job 8): logs/planning/start_x_m~-0.035_..._seed~0.log
    [19:31:50] done  plan (job 8) in 12 s: logs/planning/start_x_m~-0.035_..._seed~0.log
    1 of 22 steps (5%) done

and, in a dry run, ``would run plan (job 8; missing output files): logs/planning/...``: the job's
log names the run, and the log is where its progress is (``pih status`` sums it up per study).
Everything else is as Snakemake prints it: a failed job's full error block (with its log under
``--show-failed-logs``), the job counts, warnings and errors, ``--quiet`` and ``--nocolor``.
``--workflow-profile none`` gives Snakemake's own output. Snakemake's log file
(``.snakemake/log/``) keeps its own full format.
"""

from __future__ import annotations

import logging
import re
import sys
import time
from dataclasses import dataclass
from typing import Any

from snakemake_interface_logger_plugins.base import LogHandlerBase
from snakemake_interface_logger_plugins.common import LogEvent
from snakemake_interface_logger_plugins.settings import LogHandlerSettingsBase

CONFIG_FILE_ERRORS = (
    "Config file must be given as JSON or YAML with keys at top level",
    "Config file is not valid JSON or YAML",
)
"""Snakemake's messages for a ``--configfile`` it cannot read: it reads them before the Snakefile
and names no file, so :func:`config_file_error` names it."""

QUIET_MESSAGES = ("Select jobs to execute...",)
"""Snakemake's scheduler note, printed each time it starts jobs (as is "Execute N jobs..."): the
job lines say it."""


def configfile_arguments(argv: list[str]) -> list[str]:
    """The paths given to ``--configfile``/``--configfiles`` on a Snakemake command line."""
    paths, taking = [], False
    for arg in argv[1:]:
        name, sep, value = arg.partition("=")
        if name in ("--configfile", "--configfiles"):
            taking = not sep
            paths += [value] if sep else []
        elif arg.startswith("-"):
            taking = False
        elif taking:
            paths.append(arg)
    return paths


def config_file_error(message: str, argv: list[str]) -> str | None:
    """For Snakemake's error about an unreadable config file, the one line that names the file
    and what is wrong with it (:func:`pih.study.config.load_config_file`); None otherwise."""
    if not any(known in message for known in CONFIG_FILE_ERRORS):
        return None
    from pih.config import ConfigError
    from pih.study.config import load_config_file

    for path in configfile_arguments(argv):
        try:
            load_config_file(path)
        except ConfigError as error:
            return f"config error: {error}"
    return None


def duration(seconds: float) -> str:
    """``"12 s"``, ``"4 min 05 s"``, ``"1 h 05 min"``."""
    seconds = max(0, round(seconds))
    if seconds < 60:
        return f"{seconds} s"
    minutes, seconds = divmod(seconds, 60)
    if minutes < 60:
        return f"{minutes} min {seconds:02d} s"
    hours, minutes = divmod(minutes, 60)
    return f"{hours} h {minutes:02d} min"


def short_reason(reason: str) -> str:
    """Why Snakemake runs a job, without the file lists (``"Missing output files: a, b;
    Code has changed since last execution"`` -> ``"missing output files, code has changed since
    last execution"``): a reason can name thousands of files."""
    kinds = [part.split(": ", 1)[0].strip() for part in reason.split("; ")]
    return ", ".join(k[:1].lower() + k[1:] for k in kinds if k)


def job_name(info: dict[str, Any]) -> tuple[str, str]:
    """``("plan (job 8", "logs/planning/<point>.log")``: the rule and Snakemake's job id (its
    error messages name it), and the job's log, which names the run (else its wildcards)."""
    where = ", ".join(info.get("log") or [])
    if not where and info.get("wildcards"):
        where = ", ".join(f"{k}={v}" for k, v in info["wildcards"].items())
    return f"{info['rule_name']} (job {info['jobid']}", where


def _line(head: str, where: str, note: str = "", after: str = "") -> str:
    return f"{head}{note}){after}" + (f": {where}" if where else "")


def _snakemake_formatter() -> type[logging.Formatter]:
    from snakemake.logging import DefaultFormatter  # imported when a handler is made

    return DefaultFormatter


class JobLines:
    """What :class:`LogHandler` prints: Snakemake's default formatter with one line for a job's
    start, its end (with how long it took) and the workflow's start."""

    def __init__(self, quiet: Any, show_failed_logs: bool, dryrun: bool) -> None:
        self.default = _snakemake_formatter()(quiet, show_failed_logs)
        self.quiet = set(quiet or ())
        self.dryrun = dryrun
        self.started: dict[Any, tuple[str, str, float | None]] = {}

    def format(self, record: logging.LogRecord) -> str:
        event = getattr(record, "event", None)
        info = record.__dict__
        if event == LogEvent.JOB_INFO:
            return self.job_info(info)
        if event == LogEvent.JOB_FINISHED:
            return self.job_finished(info)
        if event == LogEvent.SHELLCMD:  # every rule is a script: no "Shell command: None"
            return info.get("shellcmd") or ""
        if event == LogEvent.WORKFLOW_STARTED:
            return (
                f"Snakemake {info['snakemake_version']}: {info['snakefile_main']} in "
                f"{info['cwd']}, config files {', '.join(map(str, info['configfiles']))}"
            )
        if event == LogEvent.JOB_STARTED or record.getMessage() in QUIET_MESSAGES:
            return ""
        if record.levelno >= logging.ERROR:
            named = config_file_error(record.getMessage(), sys.argv)
            if named:
                return named
        return self.default.format(record)

    def job_info(self, info: dict[str, Any]) -> str:
        head, where = job_name(info)
        self.started[info["jobid"]] = (head, where, time.monotonic())
        if self.dryrun:
            from snakemake.logging import is_quiet_about

            why = "" if is_quiet_about(self.quiet, "reason") else short_reason(info["reason"])
            return "would run " + _line(head, where, f"; {why}" if why else "")
        return f"[{time.strftime('%H:%M:%S')}] start " + _line(head, where)

    def job_finished(self, info: dict[str, Any]) -> str:
        jobid = info.get("job_id")
        rule = re.search(r"\(Rule: (\S+)\)", str(info.get("msg")))
        unknown = (f"{rule[1] if rule else 'a rule'} (job {jobid}", "", None)
        head, where, started = self.started.pop(jobid, unknown)
        took = "" if started is None else f" in {duration(time.monotonic() - started)}"
        return f"[{time.strftime('%H:%M:%S')}] done  " + _line(head, where, after=took)


@dataclass
class LogHandlerSettings(LogHandlerSettingsBase):
    """The plugin has no settings of its own."""


class LogHandler(LogHandlerBase):
    """Snakemake's console stream with :class:`JobLines`' lines (colours as Snakemake's)."""

    def __post_init__(self) -> None:
        from snakemake.logging import ColorizingTextHandler, DefaultFilter

        settings = self.common_settings
        self.console = ColorizingTextHandler(
            nocolor=settings.nocolor, stream=sys.stdout if settings.stdout else sys.stderr
        )
        self.lines = JobLines(settings.quiet, settings.show_failed_logs, settings.dryrun)
        self.addFilter(
            DefaultFilter(
                settings.quiet,
                settings.debug_dag,
                settings.verbose,
                settings.dryrun,
                settings.printshellcmds,
            )
        )

    def emit(self, record: logging.LogRecord) -> None:
        try:
            text = self.lines.format(record)
            if text and text != "None":
                self.console.stream.write(self.console.decorate(record, text) + "\n")
                self.console.flush()
        except BrokenPipeError:
            raise
        except Exception:  # noqa: BLE001 - as logging.Handler: never stop the workflow
            self.handleError(record)

    @property
    def writes_to_stream(self) -> bool:
        return True  # instead of Snakemake's default console handler

    @property
    def writes_to_file(self) -> bool:
        return False

    @property
    def has_filter(self) -> bool:
        return True

    @property
    def has_formatter(self) -> bool:
        return True

    @property
    def needs_rulegraph(self) -> bool:
        return False
