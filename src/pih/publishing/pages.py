"""A published study's results on its page (README, or a docs page): generated from its tables
(:func:`results_block`) between its markers (:attr:`PublishedStudy.markers`), never typed."""

from __future__ import annotations

import collections
import textwrap
from collections.abc import Mapping
from pathlib import Path

import pandas as pd

from pih.publishing.published import PUBLISHED_STUDIES, PublishedStudy, published_runs
from pih.records.outputs import read_provenance, write_text

DEFAULT_BEGIN, DEFAULT_END = PUBLISHED_STUDIES["default"].markers


def results_block(published: Path, study: PublishedStudy = PUBLISHED_STUDIES["default"]) -> str:
    """README's results for ``study``, generated from its published summary tables: the
    headline per method (and per compared level, :func:`pih.reporting.summary.planning_rows`) and its
    paired comparisons from offset starts (those from the training start are in
    ``summary.md``); with replays at a finer step, both at the runs' step and at that one. A
    study of the planner's own simulator (its tables have ``training_model``) shows that table
    instead (:func:`pih.reporting.summary.training_model_rows`)."""
    from pih.records.outputs import markdown_table
    from pih.reporting.summary import pair_evidence, perturbed_pairs, planning_rows, step_pairs

    tables = published / "planning" / "summary"
    if study.in_parts and not tables.is_dir():
        return _in_progress_block(published, study)
    record = read_provenance(tables / "success.parquet")
    drake = record.get("packages", {}).get("drake", "?")
    made = f"code `{record['code_version']}`, Drake {drake}, {record['created_utc'][:10]}"
    files = published.glob("planning/*/rollouts.parquet")
    runs = published_runs(published, study)[1] if study.in_parts else {str(f): f for f in files}
    # Runs made at other code than the tables (a study in parts; a study whose tables were
    # re-made) say where they were made.
    if study.in_parts or any(
        read_provenance(path)["code_version"] != record["code_version"] for path in runs.values()
    ):
        made = f"runs made at {_sources(runs)}; tables at {made}"
    source = f"The published {study.title} (`{study.directory}/`, {made})"
    for name in study.pools:
        pooled = PUBLISHED_STUDIES[name]
        runs = published_runs(published.parents[1] / pooled.directory, pooled)[1]
        source += (
            f" pooled with the {pooled.title}'s {len(runs)} runs (`{pooled.directory}/`, made "
            f"{_dates(runs)})"
        )
    begin, end = study.markers
    if (tables / "training_model.parquet").is_file():
        return _training_model_block(tables, source, (begin, end))
    success, robustness, paired = (
        pd.read_parquet(tables / f"{name}.parquet") for name in ("success", "robustness", "paired")
    )
    time_step = None
    pairs = pair_evidence(perturbed_pairs(paired, robustness))
    caption = "Paired from offset starts"
    if (tables / "time_step.parquet").is_file():
        time_step = pd.read_parquet(tables / "time_step.parquet")
        pairs, caption = step_pairs(paired, robustness), "Paired from offset starts, at each step"
    source += "; deployment success, 95 % interval over runs:"
    source = textwrap.fill(source, 100)
    return "\n\n".join(
        [
            begin,
            source,
            markdown_table(planning_rows(success, robustness, time_step), "{:.3g}").strip(),
            f"{caption} (what the columns mean: docs/planner.md, Intervals and tests):",
            markdown_table(pairs, "{:.3g}").strip(),
            end,
        ]
    )


def _training_model_block(tables: Path, source: str, markers: tuple[str, str]) -> str:
    """A study of the planner's own simulator: each training model's policies on the real
    scene, beside what their simulator predicted and against their real-scene-trained twins."""
    from pih.records.outputs import markdown_table
    from pih.reporting.summary import training_model_rows

    table = pd.read_parquet(tables / "training_model.parquet")
    std = table["start_std_m"].iloc[0] if len(table) else 0.0
    source += (
        f"; deployment success from starts {1e3 * std:g} mm off, 95 % interval over runs, and "
        "the pairs with the twins (docs/planner.md, Intervals and tests):"
    )
    return "\n\n".join(
        [
            markers[0],
            textwrap.fill(source, 100),
            markdown_table(training_model_rows(table), "{:.3g}").strip(),
            markers[1],
        ]
    )


def _in_progress_block(published: Path, study: PublishedStudy) -> str:
    """A study published in parts, before its last run is in: how far it is, and from where."""
    expected, runs = published_runs(published, study)
    drake = sorted(
        {read_provenance(p).get("packages", {}).get("drake", "?") for p in runs.values()}
    )
    text = (
        f"The {study.title} (`{study.directory}/`) is published in parts: {len(runs)} of its "
        f"{len(expected)} runs so far"
        + (f" (Drake {', '.join(drake)}; made at {_sources(runs)})" if runs else "")
        + "; its tables come once every run is in."
    )
    begin, end = study.markers
    return "\n\n".join([begin, textwrap.fill(text, 100), end])


def _sources(runs: Mapping[str, Path]) -> str:
    """Where runs were made: each code version, host and date once, with its number of runs,
    the earliest first."""
    made = sorted((read_provenance(path) for path in runs.values()), key=lambda r: r["created_utc"])
    counts = collections.Counter(
        f"`{r['code_version']}` on {r['host']}, {r['created_utc'][:10]}" for r in made
    )
    return ", ".join(f"{source} ({n} run{'s' * (n > 1)})" for source, n in counts.items())


def _dates(runs: Mapping[str, Path]) -> str:
    """The first and last day ``runs`` were made."""
    days = sorted(read_provenance(path)["created_utc"][:10] for path in runs.values())
    return days[0] if days[0] == days[-1] else f"{days[0]} – {days[-1]}"


def readme_with_results(
    readme: str, block: str, study: PublishedStudy = PUBLISHED_STUDIES["default"]
) -> str:
    """``readme`` with the text between ``study``'s results markers replaced by ``block``."""
    begin, end_marker = study.markers
    start, end = readme.index(begin), readme.find(end_marker)
    end = end + len(end_marker) if end >= 0 else start + len(begin)
    return readme[:start] + block + readme[end:]


def write_results(study: PublishedStudy) -> Path:
    """Regenerate ``study``'s results block on its page (run from the repository's root)."""
    page = Path(study.page)
    block = results_block(study.directory, study)
    write_text(page, readme_with_results(page.read_text(), block, study))
    return page
