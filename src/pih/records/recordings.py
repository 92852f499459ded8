"""Rerun (0.41) recordings of validation insertions and planning runs.

Each recording's id is the run id of the Parquet file made by the same job, and the provenance
record is attached as a recording property, so a ``.rrd`` and its Parquet are linked. Open with
``rerun FILE.rrd`` or in a browser (README, "Recordings").
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import rerun as rr
import rerun.blueprint as rrb
from numpy.typing import NDArray

from pih.records.config import RecordingsConfig
from pih.records.outputs import write_with
from pih.records.provenance import canonical_json
from pih.records.sampling import envelope_indices, frame_indices
from pih.scene.config import SceneConfig, hole_outline
from pih.scene.frames import offset_along_axis
from pih.scene.trace import Trace
from pih.whitney.frame import error_side

APPLICATION_ID = "pih"
ROBOT_AXIS_M = 0.005  # the robot frame is drawn as its y axis (the peg's axis at rest), 5 mm long
FORCE_ARROW_M_PER_N = 1e-3  # force arrows: 1 mm per newton
# Entities whose own labels would stack on others (the spring's on the robot frame's, the best
# paths', goal's and sensed hole's at the hole bottom) are named in a legend instead: coloured
# points with labels in a column right of the hole, LEGEND_X_M from its axis, LEGEND_STEP_M apart.
LEGEND_X_M = 0.035
LEGEND_TOP_M = 0.04
LEGEND_STEP_M = 0.008
# The scene's entities live under SCENE, which is drawn through a y-flip: Rerun's 2-D view draws
# y downward and ignores view coordinates (rerun-io/rerun#1387), the paper's frame is y-up. The
# logged values stay the paper's world coordinates (hovering shows them).
SCENE = "world/scene"
COLORS = {
    "hole": (150, 110, 80),
    "peg": (80, 80, 80),
    "robot": (230, 80, 40),
    "spring": (230, 160, 40),
    "contact": (40, 120, 230),
    "sensed_hole": (200, 40, 200),
    "goal": (40, 180, 60),
    "true_hole": (0, 170, 170),  # not white: Rerun draws labels in their colour on light grey
}
# Time series: one colour per series, contact and spring forces in Whitney's convention.
SERIES = {
    "contact_f_x": ("contact F_x (N)", (40, 120, 230)),
    "contact_f_z": ("contact F_z (N)", (120, 200, 255)),
    "spring_f_x": ("spring F_x (N)", (230, 80, 40)),
    "spring_f_z": ("spring F_z (N)", (240, 180, 60)),
}


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


def _log_scene(
    rec: rr.RecordingStream, scene: SceneConfig, legend: Mapping[str, str] | None = None
) -> None:
    """The y-flip, the hole, and a legend (label → colour name) of the entities drawn unlabelled."""
    rec.log(SCENE, rr.Transform3D(scale=[1.0, -1.0, 1.0]), static=True)
    rec.log(
        f"{SCENE}/hole",
        rr.LineStrips2D(hole_outline(scene.hole), colors=[COLORS["hole"]], labels=["hole", "hole"]),
        static=True,
    )
    if legend:
        x = scene.hole.x_m + LEGEND_X_M
        rec.log(
            f"{SCENE}/legend",
            rr.Points2D(
                [[x, LEGEND_TOP_M - k * LEGEND_STEP_M] for k in range(len(legend))],
                radii=0.0008,
                colors=[COLORS[color] for color in legend.values()],
                labels=list(legend),
                show_labels=True,
            ),
            static=True,
        )


def _log_peg(
    rec: rr.RecordingStream,
    scene: SceneConfig,
    q_peg: NDArray[np.float64],
    q_robot: NDArray[np.float64],
    q_top: NDArray[np.float64],
) -> None:
    """The peg, the robot frame R and the spring R–P1 at one instant."""
    rec.log(
        f"{SCENE}/peg",
        rr.LineStrips2D(
            [peg_outline(q_peg, scene.peg.diameter_m, scene.peg.length_m)],
            colors=[COLORS["peg"]],
            labels=["peg"],
        ),
    )
    theta = q_robot[2]
    rec.log(
        f"{SCENE}/robot",
        rr.Arrows2D(
            origins=[q_robot[:2]],
            vectors=[[-ROBOT_AXIS_M * np.sin(theta), ROBOT_AXIS_M * np.cos(theta)]],
            colors=[COLORS["robot"]],
            labels=["robot frame R"],
        ),
    )
    rec.log(
        f"{SCENE}/spring",
        rr.LineStrips2D(
            [[q_robot[:2], q_top[:2]]],
            colors=[COLORS["spring"]],
            labels=["spring"],
            show_labels=False,  # R and P1 nearly coincide: named in the legend, not on R's label
        ),
    )


DEPTH_ENTITY = "depth/insertion_depth_mm"  # in mm: Rerun's plot labels metres' ticks as "0"


def _padded_range(values: NDArray[np.float64]) -> tuple[float, float]:
    """A plot range around the finite values, 5 % wider on each side (never empty)."""
    finite = values[np.isfinite(values)]
    if not len(finite):
        return (0.0, 1.0)
    low, high = float(finite.min()), float(finite.max())
    pad = max(0.05 * (high - low), 0.5)
    return (low - pad, high + pad)


def _time_panel(timeline: str) -> rrb.TimePanel:
    """Open a recording paused at the start of ``timeline`` (Rerun otherwise follows a file to
    its end); looping, so that play runs it again and again."""
    return rrb.TimePanel(timeline=timeline, play_state="paused", loop_mode="all")


def _series_styles(rec: rr.RecordingStream, entity: str, names: list[str]) -> None:
    for name in names:
        label, color = SERIES[name]
        rec.log(f"{entity}/{name}", rr.SeriesLines(colors=[color], names=[label]), static=True)


def record_insertion(
    path: str | Path,
    trace: Trace,
    scene: SceneConfig,
    run_id: str,
    provenance: Mapping[str, Any],
    rates: RecordingsConfig | None = None,
) -> None:
    """Validation insertion: peg, hole, robot frame, spring and contact-force arrow (y up); the
    contact and spring forces in Whitney's convention (F_x toward the error side, F_z the
    push-back) and the insertion depth ℓ (mm) against simulated time, each series drawn from its
    :func:`envelope_indices`, the scene at :func:`frame_indices` (at ``rates``: a 350 s descent
    at every 0.5 ms step would be 80 MB of series nobody can see; default: the config's
    defaults). Opens paused at its start."""
    rates = rates or RecordingsConfig()
    depth_mm = 1e3 * np.asarray(trace.insertion_depth_m, dtype=float)
    blueprint = rrb.Blueprint(
        rrb.Horizontal(
            rrb.Spatial2DView(name="scene (y up)", origin="world"),
            rrb.Vertical(
                rrb.TimeSeriesView(
                    name="forces on the peg (N), Whitney's convention", origin="forces"
                ),
                rrb.TimeSeriesView(
                    name="insertion depth ℓ (mm)",
                    origin="depth",
                    axis_y=rrb.ScalarAxis(range=_padded_range(depth_mm)),
                ),
            ),
        ),
        _time_panel("sim_time"),
    )
    side = error_side(trace.q_robot[0, 0], scene.hole.x_m)
    series = {
        "contact_f_x": side * trace.contact_force[:, 0],
        "contact_f_z": trace.contact_force[:, 1],
        "spring_f_x": side * trace.spring_force[:, 0],
        "spring_f_z": trace.spring_force[:, 1],
    }

    def write(target: Path) -> None:
        with _open(run_id, target, blueprint, provenance) as rec:
            _log_scene(rec, scene, {"spring R–P1": "spring"})
            _series_styles(rec, "forces", list(series))
            rec.log(
                DEPTH_ENTITY,
                rr.SeriesLines(colors=[(40, 120, 230)], names=["insertion depth ℓ (mm)"]),
                static=True,
            )
            entities = {f"forces/{name}": values for name, values in series.items()}
            for entity, values in {**entities, DEPTH_ENTITY: depth_mm}.items():
                kept = envelope_indices(
                    trace.time_s, values, rates.series_rate_hz, rates.full_rate_tail_s
                )
                rec.send_columns(
                    entity,
                    indexes=[rr.TimeColumn("sim_time", duration=trace.time_s[kept])],
                    columns=rr.Scalars.columns(scalars=values[kept]),
                )
            for k in frame_indices(trace.time_s, rates.frame_rate_hz, rates.full_rate_tail_s):
                rec.set_time("sim_time", duration=float(trace.time_s[k]))
                _log_peg(rec, scene, trace.q_peg[k], trace.q_robot[k], trace.q_peg_top[k])
                rec.log(
                    f"{SCENE}/contact_force",
                    rr.Arrows2D(
                        origins=[trace.q_peg_bottom[k, :2]],
                        vectors=[FORCE_ARROW_M_PER_N * trace.contact_force[k, :2]],
                        colors=[COLORS["contact"]],
                        labels=["contact force"],
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
    frame_rate_hz: float = RecordingsConfig.frame_rate_hz,
) -> None:
    """Planning run. Timeline ``iteration``: each iteration's best peg-tip and robot paths (at
    :func:`frame_indices`), the sensed hole and the goal (peg-tip target), and the best J_inn.
    Timeline ``playback``: the peg animated along every iteration's best rollout in turn
    (iteration i starts at (i − 1) × rollout time); the recording opens paused at its start. A
    legend names what ends at the hole bottom."""
    blueprint = rrb.Blueprint(
        rrb.Horizontal(
            rrb.Spatial2DView(name="paths (y up)", origin="world"),
            rrb.TimeSeriesView(name="best inner cost J_inn (dimensionless)", origin="cost"),
            column_shares=[2, 1],
        ),
        _time_panel("playback"),
    )
    best = rollouts[rollouts["is_best"]].set_index("iteration")
    rollout_s = float(best_paths["time_s"].max()) if len(best_paths) else 0.0
    step = float(np.median(np.diff(best_paths["time_s"].unique()))) if len(best_paths) > 2 else 1.0
    length = scene.peg.length_m

    def write(target: Path) -> None:
        with _open(run_id, target, blueprint, provenance) as rec:
            _log_scene(rec, scene, PLANNING_LEGEND)
            rec.log(
                f"{SCENE}/true_hole",
                rr.Points2D(
                    [[scene.hole.x_m, scene.hole.y_m]],
                    radii=0.0006,
                    colors=[COLORS["true_hole"]],
                    labels=["true hole H"],
                ),
                static=True,
            )
            for iteration, rows in best_paths.groupby("iteration"):
                times = rows["time_s"].to_numpy()
                path_rows = rows.iloc[frame_indices(times, frame_rate_hz)]
                row = best.loc[iteration]
                start_s = (int(iteration) - 1) * (rollout_s + step)
                for timeline in ("iteration", "playback"):
                    rec.reset_time()
                    if timeline == "iteration":
                        rec.set_time("iteration", sequence=int(iteration))
                    else:
                        rec.set_time("playback", duration=start_s)
                    _log_iteration(rec, row, path_rows)
                rec.reset_time()
                q_bottom = path_rows[
                    ["peg_bottom_x_m", "peg_bottom_y_m", "peg_bottom_theta_rad"]
                ].to_numpy()
                q_robot = path_rows[["robot_x_m", "robot_y_m", "robot_theta_rad"]].to_numpy()
                q_peg = offset_along_axis(q_bottom, length / 2)
                q_top = offset_along_axis(q_bottom, length)
                times = path_rows["time_s"].to_numpy()
                for k in range(len(times)):
                    rec.set_time("playback", duration=start_s + float(times[k]))
                    _log_peg(rec, scene, q_peg[k], q_robot[k], q_top[k])
                if np.isfinite(row["cost"]):
                    # On both timelines: per iteration, and at the end of its playback.
                    rec.set_time("iteration", sequence=int(iteration))
                    rec.log("cost/best", rr.Scalars(float(row["cost"])))

    write_with(path, write)


# The planning recording's legend: the entities at the hole bottom, drawn without their labels.
PLANNING_LEGEND = {
    "best rollout: peg tip P2": "contact",
    "best rollout: robot frame R": "robot",
    "goal (peg-tip target)": "goal",
    "sensed hole": "sensed_hole",
    "spring R–P1": "spring",
}


def _log_iteration(rec: rr.RecordingStream, row: pd.Series, path_rows: pd.DataFrame) -> None:
    """One iteration's best paths, sensed hole and goal (the peg-tip target of the DMP goal)."""
    rec.log(
        f"{SCENE}/best_peg_tip_path",
        rr.LineStrips2D(
            [path_rows[["peg_bottom_x_m", "peg_bottom_y_m"]].to_numpy()],
            colors=[COLORS["contact"]],
            labels=["best rollout: peg tip P2"],
            show_labels=False,
        ),
    )
    rec.log(
        f"{SCENE}/best_robot_path",
        rr.LineStrips2D(
            [path_rows[["robot_x_m", "robot_y_m"]].to_numpy()],
            colors=[COLORS["robot"]],
            labels=["best rollout: robot frame R"],
            show_labels=False,
        ),
    )
    rec.log(
        f"{SCENE}/sensed_hole",
        rr.Points2D(
            [[row["sensed_hole_x_m"], row["sensed_hole_y_m"]]],
            radii=0.0008,
            colors=[COLORS["sensed_hole"]],
            labels=["sensed hole"],
            show_labels=False,
        ),
    )
    rec.log(
        f"{SCENE}/goal",
        rr.Points2D(
            [[row["target_x_m"], row["target_y_m"]]],
            radii=0.0008,
            colors=[COLORS["goal"]],
            labels=["goal (peg-tip target)"],
            show_labels=False,
        ),
    )
