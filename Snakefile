# pih: hydroelastic peg-in-hole study (Yang et al., Machines 2023), reproduced and extended.
#   snakemake -j2                                  full study, config/config.yaml
#   snakemake -j2 --configfile config/smoke.yaml   smoke study (CI)
#   snakemake --report results/report.html         self-contained report


import os

from snakemake.utils import min_version

min_version("9.0")

# Each job process is single-threaded (a plan job with N threads runs N such processes):
# NumPy/BLAS and Drake must not oversubscribe a core (sbatch passes the environment on).
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

from pih.study_config import load_yaml_strictly

# Snakemake's own message for a YAML syntax error names neither the file nor the line.
load_yaml_strictly("config/config.yaml")


configfile: "config/config.yaml"


report: "workflow/report/workflow.rst"


include: "workflow/rules/common.smk"
include: "workflow/rules/validation.smk"
include: "workflow/rules/planning.smk"
include: "workflow/rules/report.smk"


rule all:
    default_target: True
    input:
        rules.validation_compare.output,
        rules.validation_variants.output,
        rules.planning_aggregate.output,
        rules.provenance_index.output,
        rules.summary.output,
