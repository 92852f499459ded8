"""Over all runs: cost bands (Fig. 9), success, paired, robustness and ablation tables, best-path
figures (Fig. 8)."""

import dataclasses
from pathlib import Path

import pandas as pd

from pih.analysis.aggregate import planning_tables
from pih.analysis.run_summary import (
    best_training_rows,
    redeployment_summaries,
    run_tables,
    run_title,
)
from pih.config import from_mapping
from pih.records.outputs import read_provenance
from pih.reporting import plots
from pih.reporting.planning_summary import write_planning_summary
from pih.scene.config import SceneConfig
from pih.study.points import VARIANT_KEY
from pih.workflow.jobs import job_provenance, logged

with logged(snakemake.log[0]):
    keys = list(snakemake.params.sweep)
    runs, summaries = run_tables(snakemake.input.rollouts, keys)
    deployments = pd.concat(
        [summaries, redeployment_summaries(snakemake.input.redeployments, keys)],
        ignore_index=True,
    )
    reference_variant = snakemake.params.sweep.get(VARIANT_KEY, [None])[0]
    # The ladder's tables are not among the rule's declared outputs: `pih aggregate` and the
    # published studies make them (docs/planner.md, "The deployment ladder").
    tables = dataclasses.replace(
        planning_tables(runs, summaries, deployments, keys, reference_variant),
        ladder=None,
        ladder_pairs=None,
    )
    record = job_provenance(
        snakemake, "planning_aggregate", config={"sweep": snakemake.params.sweep}
    )
    write_planning_summary(Path(snakemake.output.runs).parent, runs, tables, keys, record)
    scene = from_mapping(SceneConfig, snakemake.params.scene, "scene")
    for source, png in zip(snakemake.input.best_paths, snakemake.output.fig_paths):
        rollouts_file = Path(source).with_name("rollouts.parquet")
        run = read_provenance(rollouts_file)
        rollouts = pd.read_parquet(rollouts_file)
        goals = best_training_rows(rollouts)
        title = run_title(run["sweep_point"], run["config"]["planner"])
        figure = plots.best_paths_figure(pd.read_parquet(source), scene.hole, title, goals)
        plots.save(figure, png, provenance=record)
    print(tables.success.to_string())
    print(tables.paired.to_string())
    print(tables.robustness.to_string())
