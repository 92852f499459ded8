"""One planning run (paper Algorithm 1) at one sweep point."""

from pih.planner import PATH_COLUMNS, ROLLOUT_COLUMNS, Planner
from pih.recordings import record_planning
from pih.study import resolve
from pih.traces import write_table
from pih.workflow import job_provenance, logged

with logged(snakemake.log[0]):
    point = dict(snakemake.params.point)
    scene_config, planner_config = resolve(
        {"scene": snakemake.params.scene, "planner": snakemake.params.planner}, point
    )
    planner = Planner.from_configs(scene_config, planner_config)
    record = planner.run(
        progress=lambda i, cost, ok: print(
            f"iteration {i}: best J_inn {cost:.4g}{' (success)' if ok else ''}", flush=True
        )
    )
    provenance = job_provenance(
        snakemake,
        "plan",
        point=point,
        seeds={"noise": planner_config.seed, "optimizer": planner_config.optimizer.seed},
        config={"scene": snakemake.params.scene, "planner": snakemake.params.planner},
        simulator=scene_config.simulator_settings(),
        extra={"result": {"success_iteration": record.success_iteration}},
    )
    summary = {
        "success_iteration": record.success_iteration,
        "seconds": record.seconds,
        "rollout_seconds": record.rollout_seconds,
    }
    write_table(
        record.rollouts,
        snakemake.output.rollouts,
        provenance,
        ROLLOUT_COLUMNS,
        extra_metadata={"run": summary},
    )
    write_table(record.best_paths, snakemake.output.best_paths, provenance, PATH_COLUMNS)
    record_planning(
        snakemake.output.recording,
        record.rollouts,
        record.best_paths,
        scene_config,
        provenance["run_id"],
        provenance,
    )
    print(f"success iteration {record.success_iteration}; {record.seconds:.1f} s")
