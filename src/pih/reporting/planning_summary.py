"""The planning summary files, one writer for the workflow's ``planning_aggregate`` job and for
``pih aggregate``: cost bands (Fig. 9), success, paired, robustness and ablation tables as
Parquet with column units and as Markdown, and their figures (docs/planner.md)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pandas as pd

from pih.analysis.aggregate import (
    BAND_COLUMNS,
    PAIRED_COLUMNS,
    SUCCESS_COLUMNS,
    PlanningTables,
    compared_keys,
    figure_bands,
    per_run_columns,
    planning_tables,
    robustness_columns,
)
from pih.analysis.ladder import LADDER_COLUMNS, LADDER_PAIR_COLUMNS, ladder_columns
from pih.analysis.pooling import SOURCE_COLUMNS, PooledRuns
from pih.analysis.run_summary import BEST_COST_COLUMNS, level_columns
from pih.analysis.time_step import time_step_columns, with_time_step
from pih.analysis.training_model import TRAINING_MODEL_COLUMNS
from pih.records.outputs import markdown_table, write_table, write_text
from pih.records.provenance import record as provenance_record
from pih.reporting import plots


def write_planning_summary(
    directory: Path,
    runs: pd.DataFrame,
    tables: PlanningTables,
    sweep_keys: list[str],
    record: dict[str, Any],
) -> None:
    """Every summary file of a study's planning runs under ``directory`` (``runs``,
    ``cost_bands``, ``success``, ``paired``, ``robustness``, ``ablation``, ``per_run``, with
    replays ``time_step``, with a swept ``planner.simulator`` ``training_model``, with two rungs
    of the deployment ladder ``ladder`` (and ``ladder_pairs.parquet``, ``fig_ladder.png``):
    ``.parquet`` and ``.md``; ``success.csv``; ``fig9_cost_bands.{png,pdf}``,
    ``fig_deploy_success.png``),
    each with the provenance ``record``."""
    directory = Path(directory)
    frames = {
        "runs": (runs, {**BEST_COST_COLUMNS, **level_columns(sweep_keys)}),
        "cost_bands": (tables.bands, BAND_COLUMNS),
        "success": (tables.success, SUCCESS_COLUMNS),
        "paired": (tables.paired, PAIRED_COLUMNS),
        "robustness": (tables.robustness, robustness_columns(sweep_keys)),
        "ablation": (tables.ablation, SUCCESS_COLUMNS),
        "per_run": (tables.per_run, per_run_columns(sweep_keys)),
    }
    if tables.time_step is not None:
        frames["time_step"] = (tables.time_step, time_step_columns(sweep_keys))
    if tables.training_model is not None:
        frames["training_model"] = (tables.training_model, TRAINING_MODEL_COLUMNS)
    if tables.ladder is not None:
        compared = level_columns(compared_keys(sweep_keys))
        frames["ladder"] = (tables.ladder, ladder_columns(LADDER_COLUMNS, compared))
        frames["ladder_pairs"] = (
            tables.ladder_pairs,
            ladder_columns(LADDER_PAIR_COLUMNS, compared),
        )
    for name, (frame, columns) in frames.items():
        write_table(frame, directory / f"{name}.parquet", record, columns)
    robustness = f"{markdown_table(tables.robustness)}\n\n{markdown_table(tables.robustness_pairs)}"
    compared = tables.robustness_pairs["dimension"].isin(compared_keys(sweep_keys))
    # An ablation's answer: each level's nominal deployment, its deployments from offset starts
    # and the pairs there, then each variant against the reference.
    ablation = [tables.ablation, tables.robustness, tables.robustness_pairs[compared]]
    if len(compared_keys(sweep_keys)) == 0:
        ablation = ablation[:1]
    markdown = {
        "success": markdown_table(tables.success),
        "per_run": markdown_table(tables.per_run.drop(columns="run")),
        "paired": markdown_table(tables.paired),
        "robustness": robustness,
        "ablation": "\n\n".join(
            markdown_table(t) for t in [*ablation, tables.variant_pairs] if len(t)
        ),
    }
    if tables.time_step is not None:
        markdown["time_step"] = "\n\n".join(
            markdown_table(t) for t in (tables.time_step, tables.time_step_pairs)
        )
    if tables.training_model is not None:
        markdown["training_model"] = markdown_table(tables.training_model)
    if tables.ladder is not None:
        markdown["ladder"] = "\n\n".join(
            markdown_table(t) for t in (tables.ladder, tables.ladder_pairs)
        )
    # An earlier pooling's table that this one has no data for would misreport it.
    for name in {"time_step", "training_model", "ladder"} - set(markdown):
        for path in (directory / f"{name}.parquet", directory / f"{name}.md"):
            path.unlink(missing_ok=True)
    if tables.ladder is None:
        for path in (directory / "ladder_pairs.parquet", directory / "fig_ladder.png"):
            path.unlink(missing_ok=True)
    for name, text in markdown.items():
        write_text(directory / f"{name}.md", text, record)
    write_text(directory / "success.csv", tables.success.to_csv(index=False))
    plots.save(
        plots.cost_band_figure(figure_bands(tables.bands)),
        directory / "fig9_cost_bands.png",
        directory / "fig9_cost_bands.pdf",
        provenance=record,
    )
    plots.save(
        plots.deploy_success_figure(tables.ablation, tables.robustness),
        directory / "fig_deploy_success.png",
        provenance=record,
    )
    if tables.ladder is not None:
        plots.save(
            plots.ladder_figure(tables.ladder, compared_keys(sweep_keys)),
            directory / "fig_ladder.png",
            provenance=record,
        )


def write_pooled_summary(
    pooled: PooledRuns, directory: Path, reference_variant: str | None = None
) -> PlanningTables:
    """Pooled runs' (:func:`pih.analysis.pooling.pool`) planning tables, their summary files under
    ``directory`` with ``sources.parquet`` (which file each training's rows came from): ``pih
    aggregate``'s work, and a study published in parts'."""
    keys = pooled.sweep_keys
    tables = planning_tables(
        pooled.runs, pooled.summaries, pooled.deployments, keys, reference_variant
    )
    tables = with_time_step(tables, pooled.replays, keys)
    record = provenance_record(
        "aggregate", config={"sweep_keys": keys}, inputs=sorted(set(pooled.sources["file"]))
    )
    write_planning_summary(directory, pooled.runs, tables, keys, record)
    write_table(pooled.sources, Path(directory) / "sources.parquet", record, SOURCE_COLUMNS)
    return tables
