"""``pih replay RUN_DIR QUERY``: the selected rollouts simulated again."""

from __future__ import annotations

import sys
from pathlib import Path

from pih.cli.common import first_line


def replay(run: Path, query: str, output: Path | None, settings: list[str]) -> int:
    """Simulate the rows ``query`` selects again, optionally under ``settings``; one line each."""
    import numpy as np

    from pih.cli.row_query import select_rows
    from pih.config import to_mapping
    from pih.planning.planner import Planner
    from pih.planning.run_record import RecordedRun, recorded_pose, recorded_rollout, succeeded
    from pih.records.config import RecordingsConfig
    from pih.records.provenance import record as provenance_record
    from pih.records.recordings import record_insertion
    from pih.scene.overrides import scene_settings, scene_with

    try:
        recorded = RecordedRun.read(run / "rollouts.parquet")
        rollouts, config = recorded.rollouts, recorded.record["config"]
        rows = select_rows(rollouts, query)
        overrides = scene_settings(settings)
        scene = scene_with(to_mapping(recorded.scene), overrides, "--set scene")
    except Exception as error:  # noqa: BLE001 - a bad run, query or setting: one clear line
        print(f"pih replay {run}: {first_line(error)}", file=sys.stderr)
        return 1
    if "weights" not in rollouts or rows.empty:
        if "weights" not in rollouts:
            why = "it predates recorded weights"
        else:
            why = (
                f"no row matches {query!r}; "
                + ", ".join(
                    f"{c} {rollouts[c].min()}–{rollouts[c].max()}" for c in ("iteration", "rollout")
                )
                + f", phases {', '.join(sorted(rollouts['phase'].unique()))}"
            )
        print(f"pih replay {run}: nothing to replay ({why})", file=sys.stderr)
        return 1
    planner = Planner.from_configs(scene, recorded.planner)
    hole, tolerance = planner.scene.hole_pose, recorded.planner.success_tolerance_m
    differs = 0
    for index, (_, row) in enumerate(rows.iterrows()):
        rollout = recorded_rollout(row)
        trace, _ = planner.evaluate_rollout(rollout)
        replayed = trace.q_peg_bottom[-1]
        simulated = hole if rollout.simulated_hole is None else rollout.simulated_hole
        inserted = succeeded(trace, simulated, tolerance)
        same = np.array_equal(replayed, recorded_pose(row, "final_bottom"))
        differs += not same
        if index == 0:
            name = f"replay_{row['phase']}_{row['iteration']}_{row['rollout']}"
            rates = RecordingsConfig()
            extra = {"query": query, "set": overrides, "recordings": to_mapping(rates)}
            provenance = provenance_record(
                "replay", config=config, inputs=[run / "rollouts.parquet"], extra=extra
            )
            target_file = output or run / f"{name}.rrd"
            # Drawn in the scene it ran in: a training row in the planner's own simulator.
            ran_in = planner.scene_for(rollout.simulated_hole).config
            record_insertion(target_file, trace, ran_in, name, provenance, rates)
            print(f"# {target_file}: the first row's replay, as a Rerun recording")
        pose = ",".join(f"{v:.9g}" for v in recorded_pose(row, "final_bottom"))
        print(
            f"phase={row['phase']} iteration={row['iteration']} rollout={row['rollout']} "
            f"recorded_p2={pose} replayed_p2={','.join(f'{v:.9g}' for v in replayed)} "
            f"recorded_inserted={int(bool(row['success']))} replayed_inserted={int(inserted)} "
            f"status={trace.status} same={int(same)}"
        )
    # Without --set a replay must end where the record says (exit 1 if not); with it, it may not.
    return 0 if settings or not differs else 1
