"""``pih compare OLD NEW``: did a study reproduce another one (e.g. the published one)? At two
levels (docs/reproducibility.md):

- **data**: every headline number (deployment success per method from offset starts and from
  the training start, with intervals, the paired comparisons, Table 2–3's validation numbers,
  a study of the planner's own simulator's numbers per training model) and each planning run's
  data (the table of ``rollouts.parquet`` and its redeployments, without provenance),
  bit-identical or within ``rtol``. Each item that differs is one line.
- **conclusions**: each deployment success of NEW inside OLD's 95 % interval, each paired
  comparison's sign kept, each validation r within a tolerance; per training model, its
  simulator's prediction inside OLD's interval too and its sign against the twins trained on the
  real scene's model kept. This is what a run on another CPU or Drake can be expected to
  reproduce; the physics is chaotic at the µm level.

When the data differ, the two trees' provenance says what differs between the machines and code
that made them (:func:`likely_causes`). When OLD holds every planning run NEW does and more (the
sim-to-real study against a fresh default run, a subset of its runs), OLD is read at NEW's sweep
points only, its planning tables remade from those runs (:func:`runs_at_points`); when each holds
runs the other lacks (the paper-scale study, seed 0 only, against a fresh default run on seeds
0-1), both are read at the points they share (:func:`shared_points`). When NEW is a run of a
published study whose tables pool other published studies' runs (the contact-model study's pool
the sim-to-real study's, its runs' twins trained on the real scene's model), NEW's tables, and
those of any copy read at some points, are remade pooled with those studies' runs, as the
study's are (:func:`pooling_study`). Runs are matched over both trees' sweep keys
(:func:`run_directories`). No Drake, no simulation: it reads Parquet files.
"""

from __future__ import annotations

import math
import tempfile
from collections.abc import Iterable, Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from pih.analysis.aggregate import ROBUSTNESS_COLUMNS
from pih.analysis.run_summary import NO_MODEL_ERROR
from pih.analysis.training_model import REAL_SCENE
from pih.publishing.equivalence import REPOSITORY
from pih.publishing.published import (
    PUBLISHED_STUDIES,
    pooled_planning,
)
from pih.publishing.scope import (
    SUCCESS,
    pooling_study,
    pools_its_runs,
    restricted,
    run_directories,
    run_files,
    runs_at_points,
    shared_points,
    swept_keys,
)
from pih.records.outputs import read_provenance
from pih.records.provenance import input_sha256

R_TOLERANCE = 0.02
"""How far a validation correlation r may move for the conclusions to hold: the paper's own
pooled r(F_x) and r(F_z) differ by 0.09, and the step and contact settings move r by more."""

ROBUSTNESS = "planning/summary/robustness.parquet"
PAIRED = "planning/summary/paired.parquet"
TIME_STEP = "planning/summary/time_step.parquet"
TRAINING_MODEL = "planning/summary/training_model.parquet"
VALIDATION = "validation/comparison.parquet"

LEVELS = "<levels>"
"""In a table's key columns: the levels of the compared dimensions, whichever the table has
(robustness: its columns beside :data:`pih.analysis.aggregate.ROBUSTNESS_COLUMNS`), so that
rows at different levels of a sim-to-real study's training simulator stay apart."""

# (table under a results tree, the columns that name a row, the numbers compared)
HEADLINE_TABLES: tuple[tuple[str, tuple[str, ...], tuple[str, ...]], ...] = (
    (
        ROBUSTNESS,
        ("method", LEVELS, "start_std_m", "model_error"),
        ("runs", "deploy_success_rate", "deploy_ci_low", "deploy_ci_high", "runs_all_inserted"),
    ),
    (
        SUCCESS,
        ("method", "dimension", "level"),
        (
            "runs",
            "deploy_success_rate",
            "deploy_ci_low",
            "deploy_ci_high",
            "final_mean_deploy_success_rate",
            "median_goal_iteration",
        ),
    ),
    (
        PAIRED,
        ("method", "versus", "dimension", "level"),
        ("pairs", "better", "worse", "tied", "mean_difference", "sign_test_p"),
    ),
    (
        TRAINING_MODEL,
        ("method", "training_model", "start_std_m"),
        (
            "runs",
            "deploy_success_rate",
            "deploy_ci_low",
            "deploy_ci_high",
            "predicted_success_rate",
            "predicted_ci_low",
            "predicted_ci_high",
            "runs_mispredicted",
            "mean_gap",
            "pairs",
            "better",
            "worse",
            "tied",
            "mean_difference",
            "sign_test_p",
        ),
    ),
    (
        VALIDATION,
        ("variant", "alignment", "offset"),
        (
            "r_f_x",
            "r_f_z",
            "rel_err_initial_f_x_pct",
            "rel_err_final_f_x_pct",
            "rel_err_initial_f_z_pct",
            "rel_err_final_f_z_pct",
            "rel_err_final_theta_pct",
        ),
    ),
)

KEY_DEFAULTS = {"model_error": NO_MODEL_ERROR}
"""A key column a table of an older version lacks, as it reads (robustness before model
errors: every deployment on the training scene)."""


@dataclass(frozen=True)
class Difference:
    """Data that is not the same in the two trees: ``items`` compared items (one number, or
    every number of a row or file that one tree lacks, or one run file)."""

    where: str
    what: str
    old: object
    new: object
    items: int = 1

    def __str__(self) -> str:
        return f"{self.where}: {self.what}: {_show(self.old)} -> {_show(self.new)}"


@dataclass(frozen=True)
class Check:
    """One conclusion of OLD, checked on NEW."""

    where: str
    what: str
    holds: bool

    def __str__(self) -> str:
        return f"{'holds' if self.holds else 'FAILS'}: {self.where}: {self.what}"


@dataclass(frozen=True)
class Comparison:
    """Both levels of a comparison of two result trees."""

    differences: list[Difference]
    items: int
    checks: list[Check]
    causes: list[str]
    scope: str = ""
    """How the trees were read when one holds runs the other lacks (:func:`runs_at_points`,
    :func:`shared_points`) or NEW's tables were pooled with published runs
    (:func:`pooling_study`); empty when read as they are."""

    @property
    def data_identical(self) -> bool:
        return not self.differences

    @property
    def conclusions_hold(self) -> bool:
        """Every conclusion of OLD holds on NEW, and there was one to check."""
        return bool(self.checks) and all(check.holds for check in self.checks)

    def differing_items(self) -> int:
        return sum(d.items for d in self.differences)


def _show(value: object) -> str:
    return f"{value:.6g}" if isinstance(value, float) else str(value)


def _same(a: object, b: object, rtol: float) -> bool:
    if isinstance(a, float | int) and isinstance(b, float | int):
        a, b = float(a), float(b)
        if math.isnan(a) or math.isnan(b):
            return math.isnan(a) and math.isnan(b)
        return math.isclose(a, b, rel_tol=rtol, abs_tol=rtol)
    return a == b


def _rows(path: Path, keys: tuple[str, ...], numbers: tuple[str, ...]) -> dict[str, dict]:
    frame = pd.read_parquet(path)
    frame = frame.assign(**{k: v for k, v in KEY_DEFAULTS.items() if k in keys and k not in frame})
    levels = [c for c in frame.columns if c not in ROBUSTNESS_COLUMNS]
    keys = tuple(k for key in keys for k in (levels if key == LEVELS else [key]))
    present = [c for c in numbers if c in frame.columns]
    return {
        ", ".join(f"{k}={row[k]}" for k in keys if k in frame.columns): {c: row[c] for c in present}
        for _, row in frame.iterrows()
    }


def redeployed(tree: Path) -> set[tuple[float, str]] | None:
    """The deployments a tree holds, (start std, model error) as its robustness table lists them
    (the runs' own and every redeployment): what its config asked for, since a workflow run
    makes every redeployment its config asks for before its tables, a failed rollout recorded as
    data; None without that table."""
    path = tree / ROBUSTNESS
    if not path.is_file():
        return None
    frame = pd.read_parquet(path)
    if "model_error" not in frame:
        frame = frame.assign(model_error=NO_MODEL_ERROR)
    return set(zip(frame["start_std_m"].astype(float), frame["model_error"], strict=True))


def _asked_for(row: str, table: str, made: set[tuple[float, str]]) -> bool:
    """Whether OLD's ``row`` of ``table`` is about a deployment NEW made (:func:`redeployed`):
    a robustness row at a start std and model error NEW deployed at, a paired row under a model
    error NEW deployed on or from starts NEW deployed from."""
    fields = dict(part.split("=", 1) for part in row.split(", ") if "=" in part)
    errors = {error for _, error in made}
    stds = {std for std, _ in made}
    if table == ROBUSTNESS:
        error = fields.get("model_error", NO_MODEL_ERROR)
        return (float(fields["start_std_m"]), error) in made
    if fields.get("dimension") == "model_error":
        level = row.split("level=", 1)[1]
        return any(level == e or level.startswith(f"{e}, ") for e in errors)
    if fields.get("dimension") == "start_std_m":
        return float(fields["level"]) in stds
    if " m off" in row and "level=" in row:
        level = row.split("level=", 1)[1]
        off = level.split("starts ", 1)[1].split(" m off", 1)[0] if "starts " in level else None
        return off is None or float(off) in stds
    return True


def _tables(old: Path, new: Path, table: str, keys: tuple[str, ...], numbers: tuple[str, ...]):
    """Both trees' rows of ``table`` (None for a tree without it). The pairs at a replay's step
    count only when both trees hold replays: a workflow run makes none (a published study's are
    made beside its runs, ``pih publish --replay-step``), so a fresh run is judged on what it
    can reproduce. Likewise OLD's rows of deployments NEW's config did not ask for (a published
    study's ladder against a fresh default run) are not NEW's to reproduce (:func:`_asked_for`)."""
    rows = [_rows(t / table, keys, numbers) if (t / table).is_file() else None for t in (old, new)]
    if table == PAIRED and not all((t / TIME_STEP).is_file() for t in (old, new)):
        replayed = "dimension=time_step_s"
        rows = [r and {k: v for k, v in r.items() if replayed not in k} for r in rows]
    made = redeployed(new)
    if made is not None and table in (ROBUSTNESS, PAIRED) and rows[0] is not None:
        rows[0] = {k: v for k, v in rows[0].items() if _asked_for(k, table, made)}
    return tuple(rows)


def headline_differences(
    old: Path, new: Path, rtol: float, tables: tuple = HEADLINE_TABLES
) -> tuple[list[Difference], int]:
    """Every headline number (of ``tables``, default :data:`HEADLINE_TABLES`) that is missing
    from one tree or differs, and how many numbers the two trees hold between them."""
    differences, compared = [], 0
    for table, keys, numbers in tables:
        before, after = _tables(old, new, table, keys, numbers)
        if before is None or after is None:
            held = len(before or after or {}) * len(numbers)
            compared += held
            if held:
                presence = (before is None, after is None)
                differences.append(Difference(table, "file", *map(_presence, presence), held))
            continue
        compared += len(set(before) | set(after)) * len(numbers)
        for row in sorted(set(before) | set(after)):
            if row not in before or row not in after:
                presence = (row not in before, row not in after)
                differences.append(Difference(table, row, *map(_presence, presence), len(numbers)))
                continue
            for column in numbers:
                a, b = before[row].get(column), after[row].get(column)
                if not _same(a, b, rtol):
                    differences.append(Difference(table, f"{row}: {column}", a, b))
    return differences, compared


def _presence(missing: bool) -> str:
    return "missing" if missing else "present"


def _same_data(a: Path, b: Path) -> bool:
    """Whether two run files hold the same table, or agree in every column both have (a newer
    version adds columns, e.g. ``simulated_hole_*`` in 0.4.0)."""
    if input_sha256(a) == input_sha256(b):
        return True
    before, after = pd.read_parquet(a), pd.read_parquet(b)
    shared = [c for c in before.columns if c in after.columns]
    return len(before) == len(after) and before[shared].equals(after[shared])


def run_differences(old: Path, new: Path, keys: Iterable[str] = ()) -> Iterator[Difference]:
    """Every planning run file whose data (the table, not its provenance) differs or is missing,
    named by its path in the tree that has it (the new one when both do); runs are matched by
    their sweep point over ``keys`` too (:func:`run_directories`). A redeployment NEW made of
    none of its runs (a model error its config did not ask for) is not NEW's to reproduce."""
    before, after = run_files(old, keys), run_files(new, keys)
    made = {Path(data).name for data in after.values()}
    before = {name: data for name, data in before.items() if data.name in made}
    for name in sorted(set(before) | set(after)):
        where = after.get(name, before.get(name))
        tree = new if name in after else old
        label = str(where.relative_to(tree))
        if name not in before or name not in after:
            yield Difference(
                label, "run file", _presence(name not in before), _presence(name not in after)
            )
        elif not _same_data(before[name], after[name]):
            yield Difference(label, "data", "one table", "another")


SUCCESSES = {"deploy": "deployment success", "predicted": "predicted success"}
"""The success rates checked against OLD's interval, by their columns' prefix
(``<prefix>_success_rate``, ``<prefix>_ci_low``, ``<prefix>_ci_high``)."""


def _success_checks(
    before: dict, after: dict | None, table: str, prefix: str = "deploy"
) -> Iterator[Check]:
    for row, numbers in sorted(before.items()):
        low, high = numbers[f"{prefix}_ci_low"], numbers[f"{prefix}_ci_high"]
        rate = (after or {}).get(row, {}).get(f"{prefix}_success_rate")
        inside = rate is not None and low - 1e-12 <= rate <= high + 1e-12
        shown = "missing" if rate is None else f"{rate:.3g}"
        what = f"{SUCCESSES[prefix]} {shown} inside [{low:.3g}, {high:.3g}]"
        yield Check(f"{table}: {row}", what, inside)


def _sign(numbers: Mapping[str, Any]) -> int:
    return (numbers["better"] > numbers["worse"]) - (numbers["better"] < numbers["worse"])


def _signed(numbers: Mapping[str, Any] | None) -> str:
    if numbers is None:
        return "missing"
    if not numbers["pairs"]:
        return "no pairs"
    return f"{'0+-'[_sign(numbers)]} ({numbers['better']}/{numbers['worse']})"


def _sign_checks(before: dict, after: dict | None, table: str) -> Iterator[Check]:
    for row, values in sorted(before.items()):
        now = (after or {}).get(row)
        held = now is not None and now["pairs"] > 0 and _sign(now) == _sign(values)
        what = f"sign (pairs better/worse) {_signed(values)} -> {_signed(now)}"
        yield Check(f"{table}: {row}", what, held)


def _training_model_checks(before: dict, after: dict | None, table: str) -> Iterator[Check]:
    """Per method and training model: success on the real scene inside OLD's interval; for a
    model other than the real scene's, the success its simulator predicted inside OLD's interval
    (where OLD has a prediction) and, where OLD pairs it with twins trained on the real scene's
    model, the sign of those pairs kept."""
    yield from _success_checks(before, after, table)
    # Rows are named "method=…, training_model=…, start_std_m=…" (_rows).
    other = {k: v for k, v in before.items() if f"training_model={REAL_SCENE}," not in k}
    predicted = {k: v for k, v in other.items() if not math.isnan(v["predicted_success_rate"])}
    yield from _success_checks(predicted, after, table, "predicted")
    yield from _sign_checks({k: v for k, v in other.items() if v["pairs"]}, after, table)


def conclusion_checks(old: Path, new: Path, r_tolerance: float = R_TOLERANCE) -> list[Check]:
    """OLD's conclusions checked on NEW: deployment success per method and level inside OLD's
    95 % interval (robustness and success tables), each paired comparison's sign (better minus
    worse pairs) kept, per method and training model the conclusions of
    :func:`_training_model_checks`, and each validation r within ``r_tolerance``."""
    checks: list[Check] = []
    for table, keys, numbers in HEADLINE_TABLES:
        before, after = _tables(old, new, table, keys, numbers)
        if before is None:
            continue
        if table in (ROBUSTNESS, SUCCESS):
            checks += _success_checks(before, after, table)
        elif table == PAIRED:
            checks += _sign_checks(before, after, table)
        elif table == TRAINING_MODEL:
            checks += _training_model_checks(before, after, table)
        else:
            for row, values in sorted(before.items()):
                for column in ("r_f_x", "r_f_z"):
                    now = (after or {}).get(row, {}).get(column)
                    held = now is not None and abs(now - values[column]) <= r_tolerance
                    shown = "missing" if now is None else f"{now:.4f}"
                    what = f"{column} {values[column]:.4f} -> {shown} (within {r_tolerance:g})"
                    checks.append(Check(f"{table}: {row}", what, held))
    return checks


def _made_by(record: Mapping[str, Any]) -> dict[str, str]:
    """What made one run (its provenance), for :func:`likely_causes`."""
    machine = record.get("machine") or {}
    blas = "; ".join(f"{b['internal_api']} {b['architecture']}" for b in machine.get("blas", []))
    made = {
        "Drake": record.get("packages", {}).get("drake"),
        "rollout code": str(record.get("rollout_code_sha256"))[:12],
        "CPU": machine.get("cpu"),
        "BLAS kernel": blas or None,
        "Python": record.get("python"),
    }
    return {field: str(value or "not recorded") for field, value in made.items()}


def likely_causes(old: Path, new: Path) -> list[str]:
    """What differs between the machines and code that made the two trees' planning runs, from
    their provenance: another Drake, other rollout code, another CPU or BLAS kernel, another
    Python. A field a tree did not record (the CPU before 0.5.0) reads "not recorded"."""
    made = []
    for tree in (old, new):
        records = [_made_by(read_provenance(p)) for p in run_files(tree).values()]
        made.append(
            {f: ", ".join(sorted({r[f] for r in records})) for f in records[0]} if records else {}
        )
    causes = [
        f"another {field} ({made[0][field]} -> {made[1][field]})"
        for field in made[0]
        if field in made[1] and made[0][field] != made[1][field]
    ]
    before, after = (
        {name: f for name, f in run_files(tree).items() if f.name == "rollouts.parquet"}
        for tree in (old, new)
    )
    shared = sorted(set(before) & set(after))
    configs = [
        name
        for name in shared
        if read_provenance(before[name]).get("config_sha256")
        != read_provenance(after[name]).get("config_sha256")
    ]
    if configs:
        causes.insert(0, f"another config in {len(configs)} of the {len(shared)} runs both hold")
    return causes


def compare(
    old: Path, new: Path, rtol: float = 1e-9, r_tolerance: float = R_TOLERANCE
) -> Comparison:
    """Both levels of a comparison of two result trees (the module docstring)."""
    for tree in (old, new):
        if not (tree / "planning").is_dir() and not (tree / "validation").is_dir():
            raise FileNotFoundError(f"{tree}: not a results tree (no planning/ or validation/)")
    with tempfile.TemporaryDirectory(prefix="pih-compare-") as scratch:
        keys = swept_keys(old) | swept_keys(new)
        # NEW's tables pool its own runs only, where its study's pool other published studies'.
        study = pooling_study(new) if pools_its_runs(new) else None
        pooled = pooled_planning(REPOSITORY, study) if study else []
        subset = runs_at_points(old, new, Path(scratch), keys, pooled)
        shared = None if subset else shared_points(old, new, Path(scratch), keys, pooled)
        scopes = []
        if study is not None:
            others = " and ".join(
                f"the {PUBLISHED_STUDIES[name].title}'s runs ({PUBLISHED_STUDIES[name].directory})"
                for name in study.pools
            )
            scopes.append(
                f"{new} is a run of the {study.title}: the tables remade here pool {others}, as "
                "the study's do"
            )
        if subset is not None:
            scopes.append(
                f"{old} holds {len(run_directories(old))} planning runs: read at the "
                f"{len(run_directories(new))} sweep points {new} has, its tables remade from them"
            )
            old = subset
        elif shared is not None:
            scopes.append(
                f"{old} holds {len(run_directories(old))} planning runs and {new} "
                f"{len(run_directories(new))}: both read at the "
                f"{len(run_directories(shared[0]))} sweep points they share, their tables remade "
                "from them"
            )
            old, new = shared
        if study is not None and shared is None:
            runs = run_directories(new, keys)
            new = restricted(new, runs, set(runs), Path(scratch) / "new", pooled)
        scope = "; ".join(scopes)
        # A study read at some points or pooled is compared on what it carries (the paper-scale
        # and contact-model studies publish planning runs only, not a validation of their own).
        tables = HEADLINE_TABLES
        if scope:
            tables = tuple(t for t in HEADLINE_TABLES if (old / t[0]).is_file())
        differences, items = headline_differences(old, new, rtol, tables)
        differences += run_differences(old, new, keys)
        items += len(set(run_files(old, keys)) | set(run_files(new, keys)))
        causes = likely_causes(old, new) if differences else []
        checks = conclusion_checks(old, new, r_tolerance)
    return Comparison(differences, items, checks, causes, scope)
