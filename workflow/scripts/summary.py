"""results/summary.md: the paper's headline numbers beside ours."""

import pandas as pd

from pih.records.outputs import read_provenance, write_text
from pih.reporting.summary import summary_markdown
from pih.workflow.jobs import job_provenance, logged

with logged(snakemake.log[0]):
    success = pd.read_parquet(snakemake.input.success)
    text = summary_markdown(
        pd.read_parquet(snakemake.input.comparison),
        pd.read_parquet(snakemake.input.variants),
        success,
        pd.read_parquet(snakemake.input.paired),
        pd.read_parquet(snakemake.input.robustness),
        read_provenance(snakemake.input.success)["code_version"],
        dict(snakemake.params.links),
        dict(snakemake.params.study),
    )
    write_text(snakemake.output.summary, text, job_provenance(snakemake, "summary"))
    print(text)
