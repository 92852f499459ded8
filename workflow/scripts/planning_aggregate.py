"""Over all runs: cost bands (Fig. 9), success, paired, robustness and ablation tables, best-path
figures (Fig. 8)."""

from pathlib import Path

import pandas as pd

from pih import plots
from pih.aggregate import (
    BAND_COLUMNS,
    BEST_COST_COLUMNS,
    PAIRED_COLUMNS,
    SUCCESS_COLUMNS,
    best_training_rows,
    figure_bands,
    level_columns,
    planning_tables,
    redeployment_summaries,
    robustness_columns,
    run_tables,
    run_title,
)
from pih.config import from_mapping
from pih.outputs import markdown_table, read_provenance, write_table, write_text
from pih.scene_config import SceneConfig
from pih.study_config import VARIANT_KEY
from pih.workflow import job_provenance, logged

with logged(snakemake.log[0]):
    keys = list(snakemake.params.sweep)
    runs, summaries = run_tables(snakemake.input.rollouts, keys)
    deployments = pd.concat(
        [summaries, redeployment_summaries(snakemake.input.redeployments, keys)],
        ignore_index=True,
    )
    reference_variant = snakemake.params.sweep.get(VARIANT_KEY, [None])[0]
    tables = planning_tables(runs, summaries, deployments, keys, reference_variant)
    bands, success, ablation = tables.bands, tables.success, tables.ablation
    paired, robustness = tables.paired, tables.robustness
    record = job_provenance(
        snakemake, "planning_aggregate", config={"sweep": snakemake.params.sweep}
    )
    write_table(runs, snakemake.output.runs, record, {**BEST_COST_COLUMNS, **level_columns(keys)})
    write_table(bands, snakemake.output.bands, record, BAND_COLUMNS)
    write_table(success, snakemake.output.success, record, SUCCESS_COLUMNS)
    write_table(paired, snakemake.output.paired, record, PAIRED_COLUMNS)
    write_table(robustness, snakemake.output.robustness, record, robustness_columns(keys))
    robust_pairs = paired[paired["dimension"] == "start_std_m"]
    write_text(
        snakemake.output.robustness_markdown,
        f"{markdown_table(robustness)}\n\n{markdown_table(robust_pairs)}",
        record,
    )
    write_table(ablation, snakemake.output.ablation, record, SUCCESS_COLUMNS)
    write_text(snakemake.output.success_markdown, markdown_table(success), record)
    write_text(snakemake.output.success_csv, success.to_csv(index=False))
    write_text(snakemake.output.paired_markdown, markdown_table(paired), record)
    against_reference = tables.variant_pairs
    write_text(
        snakemake.output.ablation_markdown,
        markdown_table(ablation)
        + (f"\n\n{markdown_table(against_reference)}" if len(against_reference) else ""),
        record,
    )
    plots.save(
        plots.cost_band_figure(figure_bands(bands)),
        snakemake.output.fig_bands,
        snakemake.output.fig_bands_pdf,
        provenance=record,
    )
    plots.save(
        plots.deploy_success_figure(ablation), snakemake.output.fig_ablation, provenance=record
    )
    scene = from_mapping(SceneConfig, snakemake.params.scene, "scene")
    for source, png in zip(snakemake.input.best_paths, snakemake.output.fig_paths):
        rollouts_file = Path(source).with_name("rollouts.parquet")
        run = read_provenance(rollouts_file)
        rollouts = pd.read_parquet(rollouts_file)
        goals = best_training_rows(rollouts)
        title = run_title(run["sweep_point"], run["config"]["planner"])
        figure = plots.best_paths_figure(pd.read_parquet(source), scene.hole, title, goals)
        plots.save(figure, png, provenance=record)
    print(success.to_string())
    print(paired.to_string())
    print(robustness.to_string())
