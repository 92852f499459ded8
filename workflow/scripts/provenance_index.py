"""A table of the provenance records of all outputs, for the report."""

from pih.records.outputs import markdown_table, provenance_index, write_text
from pih.workflow.jobs import job_provenance, logged

with logged(snakemake.log[0]):
    table = provenance_index(list(snakemake.input), snakemake.params.companions)
    write_text(
        snakemake.output.index,
        "# Provenance of the outputs\n\n" + markdown_table(table),
        job_provenance(snakemake, "provenance_index"),
    )
    print(f"{len(table)} files indexed")
