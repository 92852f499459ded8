"""``pih verify``: today's code computes exactly what the code that made the published runs
computed, shown on this machine by running both on one suite (docs/reproducibility.md, "What
current means").

The suite is the published studies' configurations: their resolved ``scene`` and ``planner``
sections without the levels of their situation keys (start, seed), deduplicated. Each item runs
one recorded (start, seed) of its configuration through each version's own workflow (its
Snakefile, scripts, config files and library, in a process of its own) until one iteration past
the first whose mean inserted, with its deployment trials and offset redeployment; every output
column is compared bit for bit. When all are identical, the equivalence record gets one row from
the published runs' hash to today's (:mod:`pih.publishing.equivalence`).
"""

from __future__ import annotations

import collections
import concurrent.futures
import hashlib
import io
import json
import math
import os
import signal
import subprocess
import sys
import tarfile
import tempfile
import threading
from collections.abc import Callable, Iterable, Mapping, Sequence
from contextlib import suppress
from dataclasses import dataclass, field, replace
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from pih.records.provenance import canonical_json, git_describe, machine, package_versions

TREE_FILES = ("Snakefile", "workflow", "config", "src")
"""What one version of the code is: its workflow, its config files and its library."""
HASH_OF_TREE = "import pih.records.provenance as p; print(p.rollout_code_hash(), p.__file__)"
"""Run in a tree's own interpreter process: which library loaded, and its own hash of itself."""


@dataclass(frozen=True)
class Study:
    """A published study's directory and its config files (relative to the repository)."""

    directory: Path
    config_files: tuple[str, ...]


@dataclass(frozen=True)
class Item:
    """One configuration of the suite, at one recorded run of it."""

    name: str
    config_files: tuple[str, ...]
    point: dict[str, Any]
    """The recorded run's sweep point (dotted keys): each version runs it as a one-point sweep."""
    iterations: int
    """One past the first iteration whose mean inserted in the recorded run."""
    redeployment: str
    """The offset redeployment's file name (empty when the study makes none)."""
    recorded: str
    """The recorded run's directory (under ``planning/``)."""
    estimate_s: float = math.nan
    """Roughly how long the item runs: the recorded run's wall time for its iterations."""

    @property
    def run(self) -> str:
        """The run's directory name, as the workflow names a one-point sweep's run."""
        return "_".join(f"{key.rsplit('.', 1)[-1]}~{level}" for key, level in self.point.items())

    @property
    def outputs(self) -> tuple[str, ...]:
        return tuple(filter(None, ("rollouts.parquet", "best_paths.parquet", self.redeployment)))


@dataclass
class Verification:
    """What :func:`verify` found."""

    from_hash: str
    to_hash: str
    from_commit: str = ""
    digests: dict[str, str] = field(default_factory=dict)
    differences: list[str] = field(default_factory=list)


def read_provenance_of(path: Path) -> dict[str, Any]:
    """A Parquet output's provenance, or one line naming the file that cannot be read."""
    from pih.records.outputs import read_provenance

    try:
        return read_provenance(path)
    except Exception as error:  # noqa: BLE001 - pyarrow's errors for a damaged file vary
        raise ValueError(f"{path}: not a readable output ({str(error).splitlines()[0]})") from None


def run_files(studies: Iterable[Study], root: Path) -> list[Path]:
    """Every planning run's ``rollouts.parquet`` and redeployment under the studies; one line
    naming a directory that holds none."""
    files = []
    for study in studies:
        planning = root / study.directory / "planning"
        found = sorted(planning.glob("*/rollouts.parquet"))
        if not found:
            raise ValueError(f"{study.directory}: no planning runs (planning/*/rollouts.parquet)")
        for path in found:
            files += [path, *sorted(path.parent.glob("redeploy_*.parquet"))]
    return files


def suite(studies: Iterable[Study], root: Path) -> list[Item]:
    """The studies' configurations without their situation levels, deduplicated, each at its
    recorded run whose mean inserted earliest, for one iteration past that (the shortest run
    that reaches the insertion branches; 2 iterations where no run's mean inserted), named by
    its method levels."""
    from pih.analysis.run_summary import run_seconds
    from pih.publishing.published import expected_runs, runs_by_point, sweep_keys_of
    from pih.study.config import load_config
    from pih.study.points import is_method_key

    candidates: dict[str, list[tuple[int, str, Item]]] = {}
    for study in studies:
        files = tuple(str(root / f) for f in study.config_files)
        expected = expected_runs(files)
        stds = sorted(float(std) for std in load_config(list(files))["robustness"]["start_std_m"])
        offset = next((std for std in stds if std > 0), stds[0] if stds else None)
        redeployment = f"redeploy_start_std_m~{offset}.parquet" if offset is not None else ""
        runs = runs_by_point(root / study.directory / "planning", sweep_keys_of(expected))
        for key, path in sorted(runs.items()):
            if key not in expected:
                continue
            point = json.loads(key)
            sections = _configuration(expected[key], point)
            planner = sections["planner"]
            methods = {"planner.goal": planner["goal"]}
            methods |= {k: v for k, v in point.items() if is_method_key(k)}
            methods.setdefault("planner.simulated_hole", planner["simulated_hole"])
            name = ", ".join(str(level) for level in methods.values())
            first = _first_inserted_mean(path)
            budget = planner["iterations"]
            iterations = min(budget, first + 1) if first else min(budget, 2)
            estimate = run_seconds(path) * iterations / budget
            item = Item(
                name,
                study.config_files,
                point,
                iterations,
                redeployment,
                path.parent.name,
                estimate,
            )
            candidates.setdefault(canonical_json(sections), []).append(
                (first or budget + 1, key, item)
            )
    items = sorted((min(runs)[2] for runs in candidates.values()), key=lambda item: item.name)
    named = collections.Counter(item.name for item in items)
    return [
        item if named[item.name] == 1 else replace(item, name=f"{item.name} ({item.recorded})")
        for item in items
    ]


def _configuration(sections: Mapping[str, Any], point: Mapping[str, Any]) -> dict[str, Any]:
    """A run's resolved sections without the levels of its situation keys (start, seed: every
    sweep key that does not select the method)."""
    from pih.study.points import is_method_key

    sections = json.loads(canonical_json(sections))
    for dotted in (key for key in point if not is_method_key(key)):
        section, *path = dotted.split(".")
        level = sections[section]
        for name in path[:-1]:
            level = level[name]
        level.pop(path[-1], None)
    return sections


def _first_inserted_mean(rollouts: Path) -> int | None:
    """The first iteration whose mean weights inserted in a recorded run, if any."""
    rows = pd.read_parquet(rollouts, columns=["phase", "iteration", "success"])
    inserted = rows[(rows["phase"] == "mean") & rows["success"].astype(bool)]
    return int(inserted["iteration"].min()) if len(inserted) else None


def tree_hash(tree: Path) -> str:
    """The rollout hash a code tree's own hash function gives for itself, computed in a process
    that loads that tree's library (checked by where it loaded from)."""
    result = _child([sys.executable, "-c", HASH_OF_TREE], tree, _environment(tree))
    if result.returncode:
        raise ValueError(f"{tree}: its rollout hash cannot be computed ({result.stderr.strip()})")
    digest, loaded = result.stdout.strip().split(maxsplit=1)
    if not Path(loaded).resolve().is_relative_to((tree / "src").resolve()):
        raise ValueError(f"{tree}: another library loaded ({loaded})")
    return digest


_CHILDREN: set[subprocess.Popen] = set()
_CHILDREN_LOCK = threading.Lock()


def _child(
    command: list[str], cwd: Path, env: Mapping[str, str] | None = None, text: bool = True
) -> subprocess.CompletedProcess:
    """``command`` run to its end in ``cwd``, its output captured, in a session of its own so
    that :func:`end_children` ends it with every job it started."""
    with subprocess.Popen(
        command,
        cwd=cwd,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=text,
        start_new_session=True,
    ) as process:
        with _CHILDREN_LOCK:
            _CHILDREN.add(process)
        try:
            out, err = process.communicate()
        finally:
            with _CHILDREN_LOCK:
                _CHILDREN.discard(process)
    return subprocess.CompletedProcess(command, process.returncode, out, err)


def end_children(number: int = signal.SIGTERM) -> None:
    """Send ``number`` to every child still running (a version's ``snakemake``) and to the jobs
    it started: its whole process group."""
    with _CHILDREN_LOCK:
        live = list(_CHILDREN)
    for process in live:
        with suppress(ProcessLookupError, PermissionError):
            os.killpg(process.pid, number)


def _environment(tree: Path) -> dict[str, str]:
    """This process's environment with ``tree``'s library first on the path."""
    return {**os.environ, "PYTHONPATH": str(tree / "src"), "PYTHONNOUSERSITE": "1"}


def extract(repository: Path, commit: str, into: Path) -> Path:
    """The code of ``commit`` (:data:`TREE_FILES`), written under ``into`` with ``git archive``
    (which leaves nothing in ``.git``); LookupError when the history does not hold it."""
    archive = _child(
        ["git", "archive", "--format=tar", commit, *TREE_FILES], repository, text=False
    )
    if archive.returncode:
        raise LookupError(f"{commit}: not in {repository}'s history")
    tree = into / commit
    with tarfile.open(fileobj=io.BytesIO(archive.stdout)) as tar:
        tar.extractall(tree, filter="data")
    return tree


def commit_of(
    made_at: str, candidates: Iterable[str], repository: Path, into: Path
) -> tuple[str, Path]:
    """The first of ``candidates`` (commits, ``-dirty`` dropped) whose own code and hash
    function give ``made_at``, and its extracted tree; one line when none does."""
    tried = []
    for commit in dict.fromkeys(c.removesuffix("-dirty") for c in candidates if c):
        try:
            tree = extract(repository, commit, into)
            own = tree_hash(tree)
            if own == made_at:
                return commit, tree
            tried.append(f"{commit} gives {own[:12]}")
        except (LookupError, ValueError) as error:
            tried.append(f"{commit}: {str(error).splitlines()[0]}")
    raise ValueError(
        f"rollout hash {made_at[:12]}: no commit in history gives it (tried: "
        f"{'; '.join(tried) or 'no commit named'})"
    )


def run_item(tree: Path, item: Item, workdir: Path) -> dict[str, Path]:
    """Run ``item`` through ``tree``'s own workflow in ``workdir``: its outputs by name."""
    workdir.mkdir(parents=True)
    override = {
        "sweep": {key: [level] for key, level in item.point.items()},
        "planner": {"iterations": item.iterations},
    }
    (workdir / "verify.yaml").write_text(json.dumps(override))  # YAML reads JSON
    run = workdir / "results" / "planning" / item.run
    command = [
        sys.executable,
        "-m",
        "snakemake",
        "-j1",
        "-s",
        str(tree / "Snakefile"),
        "-d",
        str(workdir),
        "--configfile",
        *(str(tree / f) for f in item.config_files),
        str(workdir / "verify.yaml"),
        "--",
        *(str(run.relative_to(workdir) / name) for name in item.outputs),
    ]
    result = _child(command, workdir, _environment(tree))
    if result.returncode:
        tail = " | ".join(result.stderr.strip().splitlines()[-3:])
        raise RuntimeError(f"{item.name}: the workflow of {tree.name} failed: {tail}")
    return {name: run / name for name in item.outputs}


THINNED_OUTPUTS = {"best_paths.parquet": "iteration"}
"""Outputs of per-step paths (name: the column labelling each path) that a newer plan script
keeps at a stride (:func:`pih.records.sampling.path_samples`): an older version's are thinned
alike before they are compared."""


def column_digests(source: Path | pa.Table) -> dict[str, str]:
    """sha256 of each column's data, bit for bit (NaNs by their bits; a null by its place, not
    by the undefined bytes behind it), without the schema's metadata (the provenance and
    timings) or the columns' (units and descriptions, which a change of wording moves)."""
    table = source if isinstance(source, pa.Table) else pq.read_table(source)
    table = table.combine_chunks()
    bare = pa.schema([field.remove_metadata() for field in table.schema])
    columns = [
        pa.array(column.to_pylist(), type=column.type)
        if column.null_count or pa.types.is_nested(column.type)
        else column
        for column in table.columns
    ]
    table = pa.Table.from_arrays(columns, schema=bare)
    digests = {}
    for name in table.column_names:
        sink = pa.BufferOutputStream()
        column = table.select([name])
        with pa.ipc.new_stream(sink, column.schema) as writer:
            writer.write_table(column)
        digests[name] = hashlib.sha256(sink.getvalue().to_pybytes()).hexdigest()
    return digests


def thinned_like(old: pa.Table, new: pa.Table, path_column: str) -> pa.Table:
    """``old``'s paths at the stride of ``new``'s (the ratio of the two files' longest time step
    within a path: a path's last step may come sooner); ``old`` itself when it is not the
    finer."""
    from pih.records.sampling import path_samples

    def step(table: pa.Table) -> float:
        paths, time_s = (table.column(c).to_numpy() for c in (path_column, "time_s"))
        within = np.diff(time_s)[paths[1:] == paths[:-1]]
        return float(within.max()) if within.size else math.nan

    ratio = step(new) / step(old)
    if old.num_rows <= new.num_rows or not ratio > 1:
        return old
    return old.filter(pa.array(path_samples(old.column(path_column).to_numpy(), round(ratio))))


def compare_outputs(old: Mapping[str, Path], new: Mapping[str, Path]) -> tuple[str, list[str]]:
    """The new outputs' digest and, where they differ from the old, the first column of each
    file that does (a path output of an older version thinned alike: :data:`THINNED_OUTPUTS`)."""
    digest, differences = hashlib.sha256(), []
    for name in old:
        before, after = pq.read_table(old[name]), pq.read_table(new[name])
        if name in THINNED_OUTPUTS:
            before = thinned_like(before, after, THINNED_OUTPUTS[name])
        before, after = column_digests(before), column_digests(after)
        for column in sorted(before.keys() | after.keys()):
            digest.update(f"{name}:{column}:{after.get(column)}".encode())
        changed = [c for c in before if before[c] != after.get(c)]
        changed += [c for c in after if c not in before]
        if changed:
            differences.append(f"{name}: column {changed[0]} differs")
    return digest.hexdigest(), differences


def _config_differences(old: Mapping[str, Path], new: Mapping[str, Path]) -> list[str]:
    """Where the two versions resolved another ``scene`` or ``planner`` for one item (their
    config files differ), read through today's schema: their outputs then answer another
    question."""
    from pih.publishing.published import _differing_keys, recorded_sections

    then, now = (
        recorded_sections(read_provenance_of(outputs["rollouts.parquet"])["config"])
        for outputs in (old, new)
    )
    differences = []
    for section in then:
        if then[section] == now[section]:
            continue
        both = isinstance(then[section], dict) and isinstance(now[section], dict)
        keys = ", ".join(_differing_keys(then[section], now[section])) if both else "unreadable"
        differences.append(f"the versions resolved another {section} config ({keys})")
    return differences


def verify_hash(
    made_at: str,
    old: tuple[str, Path],
    items: Sequence[Item],
    repository: Path,
    today: str,
    scratch: Path,
    progress: Callable[[str], None] = print,
    stop_at_difference: bool = False,
) -> Verification:
    """Run ``items`` through the ``old`` code (its commit and extracted tree, hash ``made_at``)
    and through the repository's tree (today's code, hash ``today``), side by side, in
    ``scratch``, and compare every output; with ``stop_at_difference``, no item after the first
    that differs."""
    result = Verification(made_at, today, old[0])
    known = [item.estimate_s for item in items if math.isfinite(item.estimate_s)]
    # Each item's two versions run side by side, one per core; a process start each.
    minutes = (sum(known) + 30 * len(items)) / 60 if known else math.nan
    about = f", about {minutes:.0f} min from the recorded run times" if known else ""
    progress(
        f"rollout hash {made_at[:12]} ({old[0]}) -> {today[:12]} (today): {len(items)} items{about}"
    )
    versions = {"old": (old[1], made_at), "new": (repository, today)}
    with concurrent.futures.ThreadPoolExecutor(2) as pool:
        for number, item in enumerate(items, 1):
            futures = {
                label: pool.submit(
                    run_item, tree, item, scratch / made_at[:12] / label / str(number)
                )
                for label, (tree, _) in versions.items()
            }
            outputs = {label: future.result() for label, future in futures.items()}
            for label, (_, expected) in versions.items():
                for path in outputs[label].values():
                    if read_provenance_of(path)["rollout_code_sha256"] != expected:
                        raise RuntimeError(
                            f"{item.name}: the {label} code's {path.name} loaded other code"
                        )
            differences = _config_differences(outputs["old"], outputs["new"])
            digest, differing = compare_outputs(outputs["old"], outputs["new"])
            differences += differing
            result.digests[item.name] = digest
            result.differences += [f"{item.name}: {d}" for d in differences]
            verdict = "identical" if not differences else "; ".join(differences)
            progress(
                f"[{number}/{len(items)}] {item.name} ({item.run}, {item.iterations} "
                f"iterations): {verdict}"
            )
            if differences and stop_at_difference:
                progress(f"stopped at the first difference: {len(items) - number} items not run")
                break
    return result


def record_row(verification: Verification, items: Sequence[Item], to_commit: str) -> dict:
    """The equivalence record's row for a verification that found no difference."""
    return {
        "from_rollout_code_sha256": verification.from_hash,
        "to_rollout_code_sha256": verification.to_hash,
        "from_commit": verification.from_commit,
        "to_commit": to_commit,
        "items": json.dumps(
            [
                {
                    "item": item.name,
                    "config_files": list(item.config_files),
                    "run": item.run,
                    "recorded": item.recorded,
                    "iterations": item.iterations,
                    "sha256": verification.digests[item.name],
                }
                for item in items
            ]
        ),
        "cpu": machine()["cpu"],
        "python": sys.version.split()[0],
        "drake": package_versions()["drake"],
        "created_utc": datetime.now(UTC).isoformat(timespec="seconds"),
    }


def verify(
    studies: Sequence[Study],
    repository: Path,
    record: Path,
    progress: Callable[[str], None] = print,
    suite_of: Sequence[Study] | None = None,
    stop_at_difference: bool = False,
) -> list[Verification]:
    """Verify today's code (the tree at ``repository``) against the code that made the runs of
    ``studies`` that are not current (:func:`pih.publishing.equivalence.current_hashes`), once per
    hash they chain to (:func:`pih.publishing.equivalence.chained`), on the suite of ``suite_of``
    (default ``studies``; the command line: every published study, since a row makes every
    run at its hash current). When every item of every verification is identical, add one row
    per hash to ``record``; nothing otherwise. Bad input (no runs, a damaged file or record, an
    empty suite, a hash no commit gives) is refused in one line before any item runs; with
    ``stop_at_difference``, each verification stops at its first differing item."""
    from pih.publishing.equivalence import add_row, chained, current_hashes, read_record

    made = [read_provenance_of(path) for path in run_files(studies, repository)]
    rows = read_record(record)
    today = tree_hash(repository)
    current = current_hashes(today, record)
    stale = [p for p in made if p["rollout_code_sha256"] not in current]
    if not stale:
        progress(f"current: {len(made)} files made at rollout hashes that chain to today's")
        return []
    # The code of a hash: a run made at it, or a verification that reached it (the commit that
    # added its row to the record, or the commit the row names when that code was clean).
    heads = {
        made_at: chained(made_at, record) for made_at in {p["rollout_code_sha256"] for p in stale}
    }
    candidates: dict[str, list[str]] = {head: [] for head in heads.values()}
    for provenance in sorted(stale, key=lambda p: p["created_utc"], reverse=True):
        if heads[provenance["rollout_code_sha256"]] == provenance["rollout_code_sha256"]:
            candidates[provenance["rollout_code_sha256"]].append(provenance["code_version"])
    for head, commits in candidates.items():
        named = list(rows.loc[rows["to_rollout_code_sha256"] == head, "to_commit"][::-1])
        commits[:0] = [*_commits_of(record, repository), *named] if named else []
    items = suite(suite_of or studies, repository)
    if not items:
        raise ValueError("the suite is empty: no published run is at a sweep point of the config")
    with tempfile.TemporaryDirectory(prefix="pih-verify-") as scratch:
        scratch = Path(scratch)
        code = {
            head: commit_of(head, commits, repository, scratch / "code")
            for head, commits in candidates.items()
        }
        verifications = [
            verify_hash(
                head, code[head], items, repository, today, scratch, progress, stop_at_difference
            )
            for head in candidates
        ]
    if not any(v.differences for v in verifications):
        for verification in verifications:
            add_row(record_row(verification, items, git_describe(repository) or ""), record)
    return verifications


def _commits_of(path: Path, repository: Path) -> list[str]:
    """The commits that changed ``path``, the newest first."""
    log = _child(["git", "log", "--format=%h", "--", str(path)], repository)
    return log.stdout.split() if not log.returncode else []
