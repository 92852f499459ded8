"""Rerun (0.41) recordings of validation insertions and planning runs.

Each recording's id is the run id of the Parquet file made by the same job, and the provenance
record is attached as a recording property, so a ``.rrd`` and its Parquet are linked. Open with
``rerun FILE.rrd`` (native viewer) or ``rerun --serve-web --bind 127.0.0.1 FILE.rrd`` (offline
web viewer on port 9090).
"""

from __future__ import annotations

import json
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import rerun as rr
import rerun.blueprint as rrb
from numpy.typing import NDArray

from pih.provenance import canonical_json
from pih.scene import HoleConfig, SceneConfig, Trace, wall_profile
from pih.traces import write_with

APPLICATION_ID = "pih"
SPATIAL_PERIOD_S = 0.02  # spatial entities are logged at 50 Hz; scalar series at every step
ROBOT_AXIS_M = 0.005  # the robot frame is drawn as its y axis (the peg's axis at rest), 5 mm long


def hole_outline(hole: HoleConfig) -> list[NDArray[np.float64]]:
    """World (x, y) outlines of the two walls: the right wall profile and its mirror."""
    right = wall_profile(hole) + [hole.x_m, hole.y_m]
    left = right * [-1.0, 1.0] + [2.0 * hole.x_m, 0.0]
    return [np.vstack([w, w[:1]]) for w in (right, left)]


def peg_outline(
    q_peg: NDArray[np.float64], diameter_m: float, length_m: float
) -> NDArray[np.float64]:
    """Closed (x, y) outline of the peg at pose q_P."""
    corners = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1], [-1, -1]]) * [
        diameter_m / 2,
        length_m / 2,
    ]
    c, s = np.cos(q_peg[2]), np.sin(q_peg[2])
    return corners @ np.array([[c, s], [-s, c]]) + q_peg[:2]


def _open(
    run_id: str, path: Path, blueprint: rrb.Blueprint, provenance: Mapping[str, Any]
) -> rr.RecordingStream:
    if os.environ.get("RERUN", "").lower() in {"0", "off", "false", "no"}:
        raise RuntimeError(
            f"cannot write {path}: the environment sets RERUN={os.environ['RERUN']}, which disables Rerun"
        )
    rec = rr.RecordingStream(APPLICATION_ID, recording_id=run_id)
    rec.save(path, default_blueprint=blueprint)
    rec.send_property("provenance", rr.AnyValues(record=canonical_json(dict(provenance))))
    return rec


def _log_scene(rec: rr.RecordingStream, scene: SceneConfig) -> None:
    rec.log(
        "world/hole",
        rr.LineStrips2D(hole_outline(scene.hole), colors=[(120, 120, 120)]),
        static=True,
    )


def record_insertion(
    path: str | Path, trace: Trace, scene: SceneConfig, run_id: str, provenance: Mapping[str, Any]
) -> None:
    """Peg, hole outline, robot frame, spring and contact-force arrow in 2-D; forces vs time."""
    blueprint = rrb.Blueprint(
        rrb.Horizontal(
            rrb.Spatial2DView(name="scene", origin="world"),
            rrb.Vertical(
                rrb.TimeSeriesView(name="contact force (N)", origin="forces"),
                rrb.TimeSeriesView(name="insertion depth (m)", origin="depth"),
            ),
        )
    )

    def write(target: Path) -> None:
        with _open(run_id, target, blueprint, provenance) as rec:
            _log_scene(rec, scene)
            times = rr.TimeColumn("sim_time", duration=trace.time_s)
            for i, name in enumerate(("fx", "fy")):
                rec.send_columns(
                    f"forces/{name}",
                    indexes=[times],
                    columns=rr.Scalars.columns(scalars=trace.contact_force[:, i]),
                )
            rec.send_columns(
                "depth/l",
                indexes=[times],
                columns=rr.Scalars.columns(scalars=trace.insertion_depth_m),
            )
            step = float(np.median(np.diff(trace.time_s))) if len(trace) > 1 else SPATIAL_PERIOD_S
            every = max(1, round(SPATIAL_PERIOD_S / step))
            scale = 1e-3  # m per N for the force arrows
            for k in range(0, len(trace), every):
                rec.set_time("sim_time", duration=float(trace.time_s[k]))
                rec.log(
                    "world/peg",
                    rr.LineStrips2D(
                        [peg_outline(trace.q_peg[k], scene.peg.diameter_m, scene.peg.length_m)]
                    ),
                )
                theta = trace.q_robot[k, 2]
                rec.log(
                    "world/robot",
                    rr.Arrows2D(
                        origins=[trace.q_robot[k, :2]],
                        vectors=[[-ROBOT_AXIS_M * np.sin(theta), ROBOT_AXIS_M * np.cos(theta)]],
                        colors=[(230, 80, 40)],
                    ),
                )
                rec.log(
                    "world/spring",
                    rr.LineStrips2D(
                        [[trace.q_robot[k, :2], trace.q_peg_top[k, :2]]], colors=[(230, 80, 40)]
                    ),
                )
                rec.log(
                    "world/contact_force",
                    rr.Arrows2D(
                        origins=[trace.q_peg_bottom[k, :2]],
                        vectors=[scale * trace.contact_force[k, :2]],
                        colors=[(40, 120, 230)],
                    ),
                )

    write_with(path, write)


def record_planning(
    path: str | Path,
    rollouts: pd.DataFrame,
    best_paths: pd.DataFrame,
    scene: SceneConfig,
    run_id: str,
    provenance: Mapping[str, Any],
) -> None:
    """Per iteration: best peg-tip and robot paths, sensed hole, DMP goal; cost series."""
    blueprint = rrb.Blueprint(
        rrb.Horizontal(
            rrb.Spatial2DView(name="paths", origin="world"),
            rrb.TimeSeriesView(name="best inner cost J_inn", origin="cost"),
        )
    )
    best = rollouts[rollouts["is_best"]].set_index("iteration")

    def write(target: Path) -> None:
        with _open(run_id, target, blueprint, provenance) as rec:
            _log_scene(rec, scene)
            for iteration, path_rows in best_paths.groupby("iteration"):
                rec.set_time("iteration", sequence=int(iteration))
                row = best.loc[iteration]
                rec.log(
                    "world/best_peg_tip_path",
                    rr.LineStrips2D(
                        [path_rows[["peg_bottom_x_m", "peg_bottom_y_m"]].to_numpy()],
                        colors=[(40, 120, 230)],
                    ),
                )
                rec.log(
                    "world/best_robot_path",
                    rr.LineStrips2D(
                        [path_rows[["robot_x_m", "robot_y_m"]].to_numpy()], colors=[(230, 80, 40)]
                    ),
                )
                rec.log(
                    "world/sensed_hole",
                    rr.Points2D(
                        [[row["sensed_hole_x_m"], row["sensed_hole_y_m"]]],
                        radii=0.001,
                        colors=[(200, 40, 200)],
                    ),
                )
                rec.log(
                    "world/goal",
                    rr.Points2D(
                        [[row["goal_x_m"], row["goal_y_m"]]], radii=0.001, colors=[(40, 180, 60)]
                    ),
                )
                if np.isfinite(row["cost"]):
                    rec.log("cost/best", rr.Scalars(float(row["cost"])))

    write_with(path, write)


def read_recording_provenance(path: str | Path) -> dict[str, Any]:
    """The provenance property of a recording written by this module."""
    from rerun.chunk import RrdReader

    for chunk in RrdReader(str(path)).store().stream():
        if chunk.entity_path == "/__properties/provenance":
            return json.loads(chunk.to_record_batch().column("record")[0][0].as_py())
    raise ValueError(f"{path}: no provenance property in the recording")
