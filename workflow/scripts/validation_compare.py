"""Tables 2-3 and Figs 4, 5, A1, A2: simulations vs Whitney's theory (paper §2.4)."""

import pandas as pd

from pih import plots, provenance
from pih.config import from_mapping
from pih.scene import SceneConfig
from pih.study import markdown_table
from pih.traces import read_trace, write_table, write_text
from pih.validation import (
    compare,
    phase_markers,
    pooled_correlation,
    summary_rows,
    theory_frame,
    validation_scene_config,
    whitney_params,
)
from pih.workflow import ValidationSection, job_provenance, logged

with logged(snakemake.log[0]):
    section = from_mapping(ValidationSection, snakemake.params.validation, "validation")
    base = from_mapping(SceneConfig, snakemake.params.scene, "scene")
    rows, aligned, theory, markers = [], {}, {}, {}
    traces = iter(snakemake.input.traces)
    for model in section.contact_models:
        scene = validation_scene_config(
            base.replace(solver__contact_model=model), section.experiment
        )
        metrics, curves = [], []
        for offset in section.offsets_m:
            result = compare(read_trace(next(traces)), scene, offset, section.experiment)
            metrics.append(result.metrics)
            curves.append(result.aligned)
            aligned[(model, offset)] = result.aligned
            params = whitney_params(scene, offset)
            theory[offset] = theory_frame(params, section.experiment.final_depth_m)
            markers[offset] = phase_markers(params)
        rows += summary_rows(metrics, pooled_correlation(curves), model)
    table = pd.DataFrame(rows)
    columns = {
        c: (
            "%"
            if c.endswith("_pct")
            else "m"
            if c.endswith("_m")
            else "N"
            if c.endswith("_n")
            else "rad"
            if "theta" in c
            else "",
            c.replace("_", " "),
        )
        for c in table.columns
    }
    record = job_provenance(
        snakemake,
        "validation_compare",
        config={"scene": snakemake.params.scene, "validation": snakemake.params.validation},
    )
    write_table(table, snakemake.output.table, record, columns)
    shown = [
        "contact_model",
        "offset",
        "alignment_shift_m",
        "reached_depth_m",
        "r_f_x",
        "r_f_z",
        "rel_err_initial_f_x_pct",
        "rel_err_final_f_x_pct",
        "rel_err_initial_f_z_pct",
        "rel_err_final_f_z_pct",
        "rel_err_final_theta_pct",
    ]
    header = f"<!-- {provenance.canonical_json({'run_id': record['run_id'], 'config_sha256': record['config_sha256'], 'library_sha256': record['library_sha256']})} -->\n"
    write_text(snakemake.output.markdown, header + markdown_table(table[shown]))
    write_text(snakemake.output.csv, table.to_csv(index=False))
    pdfs = iter(snakemake.output.pdfs)
    for quantity, png in (
        ("f_x_n", snakemake.output.fig_fx),
        ("f_z_n", snakemake.output.fig_fz),
        ("theta_rad", snakemake.output.fig_theta),
    ):
        plots.save(plots.validation_curves(aligned, theory, markers, quantity), png, next(pdfs))
    plots.save(plots.force_scatter(aligned), snakemake.output.fig_scatter, next(pdfs))
    print(table[shown].to_string())
