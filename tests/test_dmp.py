"""Tests of the 3-DoF DMP (paper Appendix B, eq. A1-A6)."""

import numpy as np
import pytest

from pih.planning.dmp import Dmp, DmpConfig

CONFIG = DmpConfig()
T = CONFIG.duration_s
TIMES_S = np.arange(0.0, 1.5 * T + 1e-9, 0.002)
START = np.array([0.0, 0.1, 0.0])
GOAL = np.array([0.05, 0.0, 0.2])


@pytest.fixture
def dmp() -> Dmp:
    return Dmp(CONFIG, START, GOAL)


def random_weights(dmp: Dmp, scale: float = 1.3, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).normal(0.0, scale, dmp.n_weights)


def test_zero_weights_start_at_start_and_converge_without_overshoot(dmp: Dmp) -> None:
    positions, velocities = dmp.rollout(np.zeros(dmp.n_weights), TIMES_S)
    np.testing.assert_array_equal(positions[0], START)
    np.testing.assert_array_equal(velocities[0], 0.0)
    np.testing.assert_allclose(positions[-1], GOAL, atol=1e-6)
    np.testing.assert_allclose(velocities[-1], 0.0, atol=1e-4)
    # Critically damped from rest: each DoF approaches its goal monotonically, never crossing it.
    progress = (positions - START) / (GOAL - START)
    assert np.all(progress <= 1.0 + 1e-12)
    assert np.all(np.diff(progress, axis=0) >= -1e-12)


@pytest.mark.parametrize(
    ("times_s", "atol"),
    [(TIMES_S, 1e-10), (np.linspace(0.0, 2.0 * T, 777), 1e-6)],  # on / mostly off the 1 ms grid
)
def test_zero_weights_match_closed_form_critically_damped_response(
    dmp: Dmp, times_s: np.ndarray, atol: float
) -> None:
    omega = np.sqrt(CONFIG.alpha * CONFIG.beta) / T
    free = (1.0 + omega * times_s) * np.exp(-omega * times_s)
    positions, velocities = dmp.rollout(np.zeros(dmp.n_weights), times_s)
    np.testing.assert_allclose(positions, GOAL + np.outer(free, START - GOAL), atol=atol)
    speed = -(omega**2) * times_s * np.exp(-omega * times_s)
    np.testing.assert_allclose(velocities, np.outer(speed, START - GOAL), atol=10.0 * atol)


def test_nonzero_weights_change_path_but_still_reach_goal(dmp: Dmp) -> None:
    free, _ = dmp.rollout(np.zeros(dmp.n_weights), TIMES_S)
    shaped, _ = dmp.rollout(random_weights(dmp), TIMES_S)
    assert np.all(np.abs(shaped - free).max(axis=0) > 0.05 * np.abs(dmp.amplitude))
    np.testing.assert_array_equal(shaped[0], START)
    np.testing.assert_allclose(shaped[-1], GOAL, atol=0.02 * np.abs(dmp.amplitude).max())
    late, _ = dmp.rollout(random_weights(dmp), np.array([4.0 * T]))
    np.testing.assert_allclose(late[0], GOAL, atol=1e-5)


def test_flat_and_matrix_weights_are_equivalent(dmp: Dmp) -> None:
    weights = random_weights(dmp)
    flat = dmp.rollout(weights, TIMES_S)
    matrix = dmp.rollout(weights.reshape(3, CONFIG.n_basis), TIMES_S)
    np.testing.assert_array_equal(flat[0], matrix[0])
    np.testing.assert_array_equal(flat[1], matrix[1])


def test_each_dof_is_driven_by_its_own_weight_row(dmp: Dmp) -> None:
    weights = np.zeros((3, CONFIG.n_basis))
    weights[1] = 2.0
    free, _ = dmp.rollout(np.zeros(dmp.n_weights), TIMES_S)
    shaped, _ = dmp.rollout(weights, TIMES_S)
    np.testing.assert_array_equal(shaped[:, [0, 2]], free[:, [0, 2]])
    assert np.abs(shaped[:, 1] - free[:, 1]).max() > 1e-3


@pytest.mark.parametrize("n_basis", [1, 5, 10, 200])
def test_basis_is_normalized_with_n_basis_functions(n_basis: int) -> None:
    dmp = Dmp(DmpConfig(n_basis=n_basis), START, GOAL)
    s = np.linspace(0.0, 1.0, 101)
    phi = dmp.basis(s)
    assert phi.shape == (len(s), n_basis)
    assert np.all(phi >= 0.0)
    np.testing.assert_allclose(phi.sum(axis=1), 1.0, rtol=1e-12)
    assert dmp.n_weights == 3 * n_basis


def test_basis_centres_are_evenly_spaced_in_time(dmp: Dmp) -> None:
    centre_times_s = np.linspace(0.0, T, CONFIG.n_basis)
    s = np.exp(-CONFIG.alpha_s * centre_times_s / T)
    np.testing.assert_array_equal(dmp.basis(s).argmax(axis=1), np.arange(CONFIG.n_basis))


def test_trajectory_is_continuous_in_the_goal(dmp: Dmp) -> None:
    weights = random_weights(dmp)
    base, _ = dmp.rollout(weights, TIMES_S)
    for step in (1e-3, 1e-5):
        moved = dmp.with_goal(GOAL + step * np.array([1.0, -1.0, 1.0]))
        np.testing.assert_array_equal(moved.start, START)
        assert moved.config is dmp.config
        shifted, _ = moved.rollout(weights, TIMES_S)
        assert np.abs(shifted - base).max() < 3.0 * step


def test_degenerate_amplitude_keeps_theta_forcing_alive() -> None:
    start = np.array([0.0, 0.1, 0.3])
    goal = np.array([0.05, 0.0, 0.3])
    dmp = Dmp(CONFIG, start, goal)
    assert dmp.amplitude[2] == CONFIG.min_amplitude[2]

    still, _ = dmp.rollout(random_weights(dmp).reshape(3, -1) * [[1.0], [1.0], [0.0]], TIMES_S)
    np.testing.assert_array_equal(still[:, 2], 0.3)

    theta_only = np.zeros((3, CONFIG.n_basis))
    theta_only[2] = 2.0
    turned, _ = dmp.rollout(theta_only, TIMES_S)
    assert np.abs(turned[:, 2] - 0.3).max() > 0.01
    assert abs(turned[-1, 2] - 0.3) < 0.02 * CONFIG.min_amplitude[2]


def test_min_amplitude_accepts_a_list() -> None:
    config = DmpConfig(min_amplitude=[0.01, 0.01, 0.1])
    assert config == CONFIG
    Dmp(config, START, GOAL).rollout(np.zeros(3 * CONFIG.n_basis), TIMES_S)


def test_amplitude_is_continuous_when_the_goal_crosses_the_start() -> None:
    dmp = Dmp(CONFIG, START, START + np.array([-1e-4, 0.5, -0.2]))
    np.testing.assert_allclose(dmp.amplitude, [CONFIG.min_amplitude[0], 0.5, 0.2])
    weights = random_weights(dmp)
    below, _ = Dmp(CONFIG, START, START + [-1e-6, 0.0, 0.0]).rollout(weights, TIMES_S)
    above, _ = Dmp(CONFIG, START, START + [+1e-6, 0.0, 0.0]).rollout(weights, TIMES_S)
    assert np.abs(above - below).max() < 1e-5


@pytest.mark.parametrize(
    ("config", "field"),
    [
        (DmpConfig(n_basis=0), "n_basis"),
        (DmpConfig(alpha=0.0), "alpha"),
        (DmpConfig(beta=-1.0), "beta"),
        (DmpConfig(alpha_s=float("nan")), "alpha_s"),
        (DmpConfig(duration_s=-3.5), "duration_s"),
        (DmpConfig(min_amplitude=(0.01, 0.0, 0.1)), "min_amplitude"),
    ],
)
def test_bad_config_names_the_field(config: DmpConfig, field: str) -> None:
    with pytest.raises(ValueError, match=field):
        config.validate()
    with pytest.raises(ValueError, match=field):
        Dmp(config, START, GOAL)


def test_bad_inputs_name_the_argument(dmp: Dmp) -> None:
    with pytest.raises(ValueError, match="goal"):
        dmp.with_goal([0.0, np.nan, 0.0])
    with pytest.raises(ValueError, match="start"):
        Dmp(CONFIG, [0.0, 0.0], GOAL)
    with pytest.raises(ValueError, match="weights"):
        dmp.rollout(np.zeros(dmp.n_weights - 1), TIMES_S)
    with pytest.raises(ValueError, match="weights"):
        dmp.rollout(np.zeros((CONFIG.n_basis, 3)), TIMES_S)
    with pytest.raises(ValueError, match="weights"):
        dmp.rollout(np.full(dmp.n_weights, np.inf), TIMES_S)
    with pytest.raises(ValueError, match="times_s"):
        dmp.rollout(np.zeros(dmp.n_weights), np.array([-0.1, 1.0]))
