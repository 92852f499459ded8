"""The published studies: what the repository carries, whether it is still current, and
``pih compare OLD NEW``: did a study reproduce another one (e.g. the published one)?

``published/<study>/`` is a copy of one complete ``snakemake -j2`` run of a study
(:data:`PUBLISHED_STUDIES`: the default ``config/config.yaml``, and the sim-to-real study) at
one commit (:func:`publish` copies it from ``results/``: data, tables, figures, provenance; not
the recordings), and README's results for it are generated from its tables. The workflow never
reads it: a fresh clone recomputes everything. :func:`stale_reasons` says why it no longer
matches the config or the rollout code (tests/test_published.py fails then).

Two result trees (``results/`` directories of studies) are compared on their headline numbers —
deployment success per method from offset starts and from the training start, with intervals,
the paired comparisons, Table 2–3's validation numbers — and on each planning run's data (the
table of ``rollouts.parquet`` and its redeployments, without provenance). Every number that
differs is one line; the last line counts them. No Drake, no simulation: it reads Parquet files.
"""

from __future__ import annotations

import importlib.metadata
import json
import math
import shutil
import tempfile
from collections.abc import Iterator, Mapping
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from pih.aggregate import NO_MODEL_ERROR
from pih.outputs import read_provenance
from pih.provenance import canonical_json, input_sha256, rollout_code_hash


@dataclass(frozen=True)
class PublishedStudy:
    """A study whose run the repository carries: its config files (as given to Snakemake) and
    what README calls it."""

    name: str
    config_files: tuple[str, ...]
    title: str
    globs: tuple[str, ...]
    """What :func:`publish` copies from the study's results tree."""
    rerun_pending: str = ""
    """Why the published run is known to be stale (:func:`stale_reasons`) and when it is re-run;
    README's block says it, and the staleness test expects the run stale while it is set."""

    @property
    def directory(self) -> Path:
        return Path("published") / self.name

    @property
    def markers(self) -> tuple[str, str]:
        """README's comments around the results generated from this study."""
        tail = "" if self.name == "default" else f" {self.name}"
        return f"<!-- PUBLISHED-RESULTS{tail} -->", f"<!-- /PUBLISHED-RESULTS{tail} -->"


PLANNING_GLOBS = (
    "summary.md",
    "provenance.md",
    "planning/*/rollouts.parquet",
    "planning/*/redeploy_*.parquet",
    "planning/summary/*",
)
"""Every rollout's record (≈ 0.3 MB a run), the planning tables, figures and provenance. Not
the per-step traces (best paths, validation runs: tens of MB a run at 0.5 ms), the recordings or
the report, which the workflow remakes."""

PUBLISHED_STUDIES = {
    study.name: study
    for study in (
        PublishedStudy(
            "default",
            ("config/config.yaml",),
            "default study",
            (*PLANNING_GLOBS, "validation/*.*", "whitney/*.parquet"),
        ),
        # Its validation is the default's (two of its variants): only the compared numbers.
        PublishedStudy(
            "sim_to_real",
            ("config/config.yaml", "config/sim_to_real.yaml"),
            "sim-to-real study",
            (*PLANNING_GLOBS, "validation/comparison.*", "validation/variants.*"),
            rerun_pending=(
                "made by Drake 1.51.1 and not yet re-run under this code and Drake: it is re-run "
                "at the paper's budget once the physics settles (issues 44, 45)"
            ),
        ),
    )
}
PUBLISHED_DIR = PUBLISHED_STUDIES["default"].directory

# (table under a results tree, the columns that name a row, the numbers compared)
HEADLINE_TABLES: tuple[tuple[str, tuple[str, ...], tuple[str, ...]], ...] = (
    (
        "planning/summary/robustness.parquet",
        ("method", "start_std_m", "model_error"),
        ("runs", "deploy_success_rate", "deploy_ci_low", "deploy_ci_high", "runs_all_inserted"),
    ),
    (
        "planning/summary/success.parquet",
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
        "planning/summary/paired.parquet",
        ("method", "versus", "dimension", "level"),
        ("pairs", "better", "worse", "tied", "mean_difference", "sign_test_p"),
    ),
    (
        "validation/comparison.parquet",
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


@dataclass(frozen=True)
class Difference:
    """One headline number or one run's data that is not the same in the two trees."""

    where: str
    what: str
    old: object
    new: object

    def __str__(self) -> str:
        return f"{self.where}: {self.what}: {_show(self.old)} -> {_show(self.new)}"


def _show(value: object) -> str:
    return f"{value:.6g}" if isinstance(value, float) else str(value)


def _same(a: object, b: object, rtol: float) -> bool:
    if isinstance(a, float | int) and isinstance(b, float | int):
        a, b = float(a), float(b)
        if math.isnan(a) or math.isnan(b):
            return math.isnan(a) and math.isnan(b)
        return math.isclose(a, b, rel_tol=rtol, abs_tol=rtol)
    return a == b


KEY_DEFAULTS = {"model_error": NO_MODEL_ERROR}
"""A key column a table of an older version lacks, as it reads (robustness before model
errors: every deployment on the training scene)."""


def _rows(path: Path, keys: tuple[str, ...], numbers: tuple[str, ...]) -> dict[str, dict]:
    frame = pd.read_parquet(path)
    frame = frame.assign(**{k: v for k, v in KEY_DEFAULTS.items() if k in keys and k not in frame})
    present = [c for c in numbers if c in frame.columns]
    return {
        ", ".join(f"{k}={row[k]}" for k in keys if k in frame.columns): {c: row[c] for c in present}
        for _, row in frame.iterrows()
    }


def headline_differences(old: Path, new: Path, rtol: float) -> tuple[list[Difference], int]:
    """Every headline number (:data:`HEADLINE_TABLES`) that is missing from one tree or differs,
    and how many numbers ``old`` holds."""
    differences, compared = [], 0
    for table, keys, numbers in HEADLINE_TABLES:
        paths = old / table, new / table
        missing = [not p.is_file() for p in paths]
        if any(missing):
            if not all(missing):
                differences.append(Difference(table, "file", *map(_presence, missing)))
            continue
        before, after = (_rows(p, keys, numbers) for p in paths)
        compared += len(before) * len(numbers)
        for row in sorted(set(before) | set(after)):
            if row not in before or row not in after:
                presence = (row not in before, row not in after)
                differences.append(Difference(table, row, *map(_presence, presence)))
                continue
            for column in numbers:
                a, b = before[row].get(column), after[row].get(column)
                if not _same(a, b, rtol):
                    differences.append(Difference(table, f"{row}: {column}", a, b))
    return differences, compared


def _presence(missing: bool) -> str:
    return "missing" if missing else "present"


def run_files(tree: Path) -> dict[str, Path]:
    """The planning runs' data files of a tree, by their run's sweep point (in today's keys,
    :func:`pih.study_config.upgraded_point`: directory names changed with 0.4.0) and file name."""
    from pih.study_config import upgraded_point

    files = {}
    for rollouts in sorted((tree / "planning").glob("*/rollouts.parquet")):
        point = point_key(upgraded_point(read_provenance(rollouts)["sweep_point"]))
        for data in [rollouts, *sorted(rollouts.parent.glob("redeploy_*.parquet"))]:
            files[f"{point} {data.name}"] = data
    return files


def _same_data(a: Path, b: Path) -> bool:
    """Whether two run files hold the same table, or agree in every column both have (a newer
    version adds columns, e.g. ``simulated_hole_*`` in 0.4.0)."""
    if input_sha256(a) == input_sha256(b):
        return True
    before, after = pd.read_parquet(a), pd.read_parquet(b)
    shared = [c for c in before.columns if c in after.columns]
    return len(before) == len(after) and before[shared].equals(after[shared])


def run_differences(old: Path, new: Path) -> Iterator[Difference]:
    """Every planning run file whose data (the table, not its provenance) differs or is missing,
    named by its path in the tree that has it (the new one when both do)."""
    before, after = run_files(old), run_files(new)
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


def compare(old: Path, new: Path, rtol: float = 1e-9) -> tuple[list[Difference], int]:
    """The differences between two result trees and how many items were compared."""
    for tree in (old, new):
        if not (tree / "planning").is_dir() and not (tree / "validation").is_dir():
            raise FileNotFoundError(f"{tree}: not a results tree (no planning/ or validation/)")
    differences, compared = headline_differences(old, new, rtol)
    differences += run_differences(old, new)
    return differences, compared + len(set(run_files(old)) | set(run_files(new)))


def expected_runs(config_files: tuple[str, ...]) -> dict[str, dict[str, object]]:
    """What a study's config computes: :func:`point_key` of each sweep point -> its resolved
    ``scene`` and ``planner`` sections."""
    from pih.study_config import load_config, resolved_sections, sweep_points

    config = load_config(list(config_files))
    points = sweep_points(config["sweep"], config.get("variants"), config["planner"]["goal"])
    return {point_key(p): resolved_sections(config, p) for p in points}


def publish(results: Path, study: PublishedStudy, root: Path = Path(".")) -> int:
    """Copy a finished run of ``study`` (its :attr:`PublishedStudy.globs` under ``results``)
    into its directory under ``root``, replacing what was there; the number of files copied. A
    tree that is not that study's run at this code (:func:`stale_reasons`) is refused before
    anything is copied."""
    files = sorted({f for pattern in study.globs for f in results.glob(pattern) if f.is_file()})
    if not files:
        raise FileNotFoundError(f"{results}: no study outputs to publish")
    config_files = tuple(str(root / f) for f in study.config_files)
    reasons = stale_reasons(results, expected_runs(config_files))
    if reasons:
        more = f" (and {len(reasons) - 1} more)" if len(reasons) > 1 else ""
        raise ValueError(f"{results} is not a run of the {study.title}: {reasons[0]}{more}")
    destination = root / study.directory
    destination.parent.mkdir(parents=True, exist_ok=True)
    # Copied beside it first, so that an interrupted copy leaves the published study whole.
    staging = Path(tempfile.mkdtemp(prefix=f".{study.name}-", dir=destination.parent))
    try:
        for source in files:
            target = staging / source.relative_to(results)
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(source, target)
        if destination.exists():
            shutil.rmtree(destination)
        staging.rename(destination)
    finally:
        shutil.rmtree(staging, ignore_errors=True)
    return len(files)


def stale_reasons(
    published: Path,
    expected: Mapping[str, Mapping[str, object]],
    code_sha256: str | None = None,
    drake: str | None = None,
) -> list[str]:
    """Why the published planning runs no longer are what the repository would compute: runs
    missing or extra against ``expected`` (:func:`point_key` of a sweep point -> its resolved
    ``scene`` and ``planner`` sections, :func:`pih.study_config.resolved_sections`), a run whose
    recorded config differs, or whose rollout code (:func:`pih.provenance.rollout_code_hash`) or
    Drake (default: the installed one) does."""
    code_sha256 = code_sha256 or rollout_code_hash()
    drake = drake or importlib.metadata.version("drake")
    runs = {}
    for path in sorted((published / "planning").glob("*/rollouts.parquet")):
        runs[point_key(read_provenance(path)["sweep_point"])] = path
    reasons = [f"sweep point {key} is not published" for key in sorted(set(expected) - set(runs))]
    reasons += [
        f"{runs[key].parent.name} is not a sweep point of the config"
        for key in sorted(set(runs) - set(expected))
    ]
    for key in sorted(set(runs) & set(expected)):
        path = runs[key]
        for data in [path, *sorted(path.parent.glob("redeploy_*.parquet"))]:
            made = read_provenance(data)
            if made.get("rollout_code_sha256") != code_sha256:
                reasons.append(f"{data.relative_to(published)}: made by other rollout code")
            made_by = made.get("packages", {}).get("drake")
            if made_by != drake:
                reasons.append(
                    f"{data.relative_to(published)}: made by Drake {made_by}, not {drake}"
                )
        recorded = read_provenance(path)["config"]
        for section in ("scene", "planner"):
            now = json.loads(canonical_json(expected[key][section]))
            if recorded.get(section) != now:
                keys = ", ".join(_differing_keys(recorded.get(section) or {}, now))
                reasons.append(f"{path.parent.name}: its {section} config differs in {keys}")
    return reasons


def point_key(point: Mapping[str, object]) -> str:
    """A sweep point as one comparable string."""
    return canonical_json(dict(point))


def _differing_keys(old: Mapping, new: Mapping, prefix: str = "") -> list[str]:
    keys = []
    for key in sorted(set(old) | set(new)):
        a, b = old.get(key), new.get(key)
        if isinstance(a, Mapping) and isinstance(b, Mapping):
            keys += _differing_keys(a, b, f"{prefix}{key}.")
        elif a != b:
            keys.append(f"{prefix}{key}")
    return keys


README_BEGIN, README_END = PUBLISHED_STUDIES["default"].markers


def results_block(published: Path, study: PublishedStudy = PUBLISHED_STUDIES["default"]) -> str:
    """README's results for ``study``, generated from its published summary tables: the
    headline per method (and per compared level, :func:`pih.summary.planning_rows`) and its
    paired comparisons from offset starts (those from the training start are in
    ``summary.md``)."""
    from pih.outputs import markdown_table
    from pih.summary import perturbed_pairs, planning_rows

    tables = published / "planning" / "summary"
    success, robustness, paired = (
        pd.read_parquet(tables / f"{name}.parquet") for name in ("success", "robustness", "paired")
    )
    record = read_provenance(tables / "success.parquet")
    drake = record.get("packages", {}).get("drake", "?")
    source = (
        f"The published {study.title} (`{study.directory}/`, code `{record['code_version']}`, "
        f"Drake {drake}, {record['created_utc'][:10]}); deployment success, 95 % interval over "
        "runs:"
    )
    if study.rerun_pending:
        source += f"\n\n**Not current:** {study.rerun_pending}."
    begin, end = study.markers
    return "\n\n".join(
        [
            begin,
            source,
            markdown_table(planning_rows(success, robustness), "{:.3g}").strip(),
            "Paired from offset starts (sign test over the untied pairs):",
            markdown_table(perturbed_pairs(paired, robustness), "{:.3g}").strip(),
            end,
        ]
    )


def readme_with_results(
    readme: str, block: str, study: PublishedStudy = PUBLISHED_STUDIES["default"]
) -> str:
    """``readme`` with the text between ``study``'s results markers replaced by ``block``."""
    begin, end_marker = study.markers
    start, end = readme.index(begin), readme.find(end_marker)
    end = end + len(end_marker) if end >= 0 else start + len(begin)
    return readme[:start] + block + readme[end:]
