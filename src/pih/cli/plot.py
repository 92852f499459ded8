"""``pih plot RUN_DIR``: one planning run's cost curve and best paths."""

from __future__ import annotations

import sys
from pathlib import Path

from pih.cli.common import first_line, missing_parent


def plot(run: Path, output: Path | None) -> int:
    """Draw one planning run's cost curve and best paths into ``output`` (default RUN/run.png)."""
    import pandas as pd

    from pih.planning.run_record import RecordedRun
    from pih.reporting import plots

    if missing_parent("plot", "--output", output):
        return 1
    try:
        recorded = RecordedRun.read(run / "rollouts.parquet")
        paths = pd.read_parquet(run / "best_paths.parquet")
    except Exception as error:  # noqa: BLE001 - any unreadable run: one clear line
        first = first_line(error)
        print(f"{run}: not a planning run directory ({first})", file=sys.stderr)
        return 1
    target = output or run / "run.png"
    figure = plots.run_figure(recorded.rollouts, paths, recorded.scene.hole, run.name)
    plots.save(figure, target, provenance=recorded.record)
    print(target)
    return 0
