"""Rerun recordings: what a researcher opening them sees (read back from the .rrd)."""

import dataclasses

import numpy as np
import pandas as pd
import pytest
import rerun.blueprint as rrb
from rerun.chunk import RrdReader

from pih.records.recordings import SCENE, record_insertion, record_planning
from pih.scene.config import SceneConfig
from pih.scene.trace import Trace


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
    # The peg is animated on the playback timeline: every iteration in turn, at 50 Hz and at
    # its last sample (where the rollout ended).
    playback = _column(chunks[f"/{SCENE}/peg"], "playback")
    assert len(playback) == iterations * (len(range(0, samples, 2)) + 1)
    assert np.all(np.diff([p.total_seconds() for p in playback]) > 0)
    # Sensed hole and goal per iteration, on both timelines; the true hole once.
    goal = chunks[f"/{SCENE}/goal"]
    assert sorted(_column(goal, "iteration")) == [1, 2, 3]
    assert len(_column(goal, "playback")) == iterations
    assert _column(chunks[f"/{SCENE}/true_hole"], "Points2D:labels") == [["true hole H"]]
    # The cost series skips the diverged iteration.
    assert _column(chunks["/cost/best"], "Scalars:scalars") == [[3.0], [2.0]]


def _time_panel(path) -> dict[str, object]:
    """The time-panel settings of a recording's default blueprint."""
    reader = RrdReader(str(path))
    (blueprint,) = reader.blueprints()
    settings: dict[str, object] = {}
    for chunk in reader.store(store=blueprint).stream():
        if chunk.entity_path == "/time_panel":
            for row in chunk.to_record_batch().to_pylist():
                settings.update({k.split(":")[-1]: v for k, v in row.items() if ":" in k})
    return settings


def _show_labels(batches) -> list[bool]:
    return [
        v
        for row in _column(
            batches,
            next(name for b in batches for name in b.schema.names if name.endswith(":show_labels")),
        )
        for v in row
    ]


def test_insertion_recording_opens_at_its_start_with_the_depth_in_mm(tmp_path):
    path = tmp_path / "run.rrd"
    record_insertion(path, _insertion_trace(0.001), SceneConfig(), "run", {"run_id": "run"})
    chunks = _chunks(path)
    # Rerun follows a file to its end unless told: the blueprint says paused, at the start.
    panel = _time_panel(path)
    assert panel["timeline"] == ["sim_time"]
    assert panel["play_state"] == [rrb.components.PlayState.Paused.value]
    # The depth in mm (in metres the plot's only tick read "0"), named with its unit.
    (entity,) = [e for e in chunks if e.startswith("/depth/")]
    assert _column(chunks[entity], "Scalars:scalars")[-1] == pytest.approx([10.0])
    assert _column(chunks[entity], "SeriesLines:names") == [["insertion depth ℓ (mm)"]]
    # The spring's label would sit on the robot frame's: it is named in the legend instead.
    assert _show_labels(chunks[f"/{SCENE}/spring"]) == [False] * len(
        _column(chunks[f"/{SCENE}/spring"], "LineStrips2D:labels")
    )
    assert "spring R–P1" in _labels(chunks[f"/{SCENE}/legend"])


def test_planning_recording_opens_at_the_start_of_playback_with_a_legend(tmp_path):
    rollouts = pd.DataFrame(
        {
            "iteration": [1, 2],
            "is_best": True,
            "sensed_hole_x_m": 0.001,
            "sensed_hole_y_m": -0.01,
            "target_x_m": 0.0,
            "target_y_m": -0.01,
            "cost": [2.0, 1.0],
        }
    )
    t = np.arange(10) * 0.02
    best_paths = pd.concat(
        pd.DataFrame(
            {
                "iteration": i,
                "time_s": t,
                "robot_x_m": 0.0,
                "robot_y_m": 0.035,
                "robot_theta_rad": 0.0,
                "peg_bottom_x_m": 0.0,
                "peg_bottom_y_m": -0.01,
                "peg_bottom_theta_rad": 0.0,
            }
        )
        for i in (1, 2)
    )
    path = tmp_path / "run.rrd"
    record_planning(path, rollouts, best_paths, SceneConfig(), "run", {"run_id": "run"})
    panel = _time_panel(path)
    assert panel["timeline"] == ["playback"]
    assert panel["play_state"] == [rrb.components.PlayState.Paused.value]
    chunks = _chunks(path)
    # Everything that ends at the hole bottom is drawn without its label...
    for entity in ("best_peg_tip_path", "best_robot_path", "goal", "sensed_hole"):
        assert set(_show_labels(chunks[f"/{SCENE}/{entity}"])) == {False}, entity
    # ...and named once in a legend, its entries apart, above the hole's top surface.
    legend = chunks[f"/{SCENE}/legend"]
    assert _labels(legend) == {
        "best rollout: peg tip P2",
        "best rollout: robot frame R",
        "goal (peg-tip target)",
        "sensed hole",
        "spring R–P1",
    }
    (positions,) = _column(legend, "Points2D:positions")
    heights = sorted(y for _, y in positions)
    assert min(heights) > 0 and np.min(np.diff(heights)) >= 0.005


def test_insertion_series_are_decimated_keeping_every_peak_and_the_tail(tmp_path):
    """A 20 s insertion at a 0.5 ms step is drawn from far fewer samples: each 10 ms bin's lowest
    and highest (a one-sample spike survives), the last second at every step, the scene at its
    frame rate."""
    from pih.records.config import RecordingsConfig
    from pih.records.recordings import DEPTH_ENTITY
    from pih.records.sampling import envelope_indices

    n = 40_000
    trace = _insertion_trace(0.001)
    t = np.arange(n) * 0.0005
    force = np.zeros((n, 3))
    force[:, 1] = np.sin(t)
    force[12_345, 1] = 50.0  # a one-step spike
    trace = dataclasses.replace(
        trace,
        time_s=t,
        **{
            name: np.resize(getattr(trace, name), (n, *getattr(trace, name).shape[1:]))
            for name in ("q_robot", "q_peg", "q_peg_top", "q_peg_bottom", "spring_force")
        },
        contact_force=force,
        contact_patches=np.ones(n, dtype=np.int64),
        spring_energy_j=np.zeros(n),
        insertion_depth_m=np.linspace(0, 0.01, n),
        penetration_m=np.zeros(n),
    )
    kept = envelope_indices(t, force[:, 1], 100.0, 1.0)
    assert 12_345 in kept and {0, n - 1} <= set(kept)
    assert set(range(n - 2001, n)) <= set(kept)  # the last second, every step
    assert len(kept) < 2 * 20 * 100 + 2001 + 2
    path = tmp_path / "run.rrd"
    rates = RecordingsConfig(frame_rate_hz=10.0)
    record_insertion(path, trace, SceneConfig(), "run", {"run_id": "run"}, rates)
    chunks = _chunks(path)
    f_z = np.concatenate(_column(chunks["/forces/contact_f_z"], "Scalars:scalars")).ravel()
    assert f_z.max() == 50.0 and len(f_z) == len(kept)
    assert len(_column(chunks[f"/{DEPTH_ENTITY}"], "Scalars:scalars")) < n / 5
    frames = _column(chunks[f"/{SCENE}/peg"], "sim_time")
    # 10 Hz, then every step of the last second (t ≥ t_end − 1 s: 2001 steps)
    assert len(frames) == len(set(range(0, n, 200)) | set(range(n - 2001, n)))


@pytest.mark.parametrize(
    ("section", "message"),
    [
        ({"series_rate_hz": 0.0}, r"recordings\.series_rate_hz: 0\.0"),
        ({"frame_rate_hz": float("nan")}, r"recordings\.frame_rate_hz: nan"),
        ({"validation_frame_rate_hz": -5.0}, r"recordings\.validation_frame_rate_hz: -5\.0"),
        ({"full_rate_tail_s": -1.0}, r"recordings\.full_rate_tail_s: -1\.0"),
        ({"frame_rate": 10.0}, r"recordings: unknown key\(s\) \['frame_rate'\]"),
    ],
)
def test_a_bad_recording_rate_is_named_before_any_job(section, message):
    from pih.config import ConfigError
    from pih.study.config import check_study, load_config, study_points

    config = load_config(["config/config.yaml"])
    config["recordings"] = {**config["recordings"], **section}
    with pytest.raises(ConfigError, match=f"^{message}"):
        check_study(config, study_points(config))


def test_the_envelope_keeps_a_peak_in_a_partial_last_bin_and_sees_past_nan():
    """The last bin may be shorter than the rest, with no full-rate tail to cover it; a NaN (a
    diverged step) in a bin does not hide its lowest and highest."""
    from pih.records.sampling import envelope_indices

    t = np.arange(1015) * 0.0005  # 10 ms bins of 20 steps: the last has 15
    values = np.zeros(1015)
    values[1007] = 5.0
    assert 1007 in envelope_indices(t, values, 100.0, 0.0)
    values = np.zeros(40)
    values[[3, 5, 7]] = [np.nan, 9.0, -9.0]
    kept = envelope_indices(t[:40], values, 100.0, 0.0)
    assert {5, 7} <= set(kept) and 3 not in kept
