rule summary:
    input:
        comparison=rules.validation_compare.output.table,
        variants=rules.validation_variants.output.table,
        success=rules.planning_aggregate.output.success,
        paired=rules.planning_aggregate.output.paired,
        robustness=rules.planning_aggregate.output.robustness,
    output:
        # In the report as results/report/summary.html (rule report_tables): shown inline.
        summary="results/summary.md",
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
        study=STUDY,
        links={
            "planning: success per method and sweep level": "planning/summary/success.md",
            "planning: methods compared pair by pair": "planning/summary/paired.md",
            "planning: deployed from inexact starts": "planning/summary/robustness.md",
            "planning: ablation": "planning/summary/ablation.md",
            "planning: each run, where its first sensing landed": "planning/summary/per_run.md",
            "validation: every offset, model and alignment": "validation/comparison.md",
            "validation: every variant (geometry, margin, solver, contact model)": "validation/variants.md",
            "provenance of every data file": "provenance.md",
        },
        library=library_of("summary.py"),
    script:
        "../scripts/summary.py"


# The report shows HTML results inline and offers any other file as a download: each markdown
# table also as an HTML page headed by its title and caption (workflow/report/report_tables.py).
REPORT_TABLES = {
    "summary": (
        rules.summary.output.summary,
        "the study at a glance, beside the paper",
        "summary.rst",
    ),
    "success": (
        rules.planning_aggregate.output.success_markdown,
        "§3 planning: success per method and sweep level",
        "success.rst",
    ),
    "paired": (
        rules.planning_aggregate.output.paired_markdown,
        "§3 planning: methods compared pair by pair",
        "paired.rst",
    ),
    "robustness": (
        rules.planning_aggregate.output.robustness_markdown,
        "§3 planning: deployed from inexact starts",
        "robustness.rst",
    ),
    "ablation": (
        rules.planning_aggregate.output.ablation_markdown,
        "§3 planning: ablation (per compared dimension)",
        "ablation.rst",
    ),
    "per_run": (
        rules.planning_aggregate.output.per_run_markdown,
        "§3 planning: each run, where its first sensing landed",
        "per_run.rst",
    ),
    "comparison": (
        rules.validation_compare.output.markdown,
        "§2.4 validation: every offset, contact model and alignment",
        "comparison.rst",
    ),
    "variants": (
        rules.validation_variants.output.markdown,
        "§2.4 validation: every variant",
        "variants.rst",
    ),
}


rule report_tables:
    input:
        **{name: source for name, (source, _, _) in REPORT_TABLES.items()},
    output:
        **{
            name: report(
                f"results/report/{name}.html",
                caption=f"../report/{caption}",
                category="Tables",
                labels={"table": title},
            )
            for name, (_, title, caption) in REPORT_TABLES.items()
            if name != "summary"
        },
        summary=report(
            "results/report/summary.html",
            caption="../report/summary.rst",
            category="Summary",
            labels={"table": REPORT_TABLES["summary"][1]},
        ),
    log:
        "logs/report_tables.log",
    localrule: True
    conda:
        "../envs/pih.yaml"
    threads: 1
    resources:
        mem_mb=500,
        runtime=5,
    params:
        pages={
            name: (title, caption)
            for name, (_, title, caption) in REPORT_TABLES.items()
        },
    script:
        "../report/report_tables.py"


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
        rules.report_tables.output,
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
            # An HTML table carries the record of the markdown it shows.
            **{
                str(getattr(rules.report_tables.output, name)): str(source)
                for name, (source, _, _) in REPORT_TABLES.items()
            },
        },
        library=library_of("provenance_index.py"),
    script:
        "../scripts/provenance_index.py"
