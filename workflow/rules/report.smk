rule summary:
    input:
        comparison=rules.validation_compare.output.table,
        variants=rules.validation_variants.output.table,
        success=rules.planning_aggregate.output.success,
        paired=rules.planning_aggregate.output.paired,
        robustness=rules.planning_aggregate.output.robustness,
    output:
        summary=report(
            "results/summary.md",
            caption="../report/summary.rst",
            category="Summary",
        ),
    log:
        "logs/summary.log",
    localrule: True
    conda:
        "../envs/pih.yaml"
    threads: 1
    resources:
        mem_mb=500,
        runtime=5,
    params:
        links={
            "planning: success per method and sweep level": "planning/summary/success.md",
            "planning: methods compared pair by pair": "planning/summary/paired.md",
            "planning: deployed from inexact starts": "planning/summary/robustness.md",
            "planning: ablation": "planning/summary/ablation.md",
            "validation: every offset, model and alignment": "validation/comparison.md",
            "validation: every variant (geometry, margin, solver, contact model)": "validation/variants.md",
            "provenance of every data file": "provenance.md",
        },
        library=library_of("summary.py"),
    script:
        "../scripts/summary.py"


rule provenance_index:
    input:
        rules.validation_compare.output,
        rules.validation_variants.output,
        rules.planning_aggregate.output,
        rules.summary.output,
        expand("results/whitney/offset_m~{offset}.parquet", offset=VALIDATION_OFFSETS),
        expand(
            "results/validation/{variant}/offset_m~{offset}.{ext}",
            variant=VALIDATION_VARIANTS,
            offset=VALIDATION_OFFSETS,
            ext=["parquet", "rrd"],
        ),
        expand(
            "results/planning/{point}/{file}",
            point=PLANNING.instance_patterns,
            file=["rollouts.parquet", "best_paths.parquet", "run.rrd"],
        ),
        REDEPLOYMENTS,
    output:
        index=report(
            "results/provenance.md",
            caption="../report/provenance.rst",
            category="Provenance",
        ),
    log:
        "logs/provenance_index.log",
    localrule: True
    conda:
        "../envs/pih.yaml"
    threads: 1
    resources:
        mem_mb=500,
        runtime=5,
    params:
        companions={
            **record_companions(
                rules.validation_compare.output, rules.validation_compare.output.table
            ),
            **record_companions(
                rules.planning_aggregate.output, rules.planning_aggregate.output.runs
            ),
        },
        library=library_of("provenance_index.py"),
    script:
        "../scripts/provenance_index.py"
