"""Rerun recordings: what a researcher opening them sees (read back from the .rrd)."""

import numpy as np
import pandas as pd
import pytest
from rerun.chunk import RrdReader

from pih.recordings import SCENE, record_insertion, record_planning
from pih.scene import Trace
from pih.scene_config import SceneConfig


def _chunks(path) -> dict[str, list]:
    by_entity: dict[str, list] = {}
    for chunk in RrdReader(str(path)).store().stream():
        by_entity.setdefault(chunk.entity_path, []).append(chunk.to_record_batch())
    return by_entity


def _column(batches, name: str) -> list:
    return [v for b in batches if name in b.schema.names for v in b.column(name).to_pylist()]


def _labels(batches) -> set[str]:
    return {
        label
        for b in batches
        for name in b.schema.names
        if name.endswith(":labels")
        for row in b.column(name).to_pylist()
        for label in row
    }


def _insertion_trace(start_x_m: float) -> Trace:
    n = 50
    q = np.zeros((n, 3))
    q[:, 0] = start_x_m
    force = np.column_stack([np.full(n, 2.0), np.full(n, 5.0), np.zeros(n)])
    spring = np.column_stack([np.full(n, -3.0), np.full(n, -4.0), np.zeros(n)])
    return Trace(
        time_s=np.arange(n) * 0.01,
        q_robot=q,
        q_peg=q,
        q_peg_top=q,
        q_peg_bottom=q,
        contact_force=force,
        contact_patches=np.ones(n, dtype=np.int64),
        spring_force=spring,
        spring_energy_j=np.zeros(n),
        insertion_depth_m=np.linspace(0, 0.01, n),
        penetration_m=np.zeros(n),
    )


@pytest.mark.parametrize("start_x_m", [-0.001, 0.001])
def test_insertion_recording_is_y_up_labelled_and_in_whitneys_convention(tmp_path, start_x_m):
    path = tmp_path / "run.rrd"
    record_insertion(path, _insertion_trace(start_x_m), SceneConfig(), "run", {"run_id": "run"})
    chunks = _chunks(path)
    # The scene is drawn through a y-flip (Rerun's 2-D view is y-down)...
    scale = _column(chunks[f"/{SCENE}"], "Transform3D:scale")
    assert np.allclose(scale[0], [1.0, -1.0, 1.0])
    # ...and every drawn thing carries a label.
    for entity, label in [
        ("hole", "hole"),
        ("peg", "peg"),
        ("robot", "robot frame R"),
        ("spring", "spring"),
        ("contact_force", "contact force"),
    ]:
        assert label in _labels(chunks[f"/{SCENE}/{entity}"]), entity
    # Forces in Whitney's convention: F_x positive toward the side the peg starts on.
    side = 1.0 if start_x_m > 0 else -1.0
    assert _column(chunks["/forces/contact_f_x"], "Scalars:scalars")[0] == [side * 2.0]
    assert _column(chunks["/forces/contact_f_z"], "Scalars:scalars")[0] == [5.0]
    assert _column(chunks["/forces/spring_f_x"], "Scalars:scalars")[0] == [side * -3.0]
    names = [
        n[0]
        for e in ("contact_f_x", "contact_f_z", "spring_f_x", "spring_f_z")
        for n in _column(chunks[f"/forces/{e}"], "SeriesLines:names")
    ]
    colors = [
        c[0]
        for e in ("contact_f_x", "contact_f_z", "spring_f_x", "spring_f_z")
        for c in _column(chunks[f"/forces/{e}"], "SeriesLines:colors")
    ]
    assert names == ["contact F_x (N)", "contact F_z (N)", "spring F_x (N)", "spring F_z (N)"]
    assert len(set(colors)) == 4


def test_planning_recording_animates_the_peg_along_each_best_path(tmp_path):
    iterations, samples = 3, 40
    rollouts = pd.DataFrame(
        {
            "iteration": range(1, iterations + 1),
            "is_best": True,
            "sensed_hole_x_m": [0.004, 0.006, 0.002],
            "sensed_hole_y_m": -0.01,
            "target_x_m": [0.004, 0.003, 0.001],
            "target_y_m": -0.01,
            "cost": [3.0, 2.0, np.nan],
        }
    )
    t = np.arange(samples) * 0.01
    best_paths = pd.concat(
        pd.DataFrame(
            {
                "iteration": i,
                "time_s": t,
                "robot_x_m": np.linspace(-0.03, 0.0, samples),
                "robot_y_m": 0.05,
                "robot_theta_rad": 0.0,
                "peg_bottom_x_m": np.linspace(-0.03, 0.0, samples),
                "peg_bottom_y_m": 0.005,
                "peg_bottom_theta_rad": 0.0,
            }
        )
        for i in range(1, iterations + 1)
    )
    path = tmp_path / "run.rrd"
    record_planning(path, rollouts, best_paths, SceneConfig(), "run", {"run_id": "run"})
    chunks = _chunks(path)
    # The peg is animated on the playback timeline: every iteration in turn, at 50 Hz.
    playback = _column(chunks[f"/{SCENE}/peg"], "playback")
    assert len(playback) == iterations * len(range(0, samples, 2))
    assert np.all(np.diff([p.total_seconds() for p in playback]) > 0)
    # Sensed hole and goal per iteration, on both timelines; the true hole once.
    goal = chunks[f"/{SCENE}/goal"]
    assert sorted(_column(goal, "iteration")) == [1, 2, 3]
    assert len(_column(goal, "playback")) == iterations
    assert _column(chunks[f"/{SCENE}/true_hole"], "Points2D:labels") == [["true hole H"]]
    # The cost series skips the diverged iteration.
    assert _column(chunks["/cost/best"], "Scalars:scalars") == [[3.0], [2.0]]
