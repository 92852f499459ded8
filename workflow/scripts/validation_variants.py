"""results/validation/variants.*: every validation variant against Whitney, and the rule's choice."""

from pih.config import from_mapping
from pih.records.outputs import read_validation_traces, write_table, write_text
from pih.study.config import ValidationSection
from pih.validation.experiment import (
    VARIANT_COLUMNS,
    choose_variants,
    comparison_table,
    variants_markdown,
)
from pih.workflow.jobs import job_provenance, logged

with logged(snakemake.log[0]):
    section = from_mapping(ValidationSection, snakemake.params.validation, "validation")
    traces = read_validation_traces(snakemake.input.traces)
    scenes = {v: section.scene(snakemake.params.scene, v) for v, _ in traces}
    table = choose_variants(comparison_table(traces, scenes, section.experiment)[0])
    record = job_provenance(
        snakemake,
        "validation_variants",
        config={"scene": snakemake.params.scene, "validation": snakemake.params.validation},
    )
    write_table(table, snakemake.output.table, record, VARIANT_COLUMNS)
    text = variants_markdown(table, section.variants)
    write_text(snakemake.output.markdown, text, record)
    print(text)
