"""Tests of the ask/tell black-box optimizers (paper eq. 12-13 and pycma)."""

import numpy as np
import pytest

from pih.planning.optimizers import OPTIMIZER_NAMES, EliteAveraging, OptimizerConfig, make_optimizer

DIMENSION = 10
TARGET = np.linspace(-1.0, 1.0, DIMENSION)


def sphere(samples: np.ndarray) -> np.ndarray:
    return np.sum((np.atleast_2d(samples) - TARGET) ** 2, axis=1)


def minimize(name: str, cost, iterations: int) -> float:
    # Elite averaging has no step-size adaptation of its own: it needs the decay to converge.
    decay = 0.95 if name == "elite_averaging" else 1.0
    config = OptimizerConfig(name=name, sigma=0.5, sigma_decay=decay)
    optimizer = make_optimizer(config, np.zeros(DIMENSION))
    for _ in range(iterations):
        samples = optimizer.ask()
        assert samples.shape == (config.population_size, DIMENSION)
        optimizer.tell(samples, cost(samples))
    return float(sphere(optimizer.mean)[0])


@pytest.mark.parametrize("name", OPTIMIZER_NAMES)
def test_minimizes_shifted_sphere(name: str) -> None:
    initial = float(sphere(np.zeros(DIMENSION))[0])
    assert minimize(name, sphere, iterations=100) < 1e-3 * initial


@pytest.mark.parametrize("name", OPTIMIZER_NAMES)
def test_minimizes_noisy_quadratic(name: str) -> None:
    noise = np.random.default_rng(123)
    initial = float(sphere(np.zeros(DIMENSION))[0])

    def noisy(samples: np.ndarray) -> np.ndarray:
        return sphere(samples) + noise.normal(0.0, 0.05, len(samples))

    assert minimize(name, noisy, iterations=100) < 0.05 * initial


def test_elite_fraction_one_gives_the_sample_mean() -> None:
    optimizer = make_optimizer(OptimizerConfig(elite_fraction=1.0), np.zeros(DIMENSION))
    samples = optimizer.ask()
    optimizer.tell(samples, sphere(samples))
    np.testing.assert_allclose(optimizer.mean, samples.mean(axis=0), rtol=1e-12)


def test_uses_ceil_n_r_elites() -> None:
    config = OptimizerConfig(population_size=10, elite_fraction=0.25)
    assert config.n_elites == 3
    assert OptimizerConfig(population_size=50, elite_fraction=0.14).n_elites == 7
    optimizer = make_optimizer(config, np.zeros(DIMENSION))
    assert isinstance(optimizer, EliteAveraging)
    samples = optimizer.ask()
    costs = np.array([5.0, 0.3, 9.0, 0.1, 7.0, 0.2, 8.0, 6.0, 4.0, 3.0])
    optimizer.tell(samples, costs)
    np.testing.assert_array_equal(optimizer.last_elite_indices, [3, 5, 1])
    np.testing.assert_allclose(optimizer.mean, samples[[1, 3, 5]].mean(axis=0), rtol=1e-12)


def test_failed_rollouts_rank_worst() -> None:
    config = OptimizerConfig(population_size=5, elite_fraction=0.4)
    optimizer = make_optimizer(config, np.zeros(DIMENSION))
    samples = optimizer.ask()
    optimizer.tell(samples, np.array([np.nan, 2.0, -np.inf, 1.0e9, np.inf]))
    np.testing.assert_array_equal(optimizer.last_elite_indices, [1, 3])


@pytest.mark.parametrize("costs", [[np.nan, 1.0, np.inf, 2.0] * 2 + [0.5, -np.inf], [np.nan] * 10])
def test_cma_accepts_failed_rollouts(costs: list[float]) -> None:
    optimizer = make_optimizer(OptimizerConfig(name="cma_es", sigma=0.5), np.zeros(DIMENSION))
    optimizer.tell(optimizer.ask(), np.array(costs))
    assert np.all(np.isfinite(optimizer.mean)) and np.isfinite(optimizer.sigma)


def ask_sequence(name: str, seed: int, iterations: int = 5) -> np.ndarray:
    optimizer = make_optimizer(
        OptimizerConfig(name=name, sigma=0.5, seed=seed), np.zeros(DIMENSION)
    )
    asked = []
    for iteration in range(iterations):
        np.random.seed(1000 * seed + iteration)  # global state must not matter
        samples = optimizer.ask()
        asked.append(samples)
        optimizer.tell(samples, sphere(samples))
    return np.array(asked)


@pytest.mark.parametrize("name", OPTIMIZER_NAMES)
def test_same_seed_same_samples_different_seed_different_samples(name: str) -> None:
    np.testing.assert_array_equal(ask_sequence(name, seed=7), ask_sequence(name, seed=7))
    assert not np.allclose(ask_sequence(name, seed=7), ask_sequence(name, seed=8))


@pytest.mark.parametrize("name", OPTIMIZER_NAMES)
def test_sigma_decay_applied_after_each_tell(name: str) -> None:
    def sigmas(decay: float) -> list[float]:
        config = OptimizerConfig(name=name, sigma=0.5, sigma_decay=decay)
        optimizer = make_optimizer(config, np.zeros(DIMENSION))
        assert optimizer.sigma == 0.5
        samples = optimizer.ask()
        optimizer.tell(samples, sphere(samples))
        return optimizer.sigma

    assert sigmas(0.9) == pytest.approx(0.9 * sigmas(1.0), rel=1e-12)
    if name == "elite_averaging":
        assert sigmas(1.0) == 0.5


@pytest.mark.parametrize(
    ("config", "field"),
    [
        (OptimizerConfig(name="nelder_mead"), "elite_averaging"),
        (OptimizerConfig(population_size=0), "population_size"),
        (OptimizerConfig(name="cma_es", population_size=1), "population_size"),
        (OptimizerConfig(elite_fraction=0.0), "elite_fraction"),
        (OptimizerConfig(elite_fraction=1.5), "elite_fraction"),
        (OptimizerConfig(sigma=0.0), "sigma"),
        (OptimizerConfig(sigma_decay=1.1), "sigma_decay"),
        (OptimizerConfig(seed=-1), "seed"),
    ],
)
def test_bad_config_names_the_field(config: OptimizerConfig, field: str) -> None:
    with pytest.raises(ValueError, match=field):
        config.validate()
    with pytest.raises(ValueError, match=field):
        make_optimizer(config, np.zeros(DIMENSION))


@pytest.mark.parametrize("name", OPTIMIZER_NAMES)
def test_tell_rejects_wrong_shapes(name: str) -> None:
    optimizer = make_optimizer(OptimizerConfig(name=name), np.zeros(DIMENSION))
    samples = optimizer.ask()
    with pytest.raises(ValueError, match="samples"):
        optimizer.tell(samples[:, :-1], sphere(samples))
    with pytest.raises(ValueError, match="costs"):
        optimizer.tell(samples, sphere(samples)[:-1])


def test_rejects_bad_initial_mean() -> None:
    with pytest.raises(ValueError, match="initial_mean"):
        make_optimizer(OptimizerConfig(), np.array([0.0, np.nan]))
