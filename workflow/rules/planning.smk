rule plan:
    output:
        rollouts=f"results/planning/{PLANNING.wildcard_pattern}/rollouts.parquet",
        best_paths=f"results/planning/{PLANNING.wildcard_pattern}/best_paths.parquet",
        recording=f"results/planning/{PLANNING.wildcard_pattern}/run.rrd",
    log:
        f"logs/planning/{PLANNING.wildcard_pattern}.log",
    benchmark:
        f"benchmarks/planning/{PLANNING.wildcard_pattern}.tsv"
    conda:
        "../envs/pih.yaml"
    threads: 1
    resources:
        mem_mb=2000,
        runtime=30,
    params:
        scene=resolved_section("scene"),
        planner=resolved_section("planner"),
        point=sweep_point,
        frame_rate_hz=RECORDINGS["frame_rate_hz"],
        library=library_of("plan.py"),
    script:
        "../scripts/plan.py"


rule redeploy:
    input:
        rollouts=f"results/planning/{PLANNING.wildcard_pattern}/rollouts.parquet",
    output:
        rollouts=f"results/planning/{PLANNING.wildcard_pattern}/redeploy_start_std_m~{{std}}.parquet",
    log:
        f"logs/planning/{PLANNING.wildcard_pattern}_redeploy_start_std_m~{{std}}.log",
    # A finished run's redeployments go before the next plan: a study stopped at any time
    # holds whole runs, publishable in parts.
    priority: 1
    conda:
        "../envs/pih.yaml"
    threads: 1
    resources:
        mem_mb=2000,
        runtime=10,
    params:
        start_std_m=lambda wildcards: float(wildcards.std),
        model_error={},
        library=library_of("redeploy.py"),
    script:
        "../scripts/redeploy.py"


rule redeploy_model_error:
    input:
        rollouts=f"results/planning/{PLANNING.wildcard_pattern}/rollouts.parquet",
    output:
        rollouts=f"results/planning/{PLANNING.wildcard_pattern}/redeploy_model_error~{{error}}.parquet",
    log:
        f"logs/planning/{PLANNING.wildcard_pattern}_redeploy_model_error~{{error}}.log",
    # A finished run's redeployments go before the next plan: a study stopped at any time
    # holds whole runs, publishable in parts.
    priority: 1
    conda:
        "../envs/pih.yaml"
    threads: 1
    resources:
        mem_mb=2000,
        runtime=10,
    params:
        start_std_m=MODEL_ERROR_STD,
        model_error=lambda wildcards: {
            "name": wildcards.error,
            "settings": config["robustness"]["model_error"][wildcards.error],
        },
        library=library_of("redeploy.py"),
    script:
        "../scripts/redeploy.py"


rule planning_aggregate:
    input:
        rollouts=expand(
            "results/planning/{point}/rollouts.parquet",
            point=PLANNING.instance_patterns,
        ),
        best_paths=expand(
            "results/planning/{point}/best_paths.parquet", point=FIGURE_POINTS
        ),
        redeployments=REDEPLOYMENTS,
    output:
        runs="results/planning/summary/runs.parquet",
        bands="results/planning/summary/cost_bands.parquet",
        success="results/planning/summary/success.parquet",
        success_markdown="results/planning/summary/success.md",
        success_csv=report(
            "results/planning/summary/success.csv",
            caption="../report/success.rst",
            category="§3 Planning: one-level vs bilevel",
        ),
        paired="results/planning/summary/paired.parquet",
        paired_markdown=report(
            "results/planning/summary/paired.md",
            caption="../report/paired.rst",
            category="§3 Planning: one-level vs bilevel",
        ),
        robustness="results/planning/summary/robustness.parquet",
        robustness_markdown=report(
            "results/planning/summary/robustness.md",
            caption="../report/robustness.rst",
            category="§3 Planning: one-level vs bilevel",
        ),
        per_run="results/planning/summary/per_run.parquet",
        per_run_markdown=report(
            "results/planning/summary/per_run.md",
            caption="../report/per_run.rst",
            category="§3 Planning: one-level vs bilevel",
        ),
        ablation="results/planning/summary/ablation.parquet",
        ablation_markdown=report(
            "results/planning/summary/ablation.md",
            caption="../report/ablation.rst",
            category="§3 Planning: one-level vs bilevel",
        ),
        fig_ablation=report(
            "results/planning/summary/fig_deploy_success.png",
            caption="../report/fig_deploy_success.rst",
            category="§3 Planning: one-level vs bilevel",
        ),
        fig_bands=report(
            "results/planning/summary/fig9_cost_bands.png",
            caption="../report/fig9.rst",
            category="§3 Planning: one-level vs bilevel",
        ),
        fig_bands_pdf="results/planning/summary/fig9_cost_bands.pdf",
        fig_paths=report(
            expand(
                "results/planning/summary/fig8_best_paths/{point}.png",
                point=FIGURE_POINTS,
            ),
            caption="../report/fig8.rst",
            category="§3 Planning: one-level vs bilevel",
        ),
    log:
        "logs/planning/aggregate.log",
    localrule: True
    conda:
        "../envs/pih.yaml"
    threads: 1
    resources:
        mem_mb=2000,
        runtime=10,
    params:
        sweep=config["sweep"],
        scene=config["scene"],
        figure_points=FIGURE_POINTS,
        library=library_of("planning_aggregate.py"),
    script:
        "../scripts/planning_aggregate.py"
