"""Bilevel's outer level: the DMP goal from what the rollouts explored (paper eq. 15–16, and the
``deepest_explored`` rule); see docs/planner.md."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import NDArray

from pih.planning.config import PlannerConfig, SensingConfig
from pih.planning.costs import hole_distance

if TYPE_CHECKING:
    from pih.scene.trace import Trace


def outer_goal(
    explored_bottom: NDArray[np.float64], sensed_hole: NDArray[np.float64], sensing: SensingConfig
) -> NDArray[np.float64]:
    """arg min over explored P2 poses of J_out(q_P2, q̃_H) (eq. 15–16)."""
    return explored_bottom[
        int(np.argmin(0.5 * hole_distance(explored_bottom, sensed_hole, sensing)))
    ]


CLEAN_OVERLAP_M = 1.0e-4
"""deepest_explored only trusts P2 samples whose peg–hole overlap is at most this: a one-step
solver transient (up to 1 mm, docs/simulation.md) must not read as a pose inside the hole."""


class OuterLevel:
    """Bilevel's goal (eq. 15–16) from what the rollouts explored; ``goal`` is the P2 target.

    Q_P is the previous iteration's explored P2 poses (Algorithm 1); ``deepest`` is the deepest
    clean P2 pose of the whole run so far (used by the ``deepest_explored`` rule).
    """

    def __init__(self, config: PlannerConfig, hole_depth_m: float, hole_theta_rad: float) -> None:
        self.config = config
        self.hole_depth_m = hole_depth_m
        self.hole_theta_rad = hole_theta_rad  # θ_H, sensed exactly (eq. 16b)
        self.explored: NDArray[np.float64] | None = None
        self.deepest: NDArray[np.float64] | None = None

    def observe(
        self,
        traces: list[Trace],
        samples: slice,
        tips: list[NDArray[np.float64]] | None = None,
    ) -> None:
        """Q_P ← the P2 poses of this iteration's non-diverged rollouts at ``samples`` (as the
        planner observes them: ``tips``, one array per trace; default the simulator's); remember
        the deepest clean, near-upright one of the run."""
        if tips is None:
            tips = [t.q_peg_bottom[samples] for t in traces]
        ok = [(t, tip) for t, tip in zip(traces, tips, strict=True) if t.ok]
        if not ok:
            return
        self.explored = np.vstack([tip for _, tip in ok])
        upright = self.config.outer.max_tilt_rad
        candidates = np.vstack(
            [
                tip[
                    (t.penetration_m[samples] <= CLEAN_OVERLAP_M)
                    & (np.abs(tip[:, 2] - self.hole_theta_rad) <= upright)
                ]
                for t, tip in ok
            ]
        )
        if candidates.size:
            candidate = candidates[int(np.argmin(candidates[:, 1]))]
            if self.deepest is None or candidate[1] < self.deepest[1]:
                self.deepest = candidate

    def goal(self, sensed: NDArray[np.float64]) -> NDArray[np.float64]:
        """The P2 pose the DMP aims at: q̃_H until something was explored."""
        cfg = self.config.outer
        if self.explored is None:
            return sensed.copy()
        top_y = sensed[1] + self.hole_depth_m  # y_H is sensed exactly (eq. 16b)
        if (
            self.config.goal == "deepest_explored"
            and self.deepest is not None
            and self.deepest[1] < top_y - cfg.entry_depth_m
        ):
            return np.array([self.deepest[0], sensed[1], sensed[2]])  # along the hole's axis
        chosen = outer_goal(self.explored, sensed, self.config.sensing).copy()
        if cfg.goal_tilt == "sensed":
            chosen[2] = sensed[2]
        return chosen
