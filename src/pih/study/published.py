"""The published studies: what the repository carries, and whether it is still current.

``published/<study>/`` is a copy of one complete ``snakemake -j2`` run of a study
(:data:`PUBLISHED_STUDIES`: the default ``config/config.yaml``, and the sim-to-real study) at
one commit (:func:`publish` copies it from ``results/``: data, tables, figures, provenance; not
the recordings), and README's results for it are generated from its tables. The workflow never
reads it: a fresh clone recomputes everything. :func:`stale_reasons` says why it no longer
matches the config, the rollout code or the Drake that computes it (tests/test_published.py
fails then). Whether another run reproduced a published one is :mod:`pih.study.compare`'s.
"""

from __future__ import annotations

import importlib.metadata
import json
import shutil
import tempfile
import textwrap
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import pandas as pd

from pih.records.outputs import read_provenance
from pih.records.provenance import canonical_json, rollout_code_hash


@dataclass(frozen=True)
class PublishedStudy:
    """A study whose run the repository carries: its config files (as given to Snakemake) and
    what README calls it."""

    name: str
    config_files: tuple[str, ...]
    title: str
    globs: tuple[str, ...]
    """What :func:`publish` copies from the study's results tree."""
    page: str = "README.md"
    """The page whose results block :func:`results_block` generates from this study."""
    rerun_pending: str = ""
    """Why the published run is known to be stale (:func:`stale_reasons`) and when it is re-run;
    README's block says it, and the staleness test expects the run stale while it is set."""

    @property
    def directory(self) -> Path:
        return Path("published") / self.name

    @property
    def markers(self) -> tuple[str, str]:
        """The comments around the results generated from this study on its page."""
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
            page="docs/sim_to_real.md",
            rerun_pending=(
                "made by Drake 1.51.1 and not yet re-run under Drake 1.58; it is re-run at the "
                "paper's budget of 50 iterations once the time-step work has settled the physics"
            ),
        ),
    )
}
PUBLISHED_DIR = PUBLISHED_STUDIES["default"].directory


def expected_runs(config_files: tuple[str, ...]) -> dict[str, dict[str, object]]:
    """What a study's config computes: :func:`point_key` of each sweep point -> its resolved
    ``scene`` and ``planner`` sections."""
    from pih.study.config import load_config, resolved_sections, sweep_points

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
    ``scene`` and ``planner`` sections, :func:`pih.study.config.resolved_sections`), a run whose
    recorded config differs, or whose rollout code (:func:`pih.records.provenance.rollout_code_hash`) or
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
    headline per method (and per compared level, :func:`pih.study.summary.planning_rows`) and its
    paired comparisons from offset starts (those from the training start are in
    ``summary.md``)."""
    from pih.records.outputs import markdown_table
    from pih.study.summary import perturbed_pairs, planning_rows

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
    source = textwrap.fill(source, 100)
    if study.rerun_pending:
        source += "\n\n" + textwrap.fill(f"**Not current:** {study.rerun_pending}.", 100)
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
