"""One planning run's learned policy deployed again from starts offset by N(0, σ²) in x and y."""

from pih.config import to_mapping
from pih.outputs import write_table
from pih.run_record import ROLLOUT_COLUMNS, RecordedRun
from pih.workflow import job_provenance, logged

with logged(snakemake.log[0]):
    run = RecordedRun.read(snakemake.input.rollouts)
    start_std_m = snakemake.params.start_std_m
    table = run.redeploy(start_std_m)
    provenance = job_provenance(
        snakemake,
        "redeploy",
        point=run.record["sweep_point"],
        seeds=run.record["seeds"],
        config={
            "scene": to_mapping(run.scene),
            "planner": to_mapping(run.redeployment_config(start_std_m)),
        },
        simulator=run.record["simulator"],
        extra={"seed_key": run.record["seed_key"]},
    )
    write_table(table, snakemake.output.rollouts, provenance, ROLLOUT_COLUMNS)
    deployed = table[table["phase"] == "deploy"]["success"].mean()
    print(f"deployment success {deployed:.0%} from starts offset by N(0, ({start_std_m:g} m)²)")
