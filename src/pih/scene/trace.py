"""A rollout's input and output: the robot trajectory q_R(t) in, the :class:`Trace` out.

Plain data, no Drake: :class:`pih.scene.simulation.PegInHoleScene` makes traces, and the
output and study layers (``pih.records.outputs``, ``pih.validation.experiment``,
``pih.analysis.aggregate``) read and write them without importing the simulator.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import NDArray


class TrajectoryError(ValueError):
    """A robot trajectory is malformed (shape, NaN, time ordering)."""


@dataclass(frozen=True)
class RobotTrajectory:
    """q_R(t): robot-frame poses (x, y, θ) in m, m, rad at strictly increasing times from 0 s."""

    times_s: NDArray[np.float64]
    poses: NDArray[np.float64]

    def __post_init__(self) -> None:
        t = np.asarray(self.times_s, dtype=float)
        q = np.asarray(self.poses, dtype=float)
        if t.ndim != 1 or t.size < 2:
            raise TrajectoryError(
                f"times_s must be a 1-D array of >= 2 samples, got shape {t.shape}"
            )
        if q.shape != (t.size, 3):
            raise TrajectoryError(
                f"poses must have shape ({t.size}, 3) for (x, y, θ), got {q.shape}"
            )
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(q))):
            bad = np.argwhere(~np.isfinite(np.column_stack([t, q])))[0][0]
            raise TrajectoryError(f"trajectory has NaN/inf at sample {bad} (t = {t[bad]!r})")
        if t[0] != 0.0:
            raise TrajectoryError(f"times_s must start at 0 s, got {t[0]!r}")
        steps = np.diff(t)
        if np.any(steps <= 0):
            bad = int(np.argmax(steps <= 0))
            raise TrajectoryError(
                f"times_s must be strictly increasing; t[{bad + 1}] = {t[bad + 1]!r} <= t[{bad}] = {t[bad]!r}"
            )
        object.__setattr__(self, "times_s", t)
        object.__setattr__(self, "poses", q)

    @property
    def duration_s(self) -> float:
        return float(self.times_s[-1])


Status = Literal["ok", "diverged"]


@dataclass
class Trace:
    """Per-step record of one rollout (SI units; world frame; paper's (x, y, θ), y up).

    ``contact_force`` is (F_x N, F_y N, moment N·m about the peg centre P, counter-clockwise) of
    the contact on the peg; ``spring_force`` is eq. 10 at P1; ``insertion_depth_m`` is Whitney's ℓ,
    the depth of the tip P2 below the hole entrance (the bottom of the chamfer).
    """

    time_s: NDArray[np.float64]
    q_robot: NDArray[np.float64]
    q_peg: NDArray[np.float64]
    q_peg_top: NDArray[np.float64]
    q_peg_bottom: NDArray[np.float64]
    contact_force: NDArray[np.float64]
    contact_patches: NDArray[np.int64]
    spring_force: NDArray[np.float64]
    spring_energy_j: NDArray[np.float64]
    insertion_depth_m: NDArray[np.float64]
    penetration_m: NDArray[np.float64]
    status: Status = "ok"
    reason: str = ""
    # The step the rollout ran at: solver.time_step_s, or solver.retry_time_step_s when it
    # diverged at the configured step and was rerun (the arrays are then sampled every
    # time_step_s all the same).
    time_step_s: float = math.nan

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    def __len__(self) -> int:
        return int(self.time_s.size)
