"""Glue between a Snakemake job and the library: the job's log and its provenance record."""

from __future__ import annotations

import base64
import logging
import os
import traceback
from collections.abc import Iterator, Mapping
from contextlib import contextmanager, redirect_stderr, redirect_stdout
from pathlib import Path
from typing import Any

from pih.records import provenance


@contextmanager
def logged(path: str) -> Iterator[None]:
    """Send a job's stdout/stderr (and Python warnings) to its log file."""
    with open(path, "w") as log, redirect_stdout(log), redirect_stderr(log):
        logging.basicConfig(stream=log, level=logging.INFO, force=True)
        logging.captureWarnings(True)
        try:
            yield
        except BaseException:
            traceback.print_exc(file=log)  # the job's log keeps the traceback too
            raise


ALLOCATORS = (
    "/usr/lib/x86_64-linux-gnu/libtcmalloc_minimal.so.4",
    "/usr/lib/x86_64-linux-gnu/libjemalloc.so.2",
    "/usr/lib/aarch64-linux-gnu/libtcmalloc_minimal.so.4",
    "/usr/lib/aarch64-linux-gnu/libjemalloc.so.2",
)


def preloaded_allocator() -> str:
    """The first installed of :data:`ALLOCATORS` (the faster first, measured in
    ``benchmarks/planner.py``), for ``LD_PRELOAD``; "" when none is."""
    return next((path for path in ALLOCATORS if Path(path).is_file()), "")


def job_provenance(
    smk: Any, step: str, *, point: Mapping[str, Any] | None = None, **fields: Any
) -> dict[str, Any]:
    """Provenance of a Snakemake job: the step, its wildcards/sweep point and input hashes."""
    wildcards = {k: v for k, v in dict(smk.wildcards).items()}
    return provenance.record(
        step, point=point if point is not None else wildcards, inputs=list(smk.input), **fields
    )


def recorded_outputs(workdir: Path) -> set[Path]:
    """Outputs Snakemake has recorded (its metadata records, written one by one as a job ends)."""
    return _job_records(workdir, "metadata")


def unfinished_outputs(workdir: Path) -> set[Path]:
    """Outputs of jobs Snakemake has started and not finished (its incomplete markers)."""
    return _job_records(workdir, "incomplete")


def _job_records(workdir: Path, kind: str) -> set[Path]:
    folder = workdir / ".snakemake" / kind
    names = os.listdir(folder) if folder.is_dir() else []
    return {workdir / base64.urlsafe_b64decode(name).decode() for name in names}


def mock_snakemake(target: str, configfiles: list[str] | None = None) -> tuple[Any, Path]:
    """The ``snakemake`` object Snakemake would hand the job that makes ``target`` (PyPSA-Eur's
    ``mock_snakemake``), built from the Snakefile and the config files in the current directory
    (default ``config/config.yaml``), so a workflow script can run outside Snakemake for
    debugging; and the path of the rule's script. Inputs are not made: run upstream jobs first.

    Uses Snakemake's internal DAG and Job classes (checked against Snakemake 9.27)."""
    import snakemake.api  # before snakemake.dag: importing that first is circular
    import snakemake.dag
    import snakemake.jobs
    from snakemake.script import Snakemake
    from snakemake.settings.types import (
        ConfigSettings,
        DAGSettings,
        OutputSettings,
        ResourceSettings,
        StorageSettings,
        WorkflowSettings,
    )

    # Without config files the Snakefile's own (config/config.yaml) is the config, as for
    # `snakemake`; passing it would make Snakemake say it "is extended by additional config".
    files = [Path(f) for f in configfiles or []]
    with snakemake.api.SnakemakeApi(OutputSettings()) as api:
        workflow_api = api.workflow(
            resource_settings=ResourceSettings(),
            config_settings=ConfigSettings(configfiles=files),
            storage_settings=StorageSettings(),
            workflow_settings=WorkflowSettings(),
            snakefile=Path("Snakefile"),
        )
        workflow = workflow_api._workflow
        workflow.dag_settings = DAGSettings(targets=[target])
        rules = [r for r in workflow.rules if r.script and r.is_producer(target)]
        if not rules:
            raise ValueError(f"{target}: no rule with a script makes this file")
        rule = rules[0]
        job = snakemake.jobs.Job(
            rule, snakemake.dag.DAG(workflow, rules=[rule]), rule.get_wildcards(target)
        )
        script = Path(rule.basedir.get_path_or_uri(secret_free=True)) / rule.script
        smk = Snakemake(
            job.input,
            job.output,
            job.params,
            job.wildcards,
            job.threads,
            job.resources,
            job.log,
            workflow.config,
            rule.name,
            None,
            script.parent,
        )
    for path in [*smk.log, *smk.output]:
        Path(path).parent.mkdir(parents=True, exist_ok=True)
    return smk, script.resolve()
