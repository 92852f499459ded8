"""The planning summary files, one writer for the workflow's ``planning_aggregate`` job and for
``pih aggregate``: cost bands (Fig. 9), success, paired, robustness and ablation tables as
Parquet with column units and as Markdown, and their figures (docs/planner.md)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pandas as pd

from pih import plots
from pih.aggregate import (
    BAND_COLUMNS,
    BEST_COST_COLUMNS,
    PAIRED_COLUMNS,
    SUCCESS_COLUMNS,
    PlanningTables,
    figure_bands,
    level_columns,
    robustness_columns,
)
from pih.outputs import markdown_table, write_table, write_text


def write_planning_summary(
    directory: Path,
    runs: pd.DataFrame,
    tables: PlanningTables,
    sweep_keys: list[str],
    record: dict[str, Any],
) -> None:
    """Every summary file of a study's planning runs under ``directory`` (``runs``,
    ``cost_bands``, ``success``, ``paired``, ``robustness``, ``ablation``: ``.parquet`` and
    ``.md``; ``success.csv``; ``fig9_cost_bands.{png,pdf}``, ``fig_deploy_success.png``), each
    with the provenance ``record``."""
    directory = Path(directory)
    frames = {
        "runs": (runs, {**BEST_COST_COLUMNS, **level_columns(sweep_keys)}),
        "cost_bands": (tables.bands, BAND_COLUMNS),
        "success": (tables.success, SUCCESS_COLUMNS),
        "paired": (tables.paired, PAIRED_COLUMNS),
        "robustness": (tables.robustness, robustness_columns(sweep_keys)),
        "ablation": (tables.ablation, SUCCESS_COLUMNS),
    }
    for name, (frame, columns) in frames.items():
        write_table(frame, directory / f"{name}.parquet", record, columns)
    paired = tables.paired
    robustness_pairs = paired[paired["dimension"].isin(["start_std_m", "model_error"])]
    against_reference = tables.variant_pairs
    markdown = {
        "success": markdown_table(tables.success),
        "paired": markdown_table(paired),
        "robustness": f"{markdown_table(tables.robustness)}\n\n{markdown_table(robustness_pairs)}",
        "ablation": markdown_table(tables.ablation)
        + (f"\n\n{markdown_table(against_reference)}" if len(against_reference) else ""),
    }
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
        plots.deploy_success_figure(tables.ablation),
        directory / "fig_deploy_success.png",
        provenance=record,
    )
