"""``pih aggregate PATH...``: several studies' runs pooled into the planning tables."""

from __future__ import annotations

import sys
from pathlib import Path

from pih.cli.common import first_line


def aggregate(paths: list[Path], output_dir: Path, reference_variant: str | None) -> int:
    """Pool the runs and redeployments under ``paths`` into the planning tables in ``output_dir``."""
    import pandas as pd

    from pih.analysis.pooling import find_outputs, pool
    from pih.config import ConfigError
    from pih.publishing.equivalence import current_hashes
    from pih.reporting.planning_summary import write_pooled_summary

    if output_dir.exists() and not output_dir.is_dir():
        print(f"pih aggregate: --output-dir {output_dir}: not a directory", file=sys.stderr)
        return 1
    try:
        pooled = pool(*find_outputs(paths), current_codes=current_hashes())
    except ConfigError as error:
        print(f"pih aggregate: {first_line(error)}", file=sys.stderr)
        return 1
    keys = pooled.sweep_keys
    if reference_variant is not None:
        known = (
            sorted(map(str, pooled.summaries["variant"].dropna().unique()))
            if "variant" in keys and "variant" in pooled.summaries
            else []
        )
        if reference_variant not in known:
            print(
                f"pih aggregate: --reference-variant {reference_variant!r} is not a variant of "
                f"these runs ({known or 'they sweep no variant'})",
                file=sys.stderr,
            )
            return 1
    tables = write_pooled_summary(pooled, output_dir, reference_variant)
    success = tables.success
    overall = success[success["dimension"] == "all"]
    with pd.option_context("display.width", 200, "display.max_columns", 12):
        print(f"{len(pooled.summaries)} trainings, sweep keys {keys}")
        print(overall[["method", "runs", "deploy_success_rate", "deploy_ci_low", "deploy_ci_high"]])
        print(tables.paired[tables.paired["dimension"].isin(["all", "start_std_m", "variant"])])
        print(tables.robustness)
        if tables.time_step is not None:
            print(tables.time_step)
    print(output_dir)
    return 0
