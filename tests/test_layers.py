"""The config layer: building the job graph and ``pih aggregate`` import no ``pydrake``
(docs/workflow.md's module table names the Drake-free modules; each check runs in a fresh
interpreter, since this test process has imported Drake long before), and every config key says
what it means, in the schema and in docs/configuration.md."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

JOB_GRAPH = ("pih.study_config", "pih.workflow", "pih.provenance")
"""What the Snakefile and workflow/rules/common.smk import to build the job graph."""
AGGREGATE = ("pih.aggregate", "pih.pooling", "pih.summary", "pih.plots", "pih.published")
"""What ``pih aggregate`` (and ``pih compare``, ``pih publish``) import."""
CONFIG = (
    "pih.config",
    "pih.scene_config",
    "pih.planner_config",
    "pih.validation_config",
    "pih.trace",
    "pih.outputs",
    "pih.run_record",
    "pih.validation",
    "pih.__main__",
)
"""The config dataclasses, the rollout records and their I/O, and the command line's top."""

REPORT = "import sys; print(sorted(m for m in sys.modules if m.split('.')[0] == 'pydrake'))"


def loaded_drake(code: str) -> str:
    """The ``pydrake`` modules a fresh interpreter has loaded after running ``code``."""
    result = subprocess.run(
        [sys.executable, "-c", f"{code}\n{REPORT}"],
        capture_output=True,
        text=True,
        check=False,
        cwd=ROOT,
    )
    assert result.returncode == 0, result.stderr[-3000:]
    return result.stdout.strip().splitlines()[-1]


@pytest.mark.parametrize(
    "modules", [JOB_GRAPH, AGGREGATE, CONFIG], ids=["job_graph", "aggregate", "config"]
)
def test_the_config_and_aggregation_layers_import_no_drake(modules):
    imports = "\n".join(f"import {module}" for module in modules)
    assert loaded_drake(imports) == "[]"


def test_pih_aggregate_imports_no_drake(tmp_path):
    """The command itself, with the modules it imports when it runs (here on no runs: it stops
    with an error after its imports)."""
    code = (
        "from pih.__main__ import main\n"
        f"main(['aggregate', {str(tmp_path)!r}, '--output-dir', {str(tmp_path / 'out')!r}])"
    )
    assert loaded_drake(code) == "[]"


@pytest.mark.slow
def test_building_the_job_graph_imports_no_drake(tmp_path):
    """``snakemake -n``: the Snakefile and its rules, parsed and planned in Snakemake's own
    process (a dry run starts no job), never import pydrake."""
    from test_workflow import copy_workflow

    copy_workflow(tmp_path)
    result = subprocess.run(
        [sys.executable, "-X", "importtime", "-m", "snakemake", "-n"]
        + ["--cores", "1", "--configfile", "config/smoke.yaml"],
        cwd=tmp_path,
        capture_output=True,
        text=True,
        check=False,
    )
    assert result.returncode == 0, result.stderr[-3000:]
    imported = [line.split("|")[-1].strip() for line in result.stderr.splitlines() if "|" in line]
    assert "pih.study_config" in imported  # the check sees the workflow's imports
    assert not [m for m in imported if m.split(".")[0] == "pydrake"]


def _keys_without_description(schema: dict, key: str = "") -> list[str]:
    missing = []
    for name, entry in schema.get("properties", {}).items():
        path = f"{key}.{name}" if key else name
        if "properties" in entry:
            missing += _keys_without_description(entry, path)
        elif not entry.get("description"):
            missing.append(path)
    return missing


def test_every_config_key_has_a_description():
    """pih.config.described on every field of the config dataclasses: the schema carries it."""
    from pih.study_config import config_schema

    assert _keys_without_description(config_schema()) == []


def test_the_configuration_doc_is_generated_from_the_config_dataclasses():
    from pih.study_config import config_markdown

    committed = (ROOT / "docs" / "configuration.md").read_text(encoding="utf-8")
    assert committed == config_markdown(), (
        "run `python -m pih schema --markdown > docs/configuration.md`"
    )
