rule provenance_index:
    input:
        rules.validation_compare.output.table,
        rules.validation_compare.output.aligned,
        rules.planning_aggregate.output.runs,
        rules.planning_aggregate.output.bands,
        rules.planning_aggregate.output.success,
        rules.planning_aggregate.output.ablation,
        expand("results/whitney/offset_m~{offset}.parquet", offset=VALIDATION_OFFSETS),
        expand(
            "results/validation/{model}/offset_m~{offset}.parquet",
            model=CONTACT_MODELS,
            offset=VALIDATION_OFFSETS,
        ),
        expand(
            "results/planning/{point}/{table}.parquet",
            point=PLANNING.instance_patterns,
            table=["rollouts", "best_paths"],
        ),
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
        library=LIBRARY_HASH,
    script:
        "../scripts/provenance_index.py"


rule summary:
    input:
        comparison=rules.validation_compare.output.table,
        success=rules.planning_aggregate.output.success,
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
            "planning: ablation": "planning/summary/ablation.md",
            "validation: every offset, model and alignment": "validation/comparison.md",
            "provenance of every data file": "provenance.md",
        },
        library=LIBRARY_HASH,
    script:
        "../scripts/summary.py"
