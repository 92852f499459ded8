"""Provenance records attached to every output (docs/workflow.md, "Outputs and provenance").

A record says which step made a file, from which configuration, inputs, seeds and code, with which
simulator settings and library versions. Volatile fields (time, host) are listed in
:data:`VOLATILE_KEYS` so that re-runs can be compared on data and stable provenance only.
"""

from __future__ import annotations

import ast
import functools
import hashlib
import importlib.metadata
import json
import platform
import subprocess
import sys
from collections.abc import Callable, Iterable, Mapping
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

SCHEMA_VERSION = 1
PROVENANCE_KEY = b"pih.provenance"
VOLATILE_KEYS = ("created_utc", "host", "code_version", "allocator", "machine")
PACKAGES = (
    "drake",
    "numpy",
    "pandas",
    "pyarrow",
    "rerun-sdk",
    "snakemake",
    "cma",
    "scipy",
    "matplotlib",
    "threadpoolctl",
)
LIBRARY_ROOT = Path(__file__).resolve().parents[1]


def canonical_json(data: Any) -> str:
    return json.dumps(data, sort_keys=True, separators=(",", ":"), default=_jsonable)


def _jsonable(value: Any) -> Any:
    if hasattr(value, "tolist"):
        return value.tolist()
    if isinstance(value, Path):
        return str(value)
    raise TypeError(f"not JSON-serialisable: {value!r}")


def sha256_text(text: str) -> str:
    return hashlib.sha256(text.encode()).hexdigest()


def file_sha256(path: str | Path) -> str:
    digest = hashlib.sha256()
    with open(path, "rb") as handle:
        for block in iter(lambda: handle.read(1 << 20), b""):
            digest.update(block)
    return digest.hexdigest()


def input_sha256(path: str | Path) -> str:
    """sha256 of an input's data: a Parquet file's table without its schema metadata (which
    holds the provenance, with its creation time), any other file's bytes. Re-running an
    upstream job with the same data therefore leaves a downstream record unchanged."""
    if Path(path).suffix != ".parquet":
        return file_sha256(path)
    import pyarrow as pa
    import pyarrow.parquet as pq

    table = pq.read_table(path)
    table = table.replace_schema_metadata(None)
    sink = pa.BufferOutputStream()
    with pa.ipc.new_stream(sink, table.schema) as writer:
        writer.write_table(table)
    return hashlib.sha256(sink.getvalue().to_pybytes()).hexdigest()


def module_path(name: str) -> Path:
    """The source file of ``pih.<name>`` (``"scene.config"``, or ``"scene.__init__"``)."""
    return LIBRARY_ROOT.joinpath(*name.split(".")).with_suffix(".py")


def _pih_imports(source: str) -> set[str]:
    """The ``pih`` modules a source file may import (anywhere in it), without ``pih.``: each
    imported module and each name imported from one (which may be a module), with the packages
    that hold them; callers keep those that are files."""
    modules = set()
    for node in ast.walk(ast.parse(source)):
        if isinstance(node, ast.Import):
            modules |= {alias.name for alias in node.names}
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            modules.add(node.module)
            modules |= {f"{node.module}.{alias.name}" for alias in node.names}
    names = set()
    for module in modules:
        parts = module.split(".")
        if parts[0] == "pih" and len(parts) > 1:
            names.add(".".join(parts[1:]))
            names |= {".".join([*parts[1:k], "__init__"]) for k in range(2, len(parts))}
    return names


def imported_library_modules(script: str | Path) -> list[str]:
    """The ``pih`` modules a script imports, directly or through other ``pih`` modules."""
    seen: set[str] = set()
    todo = _pih_imports(Path(script).read_text())
    while todo:
        name = todo.pop()
        if name in seen or not module_path(name).is_file():
            continue
        seen.add(name)
        todo |= _pih_imports(module_path(name).read_text())
    return sorted(seen)


@functools.cache
def script_library_hash(script: str | Path) -> str:
    """sha256 over the ``pih`` modules a workflow script depends on
    (:func:`imported_library_modules`, the package's ``__init__`` and data files): a job's
    library, so that a library edit re-runs the jobs whose code it reaches and no others
    (Snakemake tracks the script itself, not what it imports). A module counts by what it
    computes (:func:`behaviour_dump`): a reworded comment or docstring re-runs nothing."""
    names = ["__init__", *imported_library_modules(script)]
    digest = hashlib.sha256()
    for name in names:
        digest.update(name.encode())
        digest.update(behaviour_dump(module_path(name).read_text()).encode())
    for path in sorted(LIBRARY_ROOT.rglob("*.json")):
        digest.update(str(path.relative_to(LIBRARY_ROOT)).encode())
        digest.update(path.read_bytes())
    return digest.hexdigest()


# The modules whose code decides a planning rollout's numbers (scene, contact, the robot
# trajectory and trace records, DMP, optimizer, planner config, costs, outer level, Algorithm 1,
# and the run record, which judges success and the convergence stop). A published planning run is
# stale when their hash no longer matches its record (tests/test_published.py); bookkeeping
# modules (outputs, provenance, config checks) are not in it.
ROLLOUT_MODULES = (
    "scene.config",
    "scene.simulation",
    "scene.trace",
    "scene.frames",
    "whitney.theory",
    "planning.dmp",
    "planning.optimizers",
    "planning.config",
    "planning.costs",
    "planning.outer",
    "planning.run_record",
    "planning.planner",
    "study.redeployment",
)

# The modules whose code decides the validation's numbers (the experiment, its config, the scene
# and contact, Whitney's theory, which steps its trace files keep): the published validation is
# stale when their hash no longer matches its record. tests/test_published.py checks that it
# covers what the experiment imports.
VALIDATION_MODULES = (
    "validation.experiment",
    "validation.config",
    "scene.config",
    "scene.simulation",
    "scene.trace",
    "scene.frames",
    "whitney.theory",
    "whitney.frame",
    "records.sampling",
)


class _Behaviour(ast.NodeTransformer):
    """A module's AST without what does not change what it computes: docstrings, and where its
    imports come from (``from pih.scene_config import X`` and ``from pih.scene.config import X``
    bind the same ``X``). Comments are not in an AST at all."""

    def visit_ImportFrom(self, node: ast.ImportFrom) -> ast.AST:
        if node.level or (node.module or "").split(".")[0] == "pih":
            return ast.ImportFrom(module="pih", names=node.names, level=0)
        return node

    def generic_visit(self, node: ast.AST) -> ast.AST:
        body = getattr(node, "body", None)
        if isinstance(body, list) and body and _is_docstring(body[0]):
            node.body = body[1:] or [ast.Pass()]
        return super().generic_visit(node)


def _is_docstring(node: ast.stmt) -> bool:
    return (
        isinstance(node, ast.Expr)
        and isinstance(node.value, ast.Constant)
        and isinstance(node.value.value, str)
    )


def behaviour_dump(source: str) -> str:
    """What a module's source computes, as text: its normalized AST (:class:`_Behaviour`), the
    same for a moved file, a reworded comment or docstring, and another for a changed
    expression."""
    return _dump(_Behaviour().visit(ast.parse(source)))


def _dump(node: object) -> str:
    """``ast.dump`` as Python 3.13 writes it (fields that are None or empty left out, no source
    positions) on every Python: 3.12's writes the empty ones too, which would make the hash
    depend on the interpreter that computes it."""
    if isinstance(node, ast.AST):
        printed = (
            f"{name}={_dump(value)}"
            for name in node._fields
            if (value := getattr(node, name, None)) != []
            and (
                value is not None
                or (name == "value" and isinstance(node, (ast.Constant, ast.MatchSingleton)))
            )
        )
        return f"{type(node).__name__}({', '.join(printed)})"
    if isinstance(node, list):
        return f"[{', '.join(map(_dump, node))}]"
    return repr(node)


def modules_hash(names: Iterable[str], source: Callable[[str], str] | None = None) -> str:
    """sha256 over what the modules ``names`` compute (:func:`behaviour_dump`), in an order that
    does not depend on their names or paths; ``source(name)`` gives a module's text (default:
    this library's file; another commit's for the code that made a record)."""
    source = source or (lambda name: module_path(name).read_text())
    return sha256_text("\n".join(sorted(behaviour_dump(source(name)) for name in names)))


@functools.cache
def rollout_code_hash() -> str:
    """:func:`modules_hash` of :data:`ROLLOUT_MODULES`."""
    return modules_hash(ROLLOUT_MODULES)


@functools.cache
def validation_code_hash() -> str:
    """:func:`modules_hash` of :data:`VALIDATION_MODULES`."""
    return modules_hash(VALIDATION_MODULES)


@functools.cache
def machine() -> dict[str, Any]:
    """The CPU and the BLAS numpy calls (library, version, the kernel it picked for this CPU):
    what a physics difference across machines is attributed to (docs/reproducibility.md)."""
    import numpy  # noqa: F401 - loads the BLAS that threadpoolctl reports
    from threadpoolctl import threadpool_info

    try:
        lines = Path("/proc/cpuinfo").read_text().splitlines()
    except OSError:
        lines = []
    models = [line.split(":", 1)[1].strip() for line in lines if line.startswith("model name")]
    cpu = models[0] if models else platform.processor() or platform.machine()
    blas = [
        {key: pool.get(key) for key in ("internal_api", "version", "architecture")}
        for pool in threadpool_info()
        if pool.get("user_api") == "blas"
    ]
    return {"cpu": cpu, "blas": blas}


def allocator() -> str:
    """The malloc this process runs with: a preloaded library's file name (the workflow preloads
    tcmalloc or jemalloc when installed, docs/simulation.md), else "glibc"."""
    try:
        maps = Path("/proc/self/maps").read_text()
    except OSError:
        return "unknown"
    for name in ("tcmalloc", "jemalloc"):
        for line in maps.splitlines():
            if name in line and ".so" in line:
                return Path(line.split()[-1]).name
    return "glibc"


@functools.cache
def library_hash() -> str:
    """sha256 over the source files of the ``pih`` package (names and contents, sorted)."""
    digest = hashlib.sha256()
    for path in sorted(LIBRARY_ROOT.rglob("*")):
        if path.is_file() and path.suffix in {".py", ".json"}:
            digest.update(str(path.relative_to(LIBRARY_ROOT)).encode())
            digest.update(path.read_bytes())
    return digest.hexdigest()


def git_describe(directory: Path) -> str | None:
    """``git describe --always --dirty`` of the checkout holding ``directory``, if it is one."""
    try:
        out = subprocess.run(
            ["git", "describe", "--always", "--dirty"],
            cwd=directory,
            capture_output=True,
            text=True,
            timeout=10,
            check=True,
        )
        return out.stdout.strip()
    except (OSError, subprocess.SubprocessError):
        return None


@functools.cache
def code_version() -> str:
    """:func:`git_describe` of the checkout holding the library, else the version."""
    from pih import __version__

    return git_describe(LIBRARY_ROOT) or __version__


@functools.cache
def package_versions() -> dict[str, str]:
    versions = {}
    for name in PACKAGES:
        try:
            versions[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            versions[name] = "not installed"
    return versions


def run_id(step: str, point: Mapping[str, Any] | None = None) -> str:
    """Deterministic id of a job: the step plus its sorted sweep point / wildcards."""
    parts = [step] + [f"{k}={point[k]}" for k in sorted(point or {})]
    return "/".join(parts)


def record(
    step: str,
    *,
    point: Mapping[str, Any] | None = None,
    seeds: Mapping[str, int] | None = None,
    config: Any = None,
    inputs: Iterable[str | Path] = (),
    simulator: Mapping[str, Any] | None = None,
    extra: Mapping[str, Any] | None = None,
) -> dict[str, Any]:
    """The provenance record of one output. ``config`` is the resolved configuration (mapping)."""
    return {
        "schema_version": SCHEMA_VERSION,
        "step": step,
        "run_id": run_id(step, point),
        "sweep_point": dict(point or {}),
        "seeds": dict(seeds or {}),
        "config": config,
        "config_sha256": sha256_text(canonical_json(config)),
        "inputs": {str(p): input_sha256(p) for p in inputs},
        "code_version": code_version(),
        "library_sha256": library_hash(),
        "rollout_code_sha256": rollout_code_hash(),
        "validation_code_sha256": validation_code_hash(),
        "allocator": allocator(),
        "machine": json.loads(json.dumps(machine())),  # copies: the cached records stay as read
        "packages": dict(package_versions()),
        "simulator": dict(simulator or {}),
        "python": sys.version.split()[0],
        "platform": platform.platform(),
        "host": platform.node(),
        "created_utc": datetime.now(UTC).isoformat(timespec="seconds"),
        **dict(extra or {}),
    }


def stable(provenance: Mapping[str, Any]) -> dict[str, Any]:
    """The record without volatile fields, for comparing re-runs."""
    return {k: v for k, v in provenance.items() if k not in VOLATILE_KEYS}
