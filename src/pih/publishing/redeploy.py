"""Redeployments a study's config asks for that its published runs lack, made in place: a model
error added to a study after its runs were published (``pih publish --redeploy``). It runs the
planner, imported only when it does."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from pih.publishing.equivalence import current_hashes
from pih.publishing.published import (
    PublishedStudy,
    one_line,
    published_run_reasons,
    published_runs,
    study_tables,
)


@dataclass(frozen=True)
class Redeployed:
    """What one :func:`redeploy_published` call did."""

    made: int
    """redeployment files written beside the published runs"""
    left: int
    """redeployments the study's config asks for that its published runs still lack"""
    tables: bool = False
    """whether the study's tables were re-made (once every run has every redeployment)"""


def redeploy_published(
    study: PublishedStudy,
    root: Path = Path("."),
    workers: int = 1,
    limit: int | None = None,
    progress: Callable[[str], None] = print,
) -> Redeployed:
    """Make the redeployments ``study``'s config asks for that its published runs lack (a model
    error added after the runs were published), each written beside its run in one atomic step,
    with the provenance a redeploy job writes (the model error, the code, Drake, the CPU); the
    run's own files stay as they are. Refused in one line before any is made: a config error
    (a model error that names no scene key), a published run that is not a sweep point of the
    config or not current (:func:`run_stale_reasons`). ``limit``: make at most that many, a part
    of the study. Once every run of the study has every redeployment, its tables are re-made."""
    from pih.planning.run_record import ROLLOUT_COLUMNS, RecordedRun
    from pih.records.outputs import write_table
    from pih.records.provenance import record
    from pih.study.config import check_study, load_config, redeployments, study_points
    from pih.study.redeployment import redeploy
    from pih.study.redeployment_record import redeployment_fields

    config = load_config([str(root / f) for f in study.config_files])
    check_study(config, study_points(config))
    files = redeployments(config)
    expected, runs = published_runs(root / study.directory, study)
    destination = root / study.directory / "planning"
    reasons = published_run_reasons(root, expected, runs, current_hashes())
    if reasons:
        raise ValueError(one_line(destination, reasons))
    todo = [
        (runs[key], name)
        for key in sorted(runs, key=lambda k: runs[k].parent.name)
        for name in sorted(files)
        if not (runs[key].parent / name).exists()
    ]
    for path, name in todo[:limit]:
        run, (start_std_m, model_error) = RecordedRun.read(path), files[name]
        table = redeploy(run, start_std_m, workers, model_error.get("settings"))
        fields = redeployment_fields(run, start_std_m, model_error)
        write_table(
            table, path.parent / name, record("redeploy", inputs=[path], **fields), ROLLOUT_COLUMNS
        )
        progress(f"{path.parent.name}/{name}")
    made = len(todo[:limit])
    left = len(todo) - made
    tables = not left and set(expected) <= set(runs)
    tables = tables and (made > 0 or not (destination / "summary").is_dir())
    if tables:
        study_tables(root, study)
    return Redeployed(made, left, tables)
