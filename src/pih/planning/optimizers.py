"""Black-box optimizers of the DMP weights W behind one ask/tell interface (paper §3.1.1).

``ask`` returns the r weight vectors of one iteration, ``tell`` takes them back with their costs
J_inn (eq. 11). Failed rollouts are data, not errors: a NaN or +-inf cost ranks after every
finite cost (ties keep sample order), so a failed rollout is never an elite unless fewer
rollouts than elites succeeded (a batch with no finite cost gives a random step).

Every random draw comes from a ``numpy.random.Generator`` seeded with ``OptimizerConfig.seed``;
pycma is handed that generator as its ``randn`` option, so no global random state is used.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from numbers import Integral
from typing import Protocol

import cma
import numpy as np

from pih.config import described, require, require_positive

OPTIMIZER_NAMES = ("elite_averaging", "cma_es")


class Optimizer(Protocol):
    """Ask/tell black-box minimizer."""

    def ask(self) -> np.ndarray:
        """Samples to evaluate, shape (population_size, n)."""
        ...

    def tell(self, samples: np.ndarray, costs: np.ndarray) -> None:
        """Update from the asked samples and their costs (NaN/inf = failed, ranked worst)."""
        ...

    @property
    def mean(self) -> np.ndarray:
        """Current best estimate W*."""
        ...

    @property
    def sigma(self) -> float:
        """Current exploration scale."""
        ...


@dataclass(frozen=True)
class OptimizerConfig:
    """Optimizer choice and hyper-parameters (r, n and sigma_W of eq. 12-13)."""

    name: str = described(
        "elite_averaging", "elite_averaging (paper eq. 12–13) or cma_es (pycma's CMA-ES)"
    )
    population_size: int = described(10, "r, the rollouts per iteration (paper §3.2)")
    elite_fraction: float = described(
        0.3, "n, the fraction of the rollouts averaged as elites: ceil(n r) of them (eq. 13)"
    )
    sigma: float = described(
        0.3,
        "σ_W, the initial exploration scale of the weights (a pih.planning.dmp weight shifts the "
        "attractor by that fraction of the amplitude)",
    )
    sigma_decay: float = described(1.0, "σ is multiplied by this after every iteration")
    seed: int = described(
        0,
        "a second seed: with planner.seed and the run's sweep levels it seeds the run's streams "
        "(pih.planning.planner.run_seeds)",
    )

    def validate(self, prefix: str = "") -> None:
        """Raise :class:`~pih.config.ConfigError` naming the first key outside its range."""
        require(
            self.name in OPTIMIZER_NAMES, prefix + "name", f"one of {OPTIMIZER_NAMES}", self.name
        )
        min_population = 2 if self.name == "cma_es" else 1
        require(
            isinstance(self.population_size, Integral) and self.population_size >= min_population,
            prefix + "population_size",
            f"an integer >= {min_population} for {self.name}",
            self.population_size,
        )
        require(
            0.0 < self.elite_fraction <= 1.0,
            prefix + "elite_fraction",
            "a fraction in (0, 1]",
            self.elite_fraction,
        )
        require_positive(self, ("sigma",), prefix)
        require(
            0.0 < self.sigma_decay <= 1.0,
            prefix + "sigma_decay",
            "a factor in (0, 1]",
            self.sigma_decay,
        )
        require(
            isinstance(self.seed, Integral) and self.seed >= 0,
            prefix + "seed",
            "an integer >= 0",
            self.seed,
        )

    @property
    def n_elites(self) -> int:
        """ceil(n r), the size of the elite set of eq. 13 (n r rounded first, so that a float
        product such as 0.14 * 50 = 7.000000000000001 counts 7)."""
        return math.ceil(round(self.elite_fraction * self.population_size, 9))


def _checked_batch(
    samples: np.ndarray, costs: np.ndarray, population_size: int, dimension: int
) -> tuple[np.ndarray, np.ndarray]:
    """Validate a told batch; return it with non-finite costs replaced by a worse finite cost."""
    x = np.asarray(samples, dtype=float)
    c = np.asarray(costs, dtype=float)
    if x.shape != (population_size, dimension):
        raise ValueError(f"samples must have shape {(population_size, dimension)}, got {x.shape}")
    if c.shape != (population_size,):
        raise ValueError(f"costs must have shape {(population_size,)}, got {c.shape}")
    finite = np.isfinite(c)
    worst = c[finite].max() if finite.any() else 0.0
    return x, np.where(finite, c, worst + 1.0 + abs(worst))


class EliteAveraging:
    """Paper eq. 12-13: W^(r) ~ N(W*, sigma^2 I); W* <- mean of the ceil(n r) lowest-cost samples.

    After each ``tell`` sigma is multiplied by ``sigma_decay``; ``last_elite_indices`` holds the
    elite rows of the last told batch, best first.
    """

    def __init__(self, config: OptimizerConfig, initial_mean: np.ndarray) -> None:
        self.config = config
        self._mean = initial_mean.copy()
        self._sigma = config.sigma
        self._rng = np.random.default_rng(config.seed)
        self.last_elite_indices: np.ndarray | None = None

    def ask(self) -> np.ndarray:
        """Draw population_size samples from N(W*, sigma^2 I) (eq. 12)."""
        noise = self._rng.standard_normal((self.config.population_size, self._mean.size))
        return self._mean + self._sigma * noise

    def tell(self, samples: np.ndarray, costs: np.ndarray) -> None:
        """Average the elites (eq. 13), then decay sigma."""
        x, c = _checked_batch(samples, costs, self.config.population_size, self._mean.size)
        self.last_elite_indices = np.argsort(c, kind="stable")[: self.config.n_elites]
        self._mean = x[self.last_elite_indices].mean(axis=0)
        self._sigma *= self.config.sigma_decay

    @property
    def mean(self) -> np.ndarray:
        return self._mean.copy()

    @property
    def sigma(self) -> float:
        return self._sigma


class _GeneratorRandn:
    """pycma ``randn(lam, n)`` option drawing from a seeded numpy Generator."""

    def __init__(self, seed: int) -> None:
        self._rng = np.random.default_rng(seed)

    def __call__(self, lam: int, n: int) -> np.ndarray:
        return self._rng.standard_normal((lam, n))


class CmaEs:
    """pycma's CMA-ES with popsize r and default recombination (``elite_fraction`` unused).

    After each ``tell`` pycma's own step-size update is followed by sigma *= ``sigma_decay``.
    """

    def __init__(self, config: OptimizerConfig, initial_mean: np.ndarray) -> None:
        self.config = config
        self._es = cma.CMAEvolutionStrategy(
            initial_mean,
            config.sigma,
            {
                "popsize": config.population_size,
                "randn": _GeneratorRandn(config.seed),
                "seed": np.nan,  # seeding is done by the generator above
                "verbose": -9,
            },
        )

    def ask(self) -> np.ndarray:
        return np.asarray(self._es.ask())

    def tell(self, samples: np.ndarray, costs: np.ndarray) -> None:
        x, c = _checked_batch(samples, costs, self.config.population_size, self._es.N)
        self._es.tell(list(x), c.tolist())
        self._es.sigma *= self.config.sigma_decay

    @property
    def mean(self) -> np.ndarray:
        return np.array(self._es.mean)

    @property
    def sigma(self) -> float:
        return float(self._es.sigma)


def make_optimizer(config: OptimizerConfig, initial_mean: np.ndarray) -> Optimizer:
    """Validate ``config`` and build the optimizer it names, starting at W* = ``initial_mean``."""
    config.validate()
    mean = np.array(initial_mean, dtype=float)
    if mean.ndim != 1 or mean.size == 0 or not np.all(np.isfinite(mean)):
        raise ValueError(
            f"initial_mean must be a non-empty 1-D finite vector, got shape {mean.shape}"
        )
    optimizer_class = EliteAveraging if config.name == "elite_averaging" else CmaEs
    return optimizer_class(config, mean)
