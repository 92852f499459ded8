"""One planning run (paper Algorithm 1) at one sweep point, then its deployment trials."""

from pih.config import from_mapping, to_mapping
from pih.planning.config import PlannerConfig
from pih.planning.planner import Planner
from pih.planning.run_record import PATH_COLUMNS, ROLLOUT_COLUMNS
from pih.records.outputs import write_table
from pih.records.recordings import record_planning
from pih.records.sampling import path_samples
from pih.scene.config import SceneConfig
from pih.study.points import seed_key, variant_overrides
from pih.workflow.jobs import job_provenance, logged

with logged(snakemake.log[0]):
    point = dict(snakemake.params.point)  # already applied to the params' scene and planner
    scene = from_mapping(SceneConfig, snakemake.params.scene, "scene")
    planner_config = from_mapping(PlannerConfig, snakemake.params.planner, "planner")
    key = seed_key(point)
    planner = Planner.from_configs(scene, planner_config, key)
    # threads > 1 (--set-threads plan=N): an iteration's rollouts run in N processes.
    record = planner.run(
        progress=lambda report: print(report, flush=True), workers=snakemake.threads
    )
    summary = {
        "success_iteration": record.success_iteration,
        "deploy_success_rate": record.deploy_success_rate,
        "deployed_iteration": record.deployed_iteration,
        "final_mean_deploy_success_rate": record.final_mean_deploy_success_rate,
        "stop_reason": record.stop_reason,
        "cost_divisors": record.cost_divisors,
    }
    provenance = job_provenance(
        snakemake,
        "plan",
        point=point,
        seeds={**record.seeds, "planner.seed": planner_config.seed},
        config={"scene": to_mapping(scene), "planner": to_mapping(planner_config)},
        simulator=scene.simulator_settings(),
        extra={
            "training_scene": to_mapping(planner.training_scene_config),
            "seed_key": key,
            "variant_overrides": variant_overrides(snakemake.config, point),
            "result": summary,
        },
    )
    timing = {"seconds": record.seconds, "rollout_seconds": record.rollout_seconds}
    write_table(
        record.rollouts,
        snakemake.output.rollouts,
        provenance,
        ROLLOUT_COLUMNS,
        extra_metadata={"run": summary, "timing": timing},
    )
    # The best paths keep the steps the costs sum over (costs.sample_period_s) and each path's last.
    best_paths = record.best_paths[
        path_samples(record.best_paths["iteration"].to_numpy(), planner.cost_samples.step)
    ].reset_index(drop=True)
    write_table(best_paths, snakemake.output.best_paths, provenance, PATH_COLUMNS)
    record_planning(
        snakemake.output.recording,
        record.rollouts,
        best_paths,
        scene,
        provenance["run_id"],
        {**provenance, "recordings": {"frame_rate_hz": snakemake.params.frame_rate_hz}},
        frame_rate_hz=snakemake.params.frame_rate_hz,
    )
    print(
        f"deployment success {record.deploy_success_rate:.0%} ({planner_config.deploy_policy}; "
        f"the final mean {record.final_mean_deploy_success_rate:.0%}); first successful iteration "
        f"{record.success_iteration}; {record.stop_reason}; {record.seconds:.1f} s"
    )
