# pih: hydroelastic peg-in-hole study (Yang et al., Machines 2023), reproduced and extended.
#   snakemake -j2                                  full study, config/config.yaml
#   snakemake -j2 --configfile config/smoke.yaml   smoke study (CI)
#   snakemake --report results/report.html         self-contained report


import os

from snakemake.utils import min_version

from pih.workflow.jobs import preloaded_allocator

min_version("9.0")

# Each job process is single-threaded (a plan job with N threads runs N such processes):
# NumPy/BLAS and Drake must not oversubscribe a core (sbatch passes the environment on).
os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")
# Drake allocates and frees its contact model every step; tcmalloc (Debian libtcmalloc-minimal4)
# or jemalloc (libjemalloc2) runs the same rollouts 1.2-1.4x faster than glibc's malloc, with
# bit-identical results (docs/simulation.md). Preloaded into every job when installed; each
# output's provenance names the allocator that ran.
os.environ.setdefault("LD_PRELOAD", preloaded_allocator())

from pih.study.config import load_config_file, stop_on_config_error

# The default study's config, found beside this Snakefile: `snakemake -s REPO/Snakefile -d DIR`
# runs a study in its own working directory DIR (docs/workflow.md); named relative to the working
# directory when it is below it.
DEFAULT_CONFIG = os.path.join(workflow.basedir, "config", "config.yaml")
if not os.path.relpath(DEFAULT_CONFIG).startswith(".."):
    DEFAULT_CONFIG = os.path.relpath(DEFAULT_CONFIG)

# Snakemake's own message for a YAML syntax error names neither the file nor the line. Every
# config error is one line (`config error: KEY: ...`), before any job (common.smk).
with stop_on_config_error():
    load_config_file(DEFAULT_CONFIG)


configfile: DEFAULT_CONFIG


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
