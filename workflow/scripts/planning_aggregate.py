"""Cost bands (Fig. 9), success table, best-path figures (Fig. 8) over all planning runs."""

from pathlib import Path

import pandas as pd

from pih import plots
from pih.config import from_mapping
from pih.scene import SceneConfig
from pih.study import cost_bands, final_success_fraction, markdown_table, success_table
from pih.traces import read_metadata, read_provenance, write_table, write_text
from pih.workflow import job_provenance, logged

with logged(snakemake.log[0]):
    sweep_keys = list(snakemake.params.sweep)
    group = "planner.method" if "planner.method" in sweep_keys else sweep_keys[0]
    bests, summaries = [], []
    for path in snakemake.input.rollouts:
        point = read_provenance(path)["sweep_point"]
        rollouts = pd.read_parquet(path)
        run = read_metadata(path, "run")
        best = rollouts[rollouts["is_best"]][["iteration", "cost"]].assign(
            **{k: point[k] for k in sweep_keys}, run=path
        )
        bests.append(best)
        summaries.append(
            {
                **{k: point[k] for k in sweep_keys},
                "succeeded": run["success_iteration"] is not None,
                "success_iteration": run["success_iteration"],
                "seconds": run["seconds"],
                "final_success_fraction": final_success_fraction(rollouts),
                "diverged_fraction": float((rollouts["status"] != "ok").mean()),
            }
        )
    runs = pd.concat(bests, ignore_index=True)
    summary = pd.DataFrame(summaries)
    # Each non-grouping sweep dimension gets its own bands too: a new dimension needs no code.
    bands = pd.concat(
        [
            cost_bands(runs, key).rename(columns={key: "level"}).assign(dimension=key)
            for key in sweep_keys
        ],
        ignore_index=True,
    )
    success = pd.concat(
        [
            success_table(summary, key).rename(columns={key: "level"}).assign(dimension=key)
            for key in sweep_keys
        ],
        ignore_index=True,
    )
    record = job_provenance(
        snakemake, "planning_aggregate", config={"sweep": snakemake.params.sweep}
    )
    units = lambda frame: {
        c: ("s" if "seconds" in c else "m" if c.endswith("_m") else "1", c.replace("_", " "))
        for c in frame.columns
    }
    run_table = runs.assign(run=runs["run"].map(lambda p: str(Path(p).parent)))
    write_table(
        run_table.astype({k: str for k in sweep_keys}),
        snakemake.output.runs,
        record,
        units(run_table),
    )
    write_table(bands.astype({"level": str}), snakemake.output.bands, record, units(bands))
    write_table(success.astype({"level": str}), snakemake.output.success, record, units(success))
    write_text(snakemake.output.success_markdown, markdown_table(success))
    write_text(snakemake.output.success_csv, success.to_csv(index=False))
    grouped = bands[bands["dimension"] == group].rename(columns={"level": group})
    plots.save(
        plots.cost_band_figure(grouped, group),
        snakemake.output.fig_bands,
        snakemake.output.fig_bands_pdf,
    )
    scene = from_mapping(SceneConfig, snakemake.params.scene, "scene")
    for source, png in zip(snakemake.input.best_paths, snakemake.output.fig_paths):
        plots.save(
            plots.best_paths_figure(
                pd.read_parquet(source),
                scene.hole,
                str(Path(source).parent.relative_to("results/planning")),
            ),
            png,
        )
    print(success.to_string())
