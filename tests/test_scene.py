"""Physics sanity of the planar hydroelastic peg-in-hole scene (paper §2.1–2.2)."""

import numpy as np
import pytest

from pih.config import ConfigError, from_mapping, to_mapping
from pih.scene.config import SceneConfig, wall_profile
from pih.scene.frames import offset_along_axis, pose_matrix, pose_vector
from pih.scene.simulation import PegInHoleScene, _Snapshot
from pih.scene.trace import RobotTrajectory, TrajectoryError

# The retry tests run at 2 ms with the retry at 1 ms: the mechanism does not depend on the step,
# and the stiff spring that diverges at 2 ms (below) does not at the default 1 ms.
TWO_MS = SceneConfig().replace(solver__time_step_s=0.002, solver__retry_time_step_s=0.001)


def straight_line(start, stop, duration_s=1.5, hold_s=0.5, step_s=0.002) -> RobotTrajectory:
    """Smoothstep from start to stop over duration_s, then hold."""
    t = np.arange(0.0, duration_s + hold_s + 1e-12, step_s)
    s = np.clip(t / duration_s, 0.0, 1.0)
    s = 3 * s**2 - 2 * s**3
    start, stop = np.asarray(start, float), np.asarray(stop, float)
    return RobotTrajectory(t, start + s[:, None] * (stop - start))


def robot_for_tip(scene: PegInHoleScene, x_m: float, tip_y_m: float) -> np.ndarray:
    """Robot pose (at rest on P1) that puts an upright peg's tip P2 at (x, tip_y)."""
    return scene.peg_top_from_bottom([x_m, tip_y_m, 0.0])


def test_frames_round_trip_and_offsets():
    q = np.array([0.01, -0.02, 0.3])
    assert np.allclose(pose_vector(pose_matrix(q)), q)
    top = offset_along_axis(q, 0.0225)
    T = pose_matrix(q) @ pose_matrix([0.0, 0.0225, 0.0])
    assert np.allclose(top, pose_vector(T))


def test_peg_follows_robot_without_contact(scene):
    hole_top = scene.config.hole.top_y_m
    start = robot_for_tip(scene, -0.035, hole_top + 0.010)
    stop = robot_for_tip(scene, -0.020, hole_top + 0.015)
    trace = scene.rollout(straight_line(start, stop))
    assert trace.ok, trace.reason
    assert np.all(trace.contact_patches == 0)
    assert np.max(np.abs(trace.contact_force)) == 0.0
    # Quasi-static tracking: after the hold the spring is relaxed and P1 sits on R.
    assert np.allclose(trace.q_peg_top[-1], stop, atol=2e-5)
    assert trace.spring_energy_j[-1] < 1e-6
    # and while moving the spring stretch stays small (mm, not cm).
    assert np.max(np.abs(trace.q_robot[:, :2] - trace.q_peg_top[:, :2])) < 2e-3


def test_centred_insertion_reaches_commanded_depth(scene):
    hole = scene.config.hole
    start = robot_for_tip(scene, hole.x_m, hole.top_y_m + 0.003)
    target_tip_y = hole.y_m + 0.001  # 1 mm above the bottom
    trace = scene.rollout(straight_line(start, robot_for_tip(scene, hole.x_m, target_tip_y)))
    assert trace.ok, trace.reason
    assert trace.q_peg_bottom[-1, 1] == pytest.approx(target_tip_y, abs=2e-5)
    assert trace.insertion_depth_m[-1] == pytest.approx(hole.entrance_y_m - target_tip_y, abs=2e-5)
    assert np.max(np.abs(trace.contact_force[:, :2])) < 0.05


def test_offset_outside_chamfer_rests_on_top_surface(scene):
    hole = scene.config.hole
    offset = 0.005  # the chamfer captures up to W − (D − d)/2 ≈ 2.5 mm
    start = robot_for_tip(scene, hole.x_m - offset, hole.top_y_m + 0.003)
    stop = robot_for_tip(scene, hole.x_m - offset, hole.y_m)
    trace = scene.rollout(straight_line(start, stop))
    assert trace.ok, trace.reason
    assert trace.q_peg_bottom[-1, 1] == pytest.approx(hole.top_y_m, abs=1e-4)
    assert trace.insertion_depth_m[-1] < 0
    # Static at the end: the contact force balances the spring.
    spring, contact = trace.spring_force[-1], trace.contact_force[-1]
    assert contact[1] == pytest.approx(-spring[1], rel=0.02)
    assert contact[1] == pytest.approx(1000.0 * hole.depth_m, rel=0.02)
    assert trace.contact_patches[-1] >= 1


def test_chamfer_forces_grow_with_depth(scene):
    hole = scene.config.hole
    offset = 0.001
    start = robot_for_tip(scene, hole.x_m - offset, hole.top_y_m + 0.001)
    stop = robot_for_tip(scene, hole.x_m - offset, hole.top_y_m - 0.003)
    trace = scene.rollout(straight_line(start, stop, duration_s=3.0))
    assert trace.ok, trace.reason
    z_c = offset - (hole.diameter_m - scene.config.peg.diameter_m) / 2  # eps0' tan(45°)
    on_chamfer = (trace.insertion_depth_m > -z_c + 1e-4) & (trace.insertion_depth_m < -3e-4)
    depth = trace.insertion_depth_m[on_chamfer]
    fx, fy = trace.contact_force[on_chamfer, 0], trace.contact_force[on_chamfer, 1]
    assert on_chamfer.sum() > 20
    # The chamfer pushes the peg (on the left) toward the axis (+x) and up; both grow with depth.
    assert np.all(fx > 0) and np.all(fy > 0)
    assert np.corrcoef(depth, fx)[0, 1] > 0.9
    assert np.corrcoef(depth, fy)[0, 1] > 0.9


def test_wall_profile_is_convex_with_fillet():
    profile = wall_profile(SceneConfig().hole)
    edges = np.diff(np.vstack([profile, profile[:1]]), axis=0)
    cross = edges[:, 0] * np.roll(edges[:, 1], -1) - edges[:, 1] * np.roll(edges[:, 0], -1)
    assert np.all(cross > -1e-15), "wall outline must be convex and counter-clockwise"
    assert len(profile) == 4 + SceneConfig().hole.fillet_facets + 1


def test_config_round_trip_and_strict_keys():
    config = SceneConfig()
    assert from_mapping(SceneConfig, to_mapping(config)) == config
    data = to_mapping(config)
    del data["material"]["friction"]
    with pytest.raises(ConfigError, match=r"material: missing key\(s\) \['friction'\]"):
        from_mapping(SceneConfig, data, "scene")


@pytest.mark.parametrize(
    ("section", "key", "value", "message"),
    [
        ("spring", "stiffness", [-1000.0, 1000.0, 1.0], r"scene\.spring\.stiffness"),
        ("peg", "diameter_m", 0.013, r"scene\.peg\.diameter_m.*narrower than the hole"),
        ("solver", "time_step_s", 0.0, r"scene\.solver\.time_step_s.*a step in"),
        ("solver", "time_step_s", 10.0, r"scene\.solver\.time_step_s.*a step in"),
        ("solver", "time_step_s", 1e-12, r"scene\.solver\.time_step_s.*a step in"),
        ("solver", "retry_time_step_s", 0.003, r"scene\.solver\.retry_time_step_s.*divides"),
        ("solver", "retry_time_step_s", 0.0015, r"scene\.solver\.retry_time_step_s.*divides"),
        ("solver", "check_interval_s", 0.0002, r"scene\.solver\.check_interval_s.*whole number"),
        ("solver", "check_interval_s", 0.2502, r"scene\.solver\.check_interval_s.*whole number"),
        ("hole", "chamfer_width_m", -0.001, r"scene\.hole\.chamfer_width_m.*>= 0"),
        ("material", "friction", "high", r"scene\.material\.friction.*a number"),
        ("solver", "contact_model", "magic", r"scene\.solver\.contact_model.*one of"),
        ("peg", "colour", "red", r"scene\.peg: unknown key"),
    ],
)
def test_bad_config_is_rejected_naming_the_key(section, key, value, message):
    data = to_mapping(SceneConfig())
    data[section][key] = value
    with pytest.raises(ConfigError, match=message):
        from_mapping(SceneConfig, data, "scene")


@pytest.mark.parametrize(
    ("times", "poses", "message"),
    [
        ([0.0, 0.1, 0.1], np.zeros((3, 3)), "strictly increasing"),
        ([0.0, 0.1], np.zeros((2, 2)), r"shape \(2, 3\)"),
        ([0.0, 0.1], np.array([[0, 0, 0], [np.nan, 0, 0]]), "NaN"),
        ([0.5, 1.0], np.zeros((2, 3)), "start at 0"),
        ([0.0], np.zeros((1, 3)), ">= 2 samples"),
    ],
)
def test_bad_trajectory_is_rejected(times, poses, message):
    with pytest.raises(TrajectoryError, match=message):
        RobotTrajectory(np.asarray(times, float), np.asarray(poses, float))


def test_divergence_is_data_not_an_exception():
    strict = PegInHoleScene(SceneConfig().replace(solver__max_contact_force_n=1.0))
    hole = strict.config.hole
    start = robot_for_tip(strict, hole.x_m - 0.005, hole.top_y_m + 0.003)
    trace = strict.rollout(straight_line(start, robot_for_tip(strict, hole.x_m - 0.005, hole.y_m)))
    assert trace.status == "diverged"
    assert "solver.max_contact_force_n" in trace.reason
    # The trace stops before the offending sample and every kept force is within the limit.
    assert 0 < len(trace) < 1001
    assert np.all(np.hypot(*trace.contact_force[:, :2].T) <= 1.0)


def test_a_trace_is_unchanged_by_the_next_rollout_on_the_same_scene(scene):
    hole = scene.config.hole
    first = scene.rollout(
        straight_line(
            robot_for_tip(scene, hole.x_m - 0.03, hole.top_y_m + 0.01),
            robot_for_tip(scene, hole.x_m - 0.02, hole.top_y_m + 0.01),
        )
    )
    kept = {name: getattr(first, name).copy() for name in ("time_s", "q_robot", "q_peg_top")}
    # A rollout that ends in contact, then one in free flight: nothing of the first leaks into
    # the second (Drake's sampled contact output is reset), nor of the second into the first.
    into_hole = scene.rollout(
        straight_line(
            robot_for_tip(scene, hole.x_m - 0.001, hole.top_y_m + 0.001),
            robot_for_tip(scene, hole.x_m - 0.001, hole.y_m + 0.003),
        )
    )
    assert np.any(into_hole.contact_force[-1, :2] != 0.0)
    free = scene.rollout(
        straight_line(
            robot_for_tip(scene, hole.x_m - 0.03, hole.top_y_m + 0.01),
            robot_for_tip(scene, hole.x_m - 0.02, hole.top_y_m + 0.01),
        )
    )
    assert np.all(free.contact_force == 0.0)
    for name, values in kept.items():
        assert np.array_equal(getattr(first, name), values), name


def test_a_rollout_that_diverges_is_rerun_once_at_the_retry_step():
    # A spring twice as stiff as Table 4's: the explicit spring is unstable at 2 ms (its limit
    # scales as 1/sqrt(k): 2.5 ms -> 1.8 ms) and stable at 1 ms.
    stiff = TWO_MS.replace(spring__stiffness=(2000.0, 2000.0, 2.0))
    no_retry = PegInHoleScene(stiff.replace(solver__retry_time_step_s=0.0))
    hole = stiff.hole
    robot = straight_line(
        robot_for_tip(no_retry, hole.x_m - 0.03, hole.top_y_m + 0.01),
        robot_for_tip(no_retry, hole.x_m - 0.02, hole.top_y_m + 0.01),
    )
    failed = no_retry.rollout(robot)
    assert failed.status == "diverged" and failed.time_step_s == 0.002
    retried = PegInHoleScene(stiff).rollout(robot)
    assert retried.ok and retried.time_step_s == 0.001
    # The rerun's trace is sampled at the configured step: the 1 ms rollout's every other sample.
    fine = PegInHoleScene(stiff.replace(solver__time_step_s=0.001, solver__retry_time_step_s=0.0))
    reference = fine.rollout(robot)
    assert len(retried) == len(robot.times_s) == (len(reference) + 1) // 2
    assert np.array_equal(retried.time_s, reference.time_s[::2])
    assert np.array_equal(retried.q_peg_bottom, reference.q_peg_bottom[::2])


def test_a_trajectory_ending_between_float_grid_points_runs_to_its_end(scene):
    # linspace's 3.3 lies just below 6600 × 0.5 ms in floating point, where Drake's last step is
    # due: the rollout must still take that step and log its sample.
    hole = scene.config.hole
    start = robot_for_tip(scene, hole.x_m - 0.03, hole.top_y_m + 0.01)
    assert scene.config.solver.time_step_s == 0.0005
    times = np.linspace(0.0, 3.3, 6601)
    assert times[-1] < 6600 * 0.0005
    robot = RobotTrajectory(times, np.tile(start, (times.size, 1)))
    trace = scene.rollout(robot)
    assert trace.ok, trace.reason
    assert len(trace) == 6601 and trace.time_s[-1] == pytest.approx(3.3)


def _fail_once_at(scene: PegInHoleScene, t_s: float, reason: str = "injected") -> None:
    """Make the interval of ``scene`` that ends at ``t_s`` report a divergence (after running)."""
    advance = scene._advance

    def failing(t):
        part, found = advance(t)
        return part, found or (reason if abs(t - t_s) < 1e-9 else "")

    scene._advance = failing


def _fine_scene_calls(scene: PegInHoleScene) -> list[float]:
    """Build the retry scene now and record the end of every interval it runs."""
    fine = scene._retry_scene()
    calls: list[float] = []
    advance = fine._advance
    fine._advance = lambda t: (calls.append(t), advance(t))[1]
    return calls


def _sideways_above_the_hole(scene: PegInHoleScene) -> RobotTrajectory:
    """A free-flight robot path: 10 mm across, the tip 10 mm above the hole's top surface."""
    hole = scene.config.hole
    return straight_line(
        robot_for_tip(scene, hole.x_m - 0.03, hole.top_y_m + 0.01),
        robot_for_tip(scene, hole.x_m - 0.02, hole.top_y_m + 0.01),
    )


def test_only_the_interval_that_diverged_is_rerun_at_the_retry_step():
    config = TWO_MS
    plain = PegInHoleScene(config)
    robot = _sideways_above_the_hole(plain)
    reference = plain.rollout(robot)
    assert reference.ok and reference.time_step_s == 0.002
    scene = PegInHoleScene(config)
    fine_intervals = _fine_scene_calls(scene)
    _fail_once_at(scene, 0.5)
    trace = scene.rollout(robot)
    assert trace.ok and trace.time_step_s == 0.001
    assert fine_intervals == [0.5]
    assert np.array_equal(trace.time_s, reference.time_s)
    before = trace.time_s <= 0.25
    rerun = (trace.time_s > 0.25) & (trace.time_s <= 0.5)
    # Up to the failed interval's start the rollout is the 2 ms one, sample for sample; the
    # interval itself and what follows differ from it (1 ms there) by a discretisation error.
    assert np.array_equal(trace.q_peg_top[before], reference.q_peg_top[before])
    assert not np.array_equal(trace.q_peg_top[rerun], reference.q_peg_top[rerun])
    assert np.allclose(trace.q_peg_top[~before], reference.q_peg_top[~before], atol=1e-4)
    # The 1 ms rerun of that interval alone, from the 2 ms state at 0.25 s: its samples match.
    fine = scene._retry_scene()
    fine._start(robot, _state_at(plain, robot, 0.25))
    part, reason = fine._advance(0.5)
    assert reason == ""
    assert np.array_equal(trace.q_peg_top[rerun], part.state[1::2, :3])


def _state_at(scene: PegInHoleScene, robot: RobotTrajectory, t_s: float):
    scene._start(robot, _Snapshot.at_rest(robot.poses[0]))
    scene._advance(t_s)
    return scene._snapshot()


def test_the_interval_retry_runs_with_point_contact():
    # Point-contact results name the scene's geometry: nothing of them may cross to the retry
    # scene (it raised "GeometryId ... not known to this plant" once).
    config = TWO_MS.replace(solver__contact_model="point")
    hole = config.hole
    scene = PegInHoleScene(config)
    robot = straight_line(
        robot_for_tip(scene, hole.x_m - 0.001, hole.top_y_m + 0.001),
        robot_for_tip(scene, hole.x_m - 0.001, hole.y_m + 0.003),
    )
    _fail_once_at(scene, 1.5)
    trace = scene.rollout(robot)
    assert trace.ok and trace.time_step_s == 0.001, trace.reason
    # The rerun interval starts in contact.
    assert np.any(trace.contact_force[np.isclose(trace.time_s, 1.25), :2] != 0.0)


def test_an_interval_that_diverges_again_at_the_retry_step_ends_the_rollout():
    scene = PegInHoleScene(TWO_MS)
    robot = _sideways_above_the_hole(scene)
    fine_intervals = _fine_scene_calls(scene)
    _fail_once_at(scene, 0.75, "coarse failure")
    _fail_once_at(scene._retry_scene(), 0.75, "fine failure")
    trace = scene.rollout(robot)
    assert trace.status == "diverged" and trace.time_step_s == 0.001
    assert trace.reason == "at the 1 ms retry: fine failure (at 2 ms: coarse failure)"
    assert fine_intervals == [0.75]
    # Nothing after the failed interval was simulated.
    assert trace.time_s[-1] == pytest.approx(0.75)


def test_penetration_depth_of_peg_corners(scene):
    hole = scene.config.hole
    upright_in_hole = [hole.x_m, hole.y_m + 0.001 + scene.config.peg.length_m / 2, 0.0]
    assert scene.penetration_depth(upright_in_hole)[0] == 0.0
    into_right_wall = [hole.x_m + 0.002, hole.y_m + 0.005 + scene.config.peg.length_m / 2, 0.0]
    expected = 0.002 - (hole.diameter_m - scene.config.peg.diameter_m) / 2
    assert scene.penetration_depth(into_right_wall)[0] == pytest.approx(expected, rel=1e-6)
    into_left_wall = [hole.x_m - 0.003, hole.y_m + 0.005 + scene.config.peg.length_m / 2, 0.0]
    assert scene.penetration_depth(into_left_wall)[0] == pytest.approx(expected + 0.001, rel=1e-6)
    below_bottom = [hole.x_m, hole.y_m - 0.0007 + scene.config.peg.length_m / 2, 0.0]
    assert scene.penetration_depth(below_bottom)[0] == pytest.approx(0.0007, rel=1e-6)
    # A tilted peg whose side cuts through the chamfer edge: its corners are clear, the edge is not.
    tilted = [hole.x_m, hole.y_m + 0.005 + scene.config.peg.length_m / 2, -0.2]
    assert scene.penetration_depth(tilted)[0] > 2e-4
