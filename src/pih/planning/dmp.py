"""Three-DoF discrete dynamic movement primitive for the planar robot frame q_R = (x, y, theta).

Implements Appendix B (eq. A1-A6) of Yang et al. (2023) in the standard Ijspeert form, one
independent transformation system per DoF d, all driven by one canonical system:

    tau^2 q_d'' = alpha * (beta * (g_d - q_d) - tau * q_d') + alpha * beta * s * a_d * phi(s)^T w_d   (A2-A4)
    tau s'      = -alpha_s * s,   s(0) = 1,   q(0) = q0,   q'(0) = 0

with tau = T = ``duration_s``, so that s(T) = exp(-alpha_s). The paper's A2,
(1/tau) q'' = f_t + h_W(s) s (g - q0), is this system written loosely: with the rate nu = 1/T it
reads q'' = nu^2 * alpha * beta * (g - q + s a h_W(s)) - nu * alpha * q'.

The forcing term carries the factor alpha * beta (a choice of units for W, not in the paper):
the forcing then moves the attractor from g to g + s * a * h_W(s), so a weight is the shift of the
attractor as a fraction of the movement amplitude. Weights of order 0.1-1 shape the path
visibly, which keeps the regularization alpha_1 ||W||^2 of eq. 11 on the scale of the other costs.

The forcing amplitude a_d replaces the paper's (g_d - q0_d) by max(|g_d - q0_d|, min_amplitude_d):
when start equals goal on a DoF (theta usually does) the forcing term is not silently switched
off, and because a_d is continuous in the goal, the bilevel outer level can move the goal across
the start (theta does, by the small tilts it explores) without the trajectory jumping. A weight's
sign therefore has a fixed meaning in world axes (+ pushes toward +x, +y, +theta during the
motion) rather than relative to the direction of travel.

The system is linear, so a rollout is a superposition of unit responses (the free response to
q0 - g and the response to each basis function's forcing), integrated once per configuration
with RK4 on a grid of step <= 1 ms and cached; a rollout is then one small matrix product.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from numbers import Integral

import numpy as np
from numpy.typing import ArrayLike

from pih.config import described, require, require_positive

N_DOF = 3
MAX_STEP_S = 1e-3
"""Upper bound on the internal integration step of the unit responses."""


@dataclass(frozen=True)
class DmpConfig:
    """DMP hyper-parameters (Appendix B); gains refer to eq. A3, ``alpha_s`` to the phase s."""

    n_basis: int = described(10, "Gaussian basis functions per DoF (eq. A5–A6)")
    alpha: float = described(25.0, "the gain α of eq. A3")
    beta: float = described(6.25, "the gain β of eq. A3")
    alpha_s: float = described(4.0, "the phase's decay α_s: s(T) = exp(−α_s)")
    duration_s: float = described(3.0, "the duration T (not in the paper; docs/planner.md)")
    min_amplitude: tuple[float, float, float] = described(
        (0.01, 0.01, 0.1),
        "per DoF (m, m, rad), the least forcing amplitude: a_d = max(|g_d − q0_d|, "
        "min_amplitude_d), so the forcing is not switched off when start equals goal",
    )

    def __post_init__(self) -> None:
        # Accept any sequence (e.g. a YAML list) but store a tuple: the config must stay hashable.
        amplitude = tuple(np.atleast_1d(self.min_amplitude).tolist())
        object.__setattr__(self, "min_amplitude", amplitude)

    def validate(self, prefix: str = "") -> None:
        """Raise :class:`~pih.config.ConfigError` naming the first key outside its range."""
        require(
            isinstance(self.n_basis, Integral) and self.n_basis >= 1,
            prefix + "n_basis",
            "an integer >= 1",
            self.n_basis,
        )
        require_positive(self, ("alpha", "beta", "alpha_s", "duration_s"), prefix)
        amplitude = np.asarray(self.min_amplitude, dtype=float)
        require(
            amplitude.shape == (N_DOF,) and bool(np.all(np.isfinite(amplitude) & (amplitude > 0))),
            prefix + "min_amplitude",
            f"{N_DOF} finite numbers > 0 (m, m, rad)",
            self.min_amplitude,
        )


def _normalized_basis(config: DmpConfig, s: np.ndarray) -> np.ndarray:
    """Normalized Gaussian basis phi(s) of eq. A5-A6, shape (len(s), n_basis).

    Centres are evenly spaced in time over [0, T], i.e. c_j = exp(-alpha_s * j / (n_basis - 1));
    each kernel's full width at half maximum equals the gap to its next centre (the last kernel
    reuses the previous gap). Normalization is done in the log domain, so rows always sum to 1.
    """
    if config.n_basis == 1:
        centres = widths = np.ones(1)  # phi(s) == 1 whatever the width
    else:
        centres = np.exp(-config.alpha_s * np.linspace(0.0, 1.0, config.n_basis))
        gaps = -np.diff(centres)
        widths = np.append(gaps, gaps[-1]) / (2.0 * math.sqrt(2.0 * math.log(2.0)))
    log_w = -0.5 * ((s[:, None] - centres) / widths) ** 2
    w = np.exp(log_w - log_w.max(axis=1, keepdims=True))
    return w / w.sum(axis=1, keepdims=True)


@functools.lru_cache(maxsize=16)
def _unit_responses(config: DmpConfig, n_periods: int) -> tuple[float, np.ndarray]:
    """Unit responses on a fine grid covering ``n_periods`` durations: (step_s, states).

    ``states`` has shape (n_steps + 1, 2, n_basis + 1): axis 1 is (position, velocity); column 0
    is the free response to an initial offset of 1, column 1 + j the response from rest to the
    forcing s * phi_j(s) (eq. A2 with a = 1 and w = e_j). Integrated with RK4: the step of the
    linear system is x_(k+1) = A x_k + c_k, with A and c_k obtained from the same RK4 formula.
    """
    tau = config.duration_s
    steps_per_period = math.ceil(tau / MAX_STEP_S)
    step_s = tau / steps_per_period
    n_steps = steps_per_period * n_periods
    system = np.array([[0.0, 1.0], [-config.alpha * config.beta / tau**2, -config.alpha / tau]])

    def forcing(times_s: np.ndarray) -> np.ndarray:
        s = np.exp(-config.alpha_s * times_s / tau)
        b = np.zeros((len(times_s), 2, config.n_basis + 1))
        b[:, 1, 1:] = s[:, None] * _normalized_basis(config, s) / tau**2
        return b

    def rk4_step(x: np.ndarray, b0: np.ndarray, b_mid: np.ndarray, b1: np.ndarray) -> np.ndarray:
        k1 = system @ x + b0
        k2 = system @ (x + 0.5 * step_s * k1) + b_mid
        k3 = system @ (x + 0.5 * step_s * k2) + b_mid
        k4 = system @ (x + step_s * k3) + b1
        return x + step_s / 6.0 * (k1 + 2.0 * k2 + 2.0 * k3 + k4)

    grid_s = step_s * np.arange(n_steps + 1)
    b = forcing(grid_s)
    b_mid = forcing(grid_s[:-1] + 0.5 * step_s)
    no_input = np.zeros((2, 2))
    transition = rk4_step(np.eye(2), no_input, no_input, no_input)
    inputs = rk4_step(np.zeros_like(b_mid), b[:-1], b_mid, b[1:])

    states = np.empty_like(b)
    states[0] = 0.0
    states[0, 0, 0] = 1.0
    for k in range(n_steps):
        states[k + 1] = transition @ states[k] + inputs[k]
    states.flags.writeable = False
    return step_s, states


def _as_pose(value: ArrayLike, name: str) -> np.ndarray:
    pose = np.array(value, dtype=float)
    if pose.shape != (N_DOF,) or not np.all(np.isfinite(pose)):
        raise ValueError(
            f"{name} must be {N_DOF} finite numbers (x m, y m, theta rad), got {value!r}"
        )
    pose.flags.writeable = False
    return pose


class Dmp:
    """DMP from ``start`` to ``goal`` (eq. A1): q_R(t) = DMP(W, t, q_R(0), q_R(T))."""

    def __init__(self, config: DmpConfig, start: ArrayLike, goal: ArrayLike) -> None:
        config.validate()
        self.config = config
        self.start = _as_pose(start, "start")
        self.goal = _as_pose(goal, "goal")
        # Per-DoF forcing amplitude a, replacing g - q0 of eq. A2 (see module docstring).
        delta = self.goal - self.start
        self.amplitude = np.maximum(np.abs(delta), config.min_amplitude)
        self.amplitude.flags.writeable = False

    @property
    def n_weights(self) -> int:
        """Number of weights, 3 * n_basis."""
        return N_DOF * self.config.n_basis

    def with_goal(self, goal: ArrayLike) -> Dmp:
        """Same configuration and start, new goal q_R(T) (set by the outer level, eq. 15-16)."""
        return Dmp(self.config, self.start, goal)

    def basis(self, s: np.ndarray) -> np.ndarray:
        """Normalized Gaussian basis phi(s) (eq. A5-A6), shape (len(s), n_basis)."""
        return _normalized_basis(self.config, np.asarray(s, dtype=float).reshape(-1))

    def rollout(self, weights: ArrayLike, times_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Positions and velocities, each (len(times_s), 3), of eq. A2 sampled at ``times_s``.

        ``weights`` is W of eq. A4, flat (3 * n_basis,) ordered x, y, theta, or (3, n_basis).
        ``times_s`` are finite times >= 0 (any order, may extend past T: the system keeps
        converging to the goal). Samples are exact on the internal grid (step T / ceil(T / 1 ms))
        and linearly interpolated between grid points (position error <= step^2 / 8 * max|q''|).
        """
        w = np.asarray(weights, dtype=float)
        shapes = ((self.n_weights,), (N_DOF, self.config.n_basis))
        if w.shape not in shapes or not np.all(np.isfinite(w)):
            raise ValueError(
                f"weights must be {self.n_weights} finite numbers, flat or shaped "
                f"({N_DOF}, {self.config.n_basis}); got shape {w.shape}"
            )
        t = np.asarray(times_s, dtype=float)
        if t.ndim != 1 or t.size == 0 or not np.all(np.isfinite(t) & (t >= 0.0)):
            raise ValueError("times_s must be a non-empty 1-D array of finite times >= 0 s")

        n_periods = max(1, math.ceil(t.max() / self.config.duration_s))
        step_s, states = _unit_responses(self.config, n_periods)
        t_steps = t / step_s
        index = np.minimum(np.floor(t_steps).astype(int), len(states) - 2)
        frac = (t_steps - index)[:, None, None]
        sampled = (1.0 - frac) * states[index] + frac * states[index + 1]

        forcing_gains = (
            (self.config.alpha * self.config.beta) * self.amplitude[:, None] * w.reshape(N_DOF, -1)
        )
        gains = np.vstack([self.start - self.goal, forcing_gains.T])
        positions = self.goal + sampled[:, 0, :] @ gains
        velocities = sampled[:, 1, :] @ gains
        return positions, velocities
