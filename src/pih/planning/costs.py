"""The inner cost J_inn (paper eq. 11) of a rollout, its terms, and their balance."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from pih.planning.config import COST_TERMS, CostConfig, SensingConfig
from pih.scene.frames import spring_energy


@dataclass(frozen=True)
class CostTerms:
    """The three terms of J_inn (eq. 11), weights applied."""

    regularization: float
    spring_energy: float
    hole_distance: float

    @property
    def values(self) -> NDArray[np.float64]:
        return np.array([self.regularization, self.spring_energy, self.hole_distance])


def inner_cost(
    weights: NDArray[np.float64],
    q_robot: NDArray[np.float64],
    q_peg_top: NDArray[np.float64],
    q_peg_bottom: NDArray[np.float64],
    sensed_hole: NDArray[np.float64],
    stiffness: tuple[float, float, float],
    costs: CostConfig,
    sensing: SensingConfig,
) -> CostTerms:
    """J_inn = α1‖W‖² + α2 Σ_t E_RP(t) + α3 Σ_t δq̃ᵀ Σ_H⁻¹ δq̃, δq̃ = q_P2 − q̃_H (eq. 11);
    the sums run over the cost samples given."""
    energy = spring_energy(q_robot, q_peg_top, stiffness)
    return CostTerms(
        regularization=costs.regularization * float(np.dot(weights, weights)),
        spring_energy=costs.spring_energy * float(np.sum(energy)),
        hole_distance=costs.hole_distance
        * float(np.sum(hole_distance(q_peg_bottom, sensed_hole, sensing))),
    )


def hole_distance(
    q_peg_bottom: NDArray[np.float64], sensed_hole: NDArray[np.float64], sensing: SensingConfig
) -> NDArray[np.float64]:
    """δq̃ᵀ Σ_H⁻¹ δq̃ per sample (the summand of eq. 11's third term; 2·J_out of eq. 15)."""
    delta = np.asarray(q_peg_bottom) - sensed_hole
    return np.sum(sensing.hole_precision * delta * delta, axis=-1)


class CostBalance:
    """eq. 11's total, optionally with each term divided by its first-iteration median."""

    def __init__(self, config: CostConfig, divisors: list[float] | None = None) -> None:
        """``divisors``: a run's recorded ones (its provenance's ``cost_divisors``), kept."""
        self.divisors = np.ones(len(COST_TERMS)) if divisors is None else np.asarray(divisors)
        self._fixed = config.balance == "none" or divisors is not None

    def totals(self, terms: list[CostTerms | None]) -> NDArray[np.float64]:
        """J_inn of each rollout (NaN for diverged ones); fixes the divisors on first use."""
        values = np.array([t.values if t else np.full(3, np.nan) for t in terms])
        if not self._fixed:
            medians = np.nanmedian(values, axis=0) if np.isfinite(values).any() else None
            if medians is not None and np.all(np.isfinite(medians) & (medians > 0)):
                self.divisors = medians
                self._fixed = True
        return np.sum(values / self.divisors, axis=1)
