"""Tables 2-3 and Figs 4, 5, A1, A2: simulations vs Whitney's theory (paper §2.4)."""

import pandas as pd

from pih.config import from_mapping
from pih.records.outputs import (
    markdown_table,
    read_provenance,
    read_validation_traces,
    write_table,
    write_text,
)
from pih.reporting import plots
from pih.scene.config import SceneConfig
from pih.study.config import ValidationSection
from pih.validation.experiment import (
    ALIGNED_COLUMNS,
    COMPARISON_COLUMNS,
    aligned_curves,
    comparison_table,
    phase_markers,
    whitney_params,
)
from pih.workflow.jobs import job_provenance, logged

with logged(snakemake.log[0]):
    section = from_mapping(ValidationSection, snakemake.params.validation, "validation")
    scene = from_mapping(SceneConfig, snakemake.params.scene, "scene")
    traces = read_validation_traces(snakemake.input.traces)
    scenes = {v: section.scene(snakemake.params.scene, v) for v, _ in traces}
    table, comparisons = comparison_table(traces, scenes, section.experiment)
    theory = {
        read_provenance(path)["sweep_point"]["offset_m"]: pd.read_parquet(path)
        for path in snakemake.input.curves
    }
    markers = {offset: phase_markers(whitney_params(scene, offset)) for offset in theory}
    record = job_provenance(
        snakemake,
        "validation_compare",
        config={"scene": snakemake.params.scene, "validation": snakemake.params.validation},
    )
    write_table(table, snakemake.output.table, record, COMPARISON_COLUMNS)
    write_table(aligned_curves(comparisons), snakemake.output.aligned, record, ALIGNED_COLUMNS)
    write_text(snakemake.output.markdown, markdown_table(table.drop(columns=["note"])), record)
    write_text(snakemake.output.csv, table.to_csv(index=False))
    simulated = {key: c.simulated for key, c in comparisons.items()}
    pdfs = iter(snakemake.output.pdfs)
    for quantity, png in (
        ("f_x_n", snakemake.output.fig_fx),
        ("f_z_n", snakemake.output.fig_fz),
        ("theta_rad", snakemake.output.fig_theta),
    ):
        figure = plots.validation_curves(simulated, theory, markers, quantity)
        plots.save(figure, png, next(pdfs), provenance=record)
    plots.save(
        plots.force_scatter({k: c.aligned for k, c in comparisons.items()}),
        snakemake.output.fig_scatter,
        next(pdfs),
        provenance=record,
    )
    print(table.to_string())
