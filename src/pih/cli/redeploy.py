"""``pih redeploy RUN...``: the runs' learned policies deployed again from offset starts."""

from __future__ import annotations

import sys
from pathlib import Path

from pih.cli.common import first_line, missing_parent


def redeploy(runs: list[Path], start_std_m: float, output: Path | None, workers: int) -> int:
    """Deploy each run's policy again from starts offset by N(0, start_std_m²); print the rates."""
    import pandas as pd

    from pih.analysis.statistics import wilson_interval
    from pih.config import ConfigError
    from pih.planning.run_record import ROLLOUT_COLUMNS, Phase, RecordedRun, phase_rows
    from pih.records.outputs import write_table
    from pih.records.provenance import record as provenance_record
    from pih.study.redeployment import redeploy

    if missing_parent("redeploy", "--output", output):
        return 1
    # A run's rollouts.parquet names its run (results/planning/*/rollouts.parquet skips summary/).
    runs = [run.parent if run.name == "rollouts.parquet" else run for run in runs]
    recorded = []
    for run in runs:  # every run is read and checked before any is simulated
        try:
            recorded.append(RecordedRun.read(run / "rollouts.parquet"))
        except Exception as error:  # noqa: BLE001 - an unreadable run: one clear line
            print(f"pih redeploy {run}: cannot redeploy ({first_line(error)})", file=sys.stderr)
            return 1
        try:
            recorded[-1].redeployment_config(start_std_m)
        except ConfigError as error:
            print(f"pih redeploy: --start-std-m: {first_line(error)}", file=sys.stderr)
            return 1
        except ValueError as error:  # e.g. a run older than recorded weights
            print(f"pih redeploy {run}: cannot redeploy ({first_line(error)})", file=sys.stderr)
            return 1
    tables, rates = [], []
    for run, record in zip(runs, recorded, strict=True):
        try:
            table = redeploy(record, start_std_m, workers)
        except ValueError as error:  # the record and its seeds disagree
            print(f"pih redeploy {run}: {first_line(error)}", file=sys.stderr)
            return 1
        before = phase_rows(record.rollouts, Phase.DEPLOY)["success"].mean()
        rate = phase_rows(table, Phase.DEPLOY)["success"].mean()
        rates.append(rate)
        print(
            f"{run.name}: deployed {rate:.0%} from starts offset by N(0, ({start_std_m:g} m)²) "
            f"(recorded {before:.0%} at {record.planner.deploy_start_std_m:g} m)"
        )
        tables.append(table.assign(run=run.name))
    low, high = wilson_interval(sum(rates), len(rates))
    print(
        f"{len(rates)} runs: deployment success {sum(rates) / len(rates):.3g} (95 % Wilson "
        f"interval over runs {low:.2f}-{high:.2f})"
    )
    if output is not None:
        provenance = provenance_record(
            "redeploy",
            config={"planner": {"deploy_start_std_m": start_std_m}},  # as the rule's files
            inputs=[run / "rollouts.parquet" for run in runs],
        )
        columns = {**ROLLOUT_COLUMNS, "run": ("", "the planning run's directory name")}
        write_table(pd.concat(tables, ignore_index=True), output, provenance, columns)
        print(output)
    return 0
