"""One planning run's learned policy deployed again: from starts offset by N(0, σ²) in x and y,
and, for a model error, on a real scene with other settings."""

from pih.planning.run_record import ROLLOUT_COLUMNS, Phase, RecordedRun, phase_rows
from pih.records.outputs import write_table
from pih.study.redeployment import redeploy
from pih.study.redeployment_record import redeployment_fields
from pih.workflow.jobs import job_provenance, logged

with logged(snakemake.log[0]):
    run = RecordedRun.read(snakemake.input.rollouts)
    start_std_m = snakemake.params.start_std_m
    model_error = snakemake.params.model_error
    settings = model_error.get("settings", {})
    table = redeploy(run, start_std_m, model_error=settings)
    provenance = job_provenance(
        snakemake, "redeploy", **redeployment_fields(run, start_std_m, model_error)
    )
    write_table(table, snakemake.output.rollouts, provenance, ROLLOUT_COLUMNS)
    deployed = phase_rows(table, Phase.DEPLOY)["success"].mean()
    error = f" on {model_error['name']} ({settings})" if settings else ""
    print(
        f"deployment success {deployed:.0%} from starts offset by N(0, ({start_std_m:g} m)²){error}"
    )
