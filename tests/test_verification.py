"""Published results stay current by code equivalence: the equivalence record (rows chain, a row
for another hash counts for nothing), recorded configs read through today's schema, the
validation's own code hash, and ``pih verify`` end to end in a temporary repository."""

from __future__ import annotations

import json
import os
import re
import shutil
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pandas as pd
import pytest

from pih.__main__ import main
from pih.analysis.run_summary import run_seconds
from pih.publishing.equivalence import add_row, chained, current_hashes, read_record
from pih.publishing.published import (
    PUBLISHED_DIR,
    expected_runs,
    expected_validation,
    run_stale_reasons,
    stale_reasons,
    validation_stale_reasons,
)
from pih.publishing.verification import Study, column_digests, compare_outputs, verify
from pih.records.outputs import write_table
from pih.records.provenance import (
    VALIDATION_MODULES,
    imported_library_modules,
    module_path,
    modules_hash,
    record,
    rollout_code_hash,
    validation_code_hash,
)

ROOT = Path(__file__).resolve().parents[1]
GIT = ["git", "-c", "user.name=pih test", "-c", "user.email=pih@localhost"]


def _row(source: str, target: str, commit: str = "abc1234") -> dict[str, str]:
    return {
        "from_rollout_code_sha256": source,
        "to_rollout_code_sha256": target,
        "from_commit": commit,
        "to_commit": commit,
        "items": "[]",
        "cpu": "test",
        "python": "3",
        "drake": "1",
        "created_utc": "2026-12-07T00:00:00+00:00",
    }


def test_rows_chain_and_a_row_for_other_hashes_counts_for_nothing(tmp_path):
    path = tmp_path / "equivalence.parquet"
    assert current_hashes("h3", path) == {"h3"}  # no record: only today's hash
    for source, target in (("h1", "h2"), ("h2", "h3"), ("x", "y")):
        add_row(_row(source, target), path)
    assert len(read_record(path)) == 3
    assert current_hashes("h3", path) == {"h1", "h2", "h3"}
    assert current_hashes("h2", path) == {"h1", "h2"}
    assert current_hashes("y", path) == {"x", "y"}
    assert chained("h1", path) == "h3" and chained("x", path) == "y" and chained("h9", path) == "h9"


def test_a_truncated_record_gets_one_line(tmp_path, monkeypatch, capsys):
    path = tmp_path / "equivalence.parquet"
    add_row(_row("h1", "h2"), path)
    path.write_bytes(path.read_bytes()[:100])
    with pytest.raises(ValueError, match="equivalence.parquet: not a readable equivalence record"):
        current_hashes("h2", path)
    # pih verify refuses it in one line before running anything.
    monkeypatch.setattr("pih.publishing.equivalence.RECORD", path)
    assert main(["verify", str(ROOT / PUBLISHED_DIR)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "not a readable equivalence record" in err[0], err


def _published_run(tmp_path: Path, made_at: str, sections: dict) -> Path:
    """A one-run study made at rollout hash ``made_at``, its config ``sections``."""
    provenance = record("plan", point={"s": 0}, config=sections)
    provenance["rollout_code_sha256"] = made_at
    path = tmp_path / "planning" / "s~0" / "rollouts.parquet"
    rows = pd.DataFrame({"phase": ["deploy"], "success": [True]})
    write_table(rows, path, provenance, {"phase": ("", "phase"), "success": ("1", "inserted")})
    return path


def _sections() -> dict:
    from pih.config import to_mapping
    from pih.planning.config import PlannerConfig
    from pih.scene.config import SceneConfig

    return {"scene": to_mapping(SceneConfig()), "planner": to_mapping(PlannerConfig())}


def test_a_run_at_a_verified_hash_is_current_and_at_another_is_not(tmp_path):
    sections = _sections()
    _published_run(tmp_path, "h1", sections)
    expected = {json.dumps({"s": 0}, separators=(",", ":")): sections}
    record_path = tmp_path / "equivalence.parquet"
    stale = ["planning/s~0/rollouts.parquet: made by other rollout code"]
    assert stale_reasons(tmp_path, expected, current_hashes("today", record_path)) == stale
    add_row(_row("h0", "today"), record_path)  # another hash: ignored
    add_row(_row("h1", "h2"), record_path)  # a chain that does not reach today: ignored
    assert stale_reasons(tmp_path, expected, current_hashes("today", record_path)) == stale
    add_row(_row("h2", "today"), record_path)
    assert stale_reasons(tmp_path, expected, current_hashes("today", record_path)) == []


def test_a_recorded_config_reads_through_todays_schema(tmp_path):
    """A key the run predates counts at its default; a changed value and a key today's schema
    no longer has are reasons, not crashes."""
    sections = _sections()
    older = json.loads(json.dumps(sections))
    del older["planner"]["convergence_tolerance"], older["scene"]["solver"]["retry_time_step_s"]
    path = _published_run(tmp_path, rollout_code_hash(), older)
    current = {rollout_code_hash()}
    assert run_stale_reasons(path, sections, tmp_path, current) == []
    changed = json.loads(json.dumps(sections))
    changed["planner"]["convergence_tolerance"] = 0.5
    assert run_stale_reasons(path, changed, tmp_path, current) == [
        "s~0: its planner config differs in convergence_tolerance"
    ]
    removed = json.loads(json.dumps(sections))
    removed["planner"]["a_key_since_removed"] = 1
    path = _published_run(tmp_path, rollout_code_hash(), removed)
    [reason] = run_stale_reasons(path, sections, tmp_path, current)
    assert reason.startswith("s~0: its planner config no longer reads:"), reason
    assert "a_key_since_removed" in reason


def test_a_mapping_valued_key_is_not_merged_with_its_default():
    """``validation.variants`` (default: three variants) recorded with one stays one."""
    from pih.config import with_defaults
    from pih.study.config import ValidationSection

    filled = with_defaults(ValidationSection, {"variants": {"hydroelastic": {}}})
    assert filled["variants"] == {"hydroelastic": {}}
    assert filled["offsets_m"] == list(ValidationSection().offsets_m)


def test_the_validation_hash_covers_what_the_experiment_computes_with():
    bookkeeping = {"config", "records.outputs", "records.provenance"}
    used = {
        name
        for name in imported_library_modules(module_path("validation.experiment"))
        if not name.endswith("__init__") and name not in bookkeeping
    }
    assert used <= {*VALIDATION_MODULES}, used - set(VALIDATION_MODULES)
    assert "validation.experiment" in VALIDATION_MODULES


def test_a_changed_validation_statement_stales_the_published_validation():
    """The published validation is judged by the validation hash it records, today's; one
    changed statement in the experiment gives another hash and stales it, a reworded docstring
    does not."""
    published = ROOT / PUBLISHED_DIR
    sections = expected_validation((str(ROOT / "config" / "config.yaml"),))
    assert validation_stale_reasons(published, sections) == []
    experiment = module_path("validation.experiment").read_text()
    assert "return params\n" in experiment

    def edited(old: str, new: str):
        return lambda name: (
            module_path(name).read_text().replace(old, new, 1)
            if name == "validation.experiment"
            else module_path(name).read_text()
        )

    docstring = modules_hash(VALIDATION_MODULES, edited('"""', '"""Reworded. '))
    assert docstring == validation_code_hash()
    statement = modules_hash(VALIDATION_MODULES, edited("return params\n", "return 1 * params\n"))
    assert statement != validation_code_hash()
    assert validation_stale_reasons(published, sections, code_sha256=statement) == [
        "validation/comparison.parquet: made by other validation code",
        "validation/variants.parquet: made by other validation code",
    ]


def test_outputs_are_compared_bit_for_bit_column_by_column(tmp_path):
    units = {"cost": ("1", "cost"), "status": ("", "status")}
    old, new = tmp_path / "old.parquet", tmp_path / "new.parquet"
    frame = pd.DataFrame({"cost": [1.0, float("nan")], "status": ["ok", "diverged"]})
    write_table(frame, old, record("plan"), units)
    write_table(frame, new, record("plan"), units)  # other provenance, same data
    assert compare_outputs({"r": old}, {"r": new})[1] == []
    reworded = {**units, "cost": ("1", "the cost J, reworded")}  # a column's description
    write_table(frame, new, record("plan"), reworded)
    assert compare_outputs({"r": old}, {"r": new})[1] == []
    frame["cost"] = frame["cost"] * (1 + 1e-12)
    write_table(frame, new, record("plan"), units)
    assert compare_outputs({"r": old}, {"r": new})[1] == ["r: column cost differs"]
    assert column_digests(old)["status"] == column_digests(new)["status"]


def test_the_suite_is_the_published_configurations_without_start_and_seed():
    """3 methods x {the real hole, the sensed hole per run}, and each stable goal published so far
    on the real hole, each at the recorded run whose mean inserted earliest, one iteration past
    that."""
    from pih.planning.config import STABLE_GOALS
    from pih.publishing.published import PUBLISHED_STUDIES
    from pih.publishing.verification import suite

    studies = [Study(s.directory, s.config_files) for s in PUBLISHED_STUDIES.values()]
    items = suite(studies, ROOT)
    stable = ROOT / PUBLISHED_STUDIES["stable_goal"].directory / "planning"
    published = [goal for goal in STABLE_GOALS if any(stable.glob(f"*_goal~{goal}_*"))]
    expected = [f"{goal}, true_hole" for goal in published]
    # Each trained in point contact (issue 70), once a run of it is published.
    contact = ROOT / PUBLISHED_STUDIES["contact_model"].directory / "planning"
    pattern = r"_goal~(\w+?)_contact_model~(\w+)_point_stiffness_n_per_m~([\d.e+]+)_seed~"
    expected += sorted(
        {
            ", ".join([*match.groups(), "true_hole"])
            for run in contact.glob("*")
            if (match := re.search(pattern, run.name))
        }
    )
    expected += [
        f"{goal}, {hole}"
        for goal in ("deepest_explored", "explored_argmin", "sensed_hole")
        for hole in ("sensed_per_run", "true_hole")
    ]
    assert [item.name for item in items] == sorted(expected)
    for item in items:
        [path] = (ROOT / "published").glob(f"*/planning/{item.recorded}/rollouts.parquet")
        rollouts = pd.read_parquet(path)
        means = rollouts[(rollouts["phase"] == "mean") & rollouts["success"]]
        assert item.iterations == means["iteration"].min() + 1 < 50, item
        assert item.outputs[-1] == "redeploy_start_std_m~0.001.parquet"
        # Its time, for pih verify's first line: the recorded run's for its iterations.
        assert item.estimate_s == pytest.approx(run_seconds(path) * item.iterations / 50)
        assert 0 < item.estimate_s < run_seconds(path)


def test_ending_pih_verify_ends_its_children_and_removes_its_scratch(tmp_path):
    """SIGTERM (or SIGHUP) to pih verify: the version's snakemake still running is ended with
    the jobs it started (its process group), and the scratch directory goes with the stack."""
    script = tmp_path / "verify.py"
    script.write_text(
        textwrap.dedent(
            """
            import sys, tempfile, threading, time
            from pathlib import Path
            from pih.cli.verify import stop_on_signals
            from pih.publishing.verification import _child

            stop_on_signals()
            with tempfile.TemporaryDirectory(prefix="pih-verify-", dir=sys.argv[1]) as scratch:
                command = ["bash", "-c", "sleep 300 & echo $! > " + scratch + "/job; wait"]
                worker = threading.Thread(target=_child, args=(command, Path(scratch)))
                worker.start()
                while not (Path(scratch) / "job").exists():
                    time.sleep(0.05)
                print((Path(scratch) / "job").read_text().strip(), flush=True)
                worker.join()
            """
        )
    )
    process = subprocess.Popen(
        [sys.executable, str(script), str(tmp_path)], stdout=subprocess.PIPE, text=True
    )
    job = int(process.stdout.readline())
    process.send_signal(signal.SIGTERM)
    assert process.wait(timeout=30) == 128 + signal.SIGTERM
    assert not list(tmp_path.glob("pih-verify-*"))  # the scratch directory is gone

    def running(pid: int) -> bool:
        """Alive and not a zombie (an orphan's parent may be slow to reap it)."""
        status = Path(f"/proc/{pid}/status")
        return status.is_file() and "\nState:\tZ" not in status.read_text()

    deadline = time.monotonic() + 10
    while running(job) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not running(job)  # the child's job is ended with it


def test_pih_verify_refuses_bad_input_in_one_line(tmp_path, capsys):
    empty = tmp_path / "paper"
    empty.mkdir()
    assert main(["verify", str(empty)]) == 1
    assert capsys.readouterr().err.strip() == (
        f"pih verify: {empty}: no planning runs (planning/*/rollouts.parquet)"
    )
    assert main(["verify", str(tmp_path)]) == 1
    assert "not a published study" in capsys.readouterr().err
    # A damaged run file is named.
    run = empty / "planning" / "s~0" / "rollouts.parquet"
    run.parent.mkdir(parents=True)
    run.write_bytes(b"PAR1 truncated")
    assert main(["verify", str(empty)]) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{run}: not a readable output" in err[0], err


def _study_made_at(tmp_path: Path, made_at: str, commit: str) -> Study:
    """A one-run study (its point not one of the config's) made at ``made_at`` by ``commit``."""
    from pih.records.outputs import read_provenance

    path = _published_run(tmp_path / "published" / "one", made_at, _sections())
    made = read_provenance(path)
    made["code_version"] = commit
    rows = pd.read_parquet(path)
    write_table(rows, path, made, {"phase": ("", "phase"), "success": ("1", "inserted")})
    return Study(tmp_path / "published" / "one", ("config/config.yaml",))


def _published_studies() -> list[Study]:
    from pih.publishing.published import PUBLISHED_STUDIES

    return [Study(s.directory, s.config_files) for s in PUBLISHED_STUDIES.values()]


def test_a_hash_no_commit_gives_is_refused_in_one_line(tmp_path):
    study = _study_made_at(tmp_path, "f" * 64, "0000000")
    record_path = tmp_path / "equivalence.parquet"
    with pytest.raises(ValueError, match=r"rollout hash ffffffffffff: no commit in history gives"):
        verify([study], ROOT, record_path, lambda line: None, _published_studies())
    assert not record_path.exists()
    # The suite is the config's: a study with no run at its sweep points has none.
    with pytest.raises(ValueError, match="the suite is empty"):
        verify([study], ROOT, record_path, lambda line: None)


def test_a_current_run_is_not_verified_again_when_the_record_goes_on(tmp_path):
    """Runs at today's hash are current even where the record leads on from it (a change
    verified, then reverted): nothing runs, nothing is written."""
    study = _study_made_at(tmp_path, rollout_code_hash(), "0000000")
    record_path = tmp_path / "equivalence.parquet"
    add_row(_row(rollout_code_hash(), "later"), record_path)
    lines: list[str] = []
    assert verify([study], ROOT, record_path, lines.append, _published_studies()) == []
    assert lines == ["current: 1 files made at rollout hashes that chain to today's"]
    assert len(read_record(record_path)) == 1


# End to end: a repository of its own, a tiny published study made by its first commit.

TINY = """\
planner: {iterations: 3, goal: deepest_explored}
sweep:
  planner.start_x_m: [-0.035]
  planner.goal: [deepest_explored]
  planner.seed: [0]
robustness: {start_std_m: [0.001], model_error: {}}
"""


def _git(repository: Path, *args: str) -> str:
    result = subprocess.run(
        [*GIT, *args], cwd=repository, capture_output=True, text=True, check=False
    )
    assert result.returncode == 0, result.stderr
    return result.stdout.strip()


def _edit(path: Path, old: str, new: str) -> None:
    text = path.read_text()
    assert text.count(old) == 1, old
    path.write_text(text.replace(old, new))


@pytest.mark.slow
def test_pih_verify_makes_an_unused_function_current_and_names_a_changed_cost(tmp_path):
    repository = tmp_path / "repo"
    for name in ("workflow", "config", "src"):
        ignored = shutil.ignore_patterns("*.egg-info", "__pycache__")
        shutil.copytree(ROOT / name, repository / name, ignore=ignored)
    for name in ("Snakefile", ".gitignore"):
        shutil.copy2(ROOT / name, repository / name)
    (repository / "config" / "tiny.yaml").write_text(TINY)
    _git(repository, "init", "-q")
    _git(repository, "add", "-A")
    _git(repository, "commit", "-qm", "made the study")
    # The tiny study, made by the first commit's workflow, published.
    env = {**os.environ, "PYTHONPATH": str(repository / "src")}
    config = ["config/config.yaml", "config/smoke.yaml", "config/tiny.yaml"]
    run = "results/planning/start_x_m~-0.035_goal~deepest_explored_seed~0"
    made = subprocess.run(
        [
            sys.executable,
            "-m",
            "snakemake",
            "-j2",
            "-d",
            str(tmp_path / "study"),  # outside the repository: what verify leaves there shows
            "--configfile",
            *(str(repository / f) for f in config),
            "--",
            f"{run}/rollouts.parquet",
            f"{run}/redeploy_start_std_m~0.001.parquet",
        ],
        cwd=repository,
        env=env,
        check=False,
        capture_output=True,
        text=True,
    )
    assert made.returncode == 0, made.stderr[-2000:]
    published = repository / "published" / "tiny" / "planning"
    shutil.copytree(
        tmp_path / "study" / run,
        published / Path(run).name,
        ignore=shutil.ignore_patterns("*.rrd", "best_paths.parquet"),
    )
    study = Study(repository / "published" / "tiny", tuple(config))
    record_path = repository / "published" / "equivalence.parquet"
    files = tuple(str(repository / f) for f in config)

    def stale() -> list[str]:
        from pih.publishing.verification import tree_hash

        current = current_hashes(tree_hash(repository), record_path)
        return stale_reasons(study.directory, expected_runs(files), current)

    # An unused function in the planner moves the hash: the run is stale, then verified current.
    planner = repository / "src" / "pih" / "planning" / "planner.py"
    planner.write_text(planner.read_text() + "\n\ndef _unused() -> int:\n    return 1\n")
    _git(repository, "add", "-A")
    _git(repository, "commit", "-qm", "an unused function")
    assert stale() == [
        f"{run.removeprefix('results/')}/{name}: made by other rollout code"
        for name in ("rollouts.parquet", "redeploy_start_std_m~0.001.parquet")
    ]
    lines: list[str] = []
    [verification] = verify([study], repository, record_path, progress=lines.append)
    assert verification.differences == [], lines
    assert "identical" in lines[-1] and "deepest_explored, true_hole" in lines[-1], lines
    assert stale() == []
    [row] = read_record(record_path).to_dict("records")
    assert row["from_commit"] == _git(repository, "rev-parse", "--short", "HEAD~1")
    assert json.loads(row["items"])[0]["iterations"] >= 2
    # Nothing left behind: the record is the only new file, ignored ones included.
    status = _git(repository, "status", "--porcelain", "--ignored", "--untracked-files=all")
    left = [line for line in status.splitlines() if "__pycache__" not in line]
    assert left == ["?? published/equivalence.parquet"], left
    # Cost totals x (1 + 1e-12): verify names the cost column and records nothing.
    _git(repository, "add", "-A")
    _git(repository, "commit", "-qm", "verified")
    _edit(
        repository / "src" / "pih" / "planning" / "costs.py",
        "return np.sum(values / self.divisors, axis=1)",
        "return np.sum(values / self.divisors, axis=1) * (1 + 1e-12)",
    )
    lines.clear()
    [verification] = verify([study], repository, record_path, progress=lines.append)
    # The runs chain to the verified hash, whose code is the commit that added the record's row.
    assert verification.from_commit == _git(repository, "rev-parse", "--short", "HEAD")
    assert (
        verification.differences[0]
        == "deepest_explored, true_hole: rollouts.parquet: column cost differs"
    ), verification.differences
    assert len(read_record(record_path)) == 1
    assert stale() != []


def test_a_null_is_compared_by_its_place_not_by_the_bytes_behind_it():
    import numpy as np
    import pyarrow as pa

    validity = pa.py_buffer(np.packbits([1, 0, 1], bitorder="little").tobytes())

    def table(behind_null: float) -> pa.Table:
        data = pa.py_buffer(np.array([1.0, behind_null, 3.0]).tobytes())
        return pa.table({"cost": pa.Array.from_buffers(pa.float64(), 3, [validity, data])})

    assert table(7.0).equals(table(-2.0))
    assert column_digests(table(7.0)) == column_digests(table(-2.0))
    moved = pa.table({"cost": pa.array([1.0, 3.0, None])})
    assert column_digests(moved) != column_digests(table(7.0))
    nested = [pa.table({"w": pa.array([[1.0, None]] * 2)}) for _ in range(2)]
    assert column_digests(nested[0]) == column_digests(nested[1])


def test_an_older_versions_best_paths_are_thinned_alike_before_they_are_compared(tmp_path):
    """A newer plan script keeps each path's cost samples and its last step: the older file's
    every-step paths are thinned at the stride the newer file's times show, then compared whole,
    so a row missing or added still differs."""
    import numpy as np

    from pih.records.sampling import path_samples

    units = {"iteration": ("1", "i"), "time_s": ("s", "t"), "robot_x_m": ("m", "x")}
    # The first path stopped after 5 steps (a diverged best rollout), the third early too.
    steps = [np.arange(0, n) * 0.0005 for n in (5, 45, 33)]
    full = pd.DataFrame(
        {
            "iteration": np.repeat([1, 2, 3], [len(t) for t in steps]),
            "time_s": np.concatenate(steps),
            "robot_x_m": np.sin(np.arange(83.0)),
        }
    )
    thinned = full[path_samples(full["iteration"].to_numpy(), 20)].reset_index(drop=True)
    assert list(thinned["time_s"].round(4)) == [0, 0.002, 0, 0.01, 0.02, 0.022, 0, 0.01, 0.016]
    old, new = tmp_path / "old.parquet", tmp_path / "new.parquet"
    write_table(full, old, record("plan"), units)
    outputs = {"best_paths.parquet": old}, {"best_paths.parquet": new}
    write_table(thinned, new, record("plan"), units)
    assert compare_outputs(*outputs)[1] == []
    for changed in (thinned.drop(index=2), pd.concat([thinned, thinned.tail(1)])):
        write_table(changed.reset_index(drop=True), new, record("plan"), units)
        assert compare_outputs(*outputs)[1] == ["best_paths.parquet: column iteration differs"]


def test_a_validation_table_older_than_its_hash_is_judged_by_the_modules_its_commit_had():
    """A commit before records.sampling joined the validation modules reads it as empty (not
    as a commit the history lacks); a commit the history does not hold gives no hash."""
    from pih.publishing.published import validation_hash_at

    before = validation_hash_at("0b3a0c2")
    assert before is not None and before != validation_code_hash()
    assert validation_hash_at("f" * 40) is None


def test_verify_can_stop_at_the_first_difference(tmp_path, monkeypatch):
    """``--stop-at-difference``: no item runs after the first whose outputs differ, and the
    first line says how many items there are and roughly how long they take."""
    from pih.publishing import verification
    from pih.publishing.verification import Item, verify_hash

    items = [
        Item(f"item {k}", ("config/config.yaml",), {"planner.seed": k}, 3, "", f"run{k}", 60.0)
        for k in range(4)
    ]
    ran = []

    def run_item(tree, item, workdir):
        ran.append((tree.name, item.name))
        return {"rollouts.parquet": Path(tree.name) / item.name}

    hashes = {"old": "a" * 64, "new": "b" * 64}
    monkeypatch.setattr(verification, "run_item", run_item)
    monkeypatch.setattr(
        verification,
        "read_provenance_of",
        lambda path: {"rollout_code_sha256": hashes[str(path).split("/")[0]]},
    )
    monkeypatch.setattr(verification, "_config_differences", lambda old, new: [])
    differs = {"item 1"}
    monkeypatch.setattr(
        verification,
        "compare_outputs",
        lambda old, new: (
            "digest",
            ["rollouts.parquet: cost"] if new["rollouts.parquet"].name in differs else [],
        ),
    )
    lines: list[str] = []
    old, new = tmp_path / "old", tmp_path / "new"
    result = verify_hash(
        hashes["old"], ("abc", old), items, new, hashes["new"], tmp_path, lines.append, True
    )
    assert [name for _, name in ran] == ["item 0", "item 0", "item 1", "item 1"]
    assert result.differences == ["item 1: rollouts.parquet: cost"]
    assert lines[0].endswith(": 4 items, about 6 min from the recorded run times")
    assert lines[-1] == "stopped at the first difference: 2 items not run"
    ran.clear()
    verify_hash(hashes["old"], ("abc", old), items, new, hashes["new"], tmp_path, lines.append)
    assert len(ran) == 8  # without the flag, every item
