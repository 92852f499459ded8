"""The validation experiment's configuration (``validation.experiment``) and its scene: no Drake.

:mod:`pih.validation.experiment` runs the experiment and compares it with Whitney's theory; this module is
what the study's config (:mod:`pih.study.config`) needs of it.
"""

from __future__ import annotations

from dataclasses import dataclass

from pih.config import described, require, require_positive
from pih.scene.config import SceneConfig


@dataclass(frozen=True)
class ValidationConfig:
    """The straight-down insertion at a fixed lateral offset (paper §2.4; docs/validation.md)."""

    # Whitney's theory is quasi-static: at 2 mm/s the wedged peg sticks and slips at the 2 mm
    # offset (r(F_x) 0.789), at 0.2 mm/s it does not (0.992), with the stiction tolerance scaled
    # down with the speed (the study's validation.scene_overrides; docs/validation.md). The 70 mm
    # descent (robot_depth_m) then takes 350 s simulated, about 3–4 min of wall time at 0.5 ms.
    speed_m_per_s: float = described(
        0.0002,
        "the robot's descent speed (not in the paper: \"moving downward slowly\"); Drake's "
        "stiction tolerance should scale with it (validation.scene_overrides)",
    )
    start_height_m: float = described(
        0.0005, "the peg tip starts this far above the hole's top surface"
    )
    # Past Whitney's line contact (41.2 mm) plus the F_z lag of the vertical spring (≤ 25 N /
    # 1000 N/m).
    robot_depth_m: float = described(
        0.07, "the robot descends until the spring's rest point is this deep"
    )
    hole_depth_m: float = described(
        0.08,
        "hole depth in the validation scene: deeper than the robot descends, so the tip never "
        "bottoms",
    )
    # Inside two-point contact for every paper offset (l2' ≥ 39.4 mm), where θ = cD/l is non-zero.
    final_depth_m: float = described(
        0.035, "depth where the final values (Table 2) are read and the correlation window ends"
    )
    final_window_m: float = described(
        0.001, "depth window over which the final simulated values are averaged"
    )

    def validate(self, prefix: str = "") -> None:
        names = (
            "speed_m_per_s",
            "start_height_m",
            "robot_depth_m",
            "hole_depth_m",
            "final_depth_m",
            "final_window_m",
        )
        require_positive(self, names, prefix)
        require(
            self.robot_depth_m <= self.hole_depth_m - 0.005,
            prefix + "robot_depth_m",
            f"at most hole_depth_m − 5 mm = {self.hole_depth_m - 0.005:g} m (the tip must not bottom)",
            self.robot_depth_m,
        )


def validation_scene_config(scene: SceneConfig, config: ValidationConfig) -> SceneConfig:
    """The scene with a hole deep enough for a full insertion (same entrance height)."""
    return scene.replace(
        hole__depth_m=config.hole_depth_m, hole__y_m=scene.hole.top_y_m - config.hole_depth_m
    )
