"""One planning run (paper Algorithm 1) at one sweep point."""

from pih.config import to_mapping
from pih.planner import PATH_COLUMNS, ROLLOUT_COLUMNS, Planner
from pih.recordings import record_planning
from pih.study import resolve
from pih.traces import write_table
from pih.workflow import job_provenance, logged

with logged(snakemake.log[0]):
    point = dict(snakemake.params.point)
    scene, planner_config = resolve(
        {"scene": snakemake.params.scene, "planner": snakemake.params.planner}, point
    )
    planner = Planner.from_configs(scene, planner_config)
    record = planner.run(
        progress=lambda i, cost, ok: print(
            f"iteration {i}: best J_inn {cost:.4g}{' (success)' if ok else ''}", flush=True
        )
    )
    provenance = job_provenance(
        snakemake,
        "plan",
        point=point,
        seeds=record.seeds,
        config={"scene": to_mapping(scene), "planner": to_mapping(planner_config)},
        simulator=scene.simulator_settings(),
        extra={
            "result": {
                "success_iteration": record.success_iteration,
                "stop_reason": record.stop_reason,
            }
        },
    )
    summary = {
        "success_iteration": record.success_iteration,
        "stop_reason": record.stop_reason,
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
        scene,
        provenance["run_id"],
        provenance,
    )
    print(
        f"success iteration {record.success_iteration}; {record.stop_reason}; {record.seconds:.1f} s"
    )
