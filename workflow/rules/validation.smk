rule whitney_curve:
    output:
        curve="results/whitney/offset_m~{offset}.parquet",
    log:
        "logs/whitney/offset_m~{offset}.log",
    conda:
        "../envs/pih.yaml"
    threads: 1
    resources:
        mem_mb=500,
        runtime=5,
    params:
        scene=config["scene"],
        library=library_of("whitney_curve.py"),
    script:
        "../scripts/whitney_curve.py"


rule validation_run:
    output:
        trace="results/validation/{variant}/offset_m~{offset}.parquet",
        recording="results/validation/{variant}/offset_m~{offset}.rrd",
    log:
        "logs/validation/{variant}/offset_m~{offset}.log",
    benchmark:
        "benchmarks/validation/{variant}/offset_m~{offset}.tsv"
    conda:
        "../envs/pih.yaml"
    threads: 1
    resources:
        mem_mb=2000,
        runtime=15,
    params:
        scene=lambda wildcards: VALIDATION_SCENES[wildcards.variant],
        experiment=config["validation"]["experiment"],
        recordings=RECORDINGS,
        library=library_of("validation_run.py"),
    script:
        "../scripts/validation_run.py"


rule validation_compare:
    input:
        traces=expand(
            "results/validation/{variant}/offset_m~{offset}.parquet",
            variant=FIGURE_VARIANTS,
            offset=VALIDATION_OFFSETS,
        ),
        curves=expand(
            "results/whitney/offset_m~{offset}.parquet", offset=VALIDATION_OFFSETS
        ),
    output:
        table="results/validation/comparison.parquet",
        aligned="results/validation/aligned_curves.parquet",
        markdown="results/validation/comparison.md",
        csv=report(
            "results/validation/comparison.csv",
            caption="../report/comparison.rst",
            category="§2.4 Validation: hydroelastic vs Whitney",
        ),
        fig_fx=report(
            "results/validation/fig4_fx_vs_depth.png",
            caption="../report/fig4.rst",
            category="§2.4 Validation: hydroelastic vs Whitney",
        ),
        fig_fz=report(
            "results/validation/figA1_fz_vs_depth.png",
            caption="../report/figA1.rst",
            category="§2.4 Validation: hydroelastic vs Whitney",
        ),
        fig_theta=report(
            "results/validation/figA2_angle_vs_depth.png",
            caption="../report/figA2.rst",
            category="§2.4 Validation: hydroelastic vs Whitney",
        ),
        fig_scatter=report(
            "results/validation/fig5_sim_vs_theory.png",
            caption="../report/fig5.rst",
            category="§2.4 Validation: hydroelastic vs Whitney",
        ),
        pdfs=expand(
            "results/validation/{name}.pdf",
            name=[
                "fig4_fx_vs_depth",
                "figA1_fz_vs_depth",
                "figA2_angle_vs_depth",
                "fig5_sim_vs_theory",
            ],
        ),
    log:
        "logs/validation/compare.log",
    localrule: True
    conda:
        "../envs/pih.yaml"
    threads: 1
    resources:
        mem_mb=2000,
        runtime=10,
    params:
        scene=config["scene"],
        validation=config["validation"],
        library=library_of("validation_compare.py"),
    script:
        "../scripts/validation_compare.py"


rule validation_variants:
    input:
        traces=expand(
            "results/validation/{variant}/offset_m~{offset}.parquet",
            variant=VALIDATION_VARIANTS,
            offset=VALIDATION_OFFSETS,
        ),
    output:
        table="results/validation/variants.parquet",
        markdown=report(
            "results/validation/variants.md",
            caption="../report/variants.rst",
            category="§2.4 Validation: hydroelastic vs Whitney",
        ),
    log:
        "logs/validation/variants.log",
    localrule: True
    conda:
        "../envs/pih.yaml"
    threads: 1
    resources:
        mem_mb=2000,
        runtime=10,
    params:
        scene=config["scene"],
        validation=config["validation"],
        library=library_of("validation_variants.py"),
    script:
        "../scripts/validation_variants.py"
