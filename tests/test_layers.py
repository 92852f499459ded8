"""The config layer: building the job graph and ``pih aggregate`` import no ``pydrake``
(docs/workflow.md's module table names the Drake-free modules; each check runs in a fresh
interpreter, since this test process has imported Drake long before), and every config key says
what it means, in the schema and in docs/configuration.md."""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

JOB_GRAPH = ("pih.study.config", "pih.study.schema", "pih.workflow.jobs", "pih.records.provenance")
"""What the Snakefile and workflow/rules/common.smk import to build the job graph."""
AGGREGATE = (
    "pih.analysis.aggregate",
    "pih.analysis.run_summary",
    "pih.analysis.pooling",
    "pih.reporting.summary",
    "pih.reporting.plots",
    "pih.publishing.published",
    "pih.publishing.compare",
)
"""What ``pih aggregate`` (and ``pih compare``, ``pih publish``) import."""
CONFIG = (
    "pih.config",
    "pih.scene.config",
    "pih.planning.config",
    "pih.validation.config",
    "pih.scene.trace",
    "pih.records.outputs",
    "pih.planning.run_record",
    "pih.validation.experiment",
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
    assert "pih.study.config" in imported  # the check sees the workflow's imports
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
    from pih.study.schema import config_schema

    assert _keys_without_description(config_schema()) == []


def test_the_configuration_doc_is_generated_from_the_config_dataclasses():
    from pih.study.schema import config_markdown

    committed = (ROOT / "docs" / "configuration.md").read_text(encoding="utf-8")
    assert committed == config_markdown(), (
        "run `python -m pih schema --markdown > docs/configuration.md`"
    )


LAYERS = (
    "config",
    "whitney",
    "scene",
    "records",
    "validation",
    "planning",
    "study",
    "analysis",
    "reporting",
    "publishing",
    "workflow",
    "cli",
    "__main__",
)
"""pih's subpackages (and root modules) from the bottom up: each imports only from its own layer
or those below it (each subpackage's ``__init__`` says what it may import)."""
LIBRARY = ROOT / "src" / "pih"


def library_imports() -> dict[str, set[str]]:
    """Every module of pih (``"scene.config"``) -> the pih modules it imports, anywhere in it (at
    the top, in a function, under TYPE_CHECKING)."""
    import ast

    modules = {
        ".".join(p.relative_to(LIBRARY).with_suffix("").parts): p for p in LIBRARY.rglob("*.py")
    }
    graph = {}
    for name, path in modules.items():
        imported = set()
        for node in ast.walk(ast.parse(path.read_text())):
            names = []
            if isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
                names = [node.module] + [f"{node.module}.{alias.name}" for alias in node.names]
            for dotted in names:
                parts = dotted.split(".")
                inner = ".".join(parts[1:])
                if parts[0] == "pih" and inner in modules and not inner.endswith("__init__"):
                    imported.add(inner)
        graph[name] = imported - {name}
    return graph


def layer(module: str) -> int:
    top = module.split(".")[0]
    return -1 if top == "__init__" else LAYERS.index(top)


def test_imports_only_go_downward():
    upward = [
        f"{module} imports {other}"
        for module, imported in library_imports().items()
        for other in imported
        if layer(other) > layer(module)
    ]
    assert upward == []


def test_no_module_imports_itself_through_others():
    graph = library_imports()
    done, active, circles = set(), [], []

    def visit(module):
        if module in active:
            circles.append(" -> ".join(active[active.index(module) :] + [module]))
            return
        if module in done:
            return
        active.append(module)
        for other in sorted(graph[module]):
            visit(other)
        active.pop()
        done.add(module)

    for module in sorted(graph):
        visit(module)
    assert circles == []


def test_no_subpackage_is_over_2500_lines():
    """A subpackage a newcomer can read as one stage: over 2,500 lines, it wants splitting."""
    sizes = {
        package: sum(len(p.read_text().splitlines()) for p in (LIBRARY / package).rglob("*.py"))
        for package in LAYERS
        if (LIBRARY / package).is_dir()
    }
    assert {package: n for package, n in sizes.items() if n > 2500} == {}


def test_every_subpackage_says_what_it_owns_and_no_module_is_over_600_lines():
    for package in LAYERS:
        init = LIBRARY / package / "__init__.py"
        if (LIBRARY / package).is_dir():
            assert re.search(r"May import|Imports nothing", init.read_text()), init
    long = {
        str(p.relative_to(LIBRARY)): n
        for p in LIBRARY.rglob("*.py")
        if (n := len(p.read_text().splitlines())) > 600
    }
    assert long == {}


def test_the_docs_name_only_files_that_exist():
    """README, config/README and docs/ (but docs/history.md, which records the past) point a
    reader at code by path; a module moved or renamed must take its mentions along."""
    pages = [ROOT / "README.md", ROOT / "config" / "README.md"]
    pages += [p for p in sorted((ROOT / "docs").glob("*.md")) if p.name != "history.md"]
    missing = [
        f"{page.relative_to(ROOT)}: {path}"
        for page in pages
        for path in sorted(set(re.findall(r"\bsrc/pih/[\w/]+\.py", page.read_text())))
        if not (ROOT / path).is_file()
    ]
    assert missing == []


def test_readme_is_at_most_200_lines():
    """README is for users (what, how to run, how long, the result, where to read on); the
    reasoning goes to docs/, so adding to README means moving older text there."""
    lines = len((ROOT / "README.md").read_text(encoding="utf-8").splitlines())
    assert lines <= 200, f"README.md has {lines} lines; move text to docs/"
