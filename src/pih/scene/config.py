"""The scene's configuration: peg, hole, material, solver and spring (paper §2, Table 4), and
the hole's geometry in the paper's (x, y) plane. Plain dataclasses with no Drake dependency, so
the workflow, the planner and the plots read them without building a simulator; the values and
the measurements behind them are in docs/simulation.md.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import NDArray

from pih.config import described, require, require_finite, require_positive
from pih.whitney.theory import WhitneyParams

PAPER = WhitneyParams()
"""The paper's Whitney parameters (docs/whitney.md): the one source of the scene's paper values."""

# --------------------------------------------------------------------------------------------
# Configuration


@dataclass(frozen=True)
class PegConfig:
    """The peg: a planar rectangle with its planar joint at the top centre P1."""

    diameter_m: float = described(
        PAPER.peg_diameter_m, "peg diameter d, of the paper's Whitney parameters (docs/whitney.md)"
    )
    length_m: float = described(
        PAPER.compliance_length_m,
        "Whitney's L_g: the spring point P1 (peg top centre) is this far above the tip P2",
    )
    # 10 mm keeps the peg's hydroelastic patches well inside the 20 mm-thick hole walls.
    thickness_m: float = described(0.010, "out-of-plane extrusion of the planar peg (chosen)")
    density_kg_per_m3: float = described(7850.0, "peg density: steel, the paper's material")

    def validate(self, prefix: str = "") -> None:
        require_positive(
            self, ("diameter_m", "length_m", "thickness_m", "density_kg_per_m3"), prefix
        )

    @property
    def mass_kg(self) -> float:
        return self.density_kg_per_m3 * self.diameter_m * self.length_m * self.thickness_m

    @property
    def inertia_about_top_kg_m2(self) -> float:
        """Moment of inertia about the out-of-plane axis through P1."""
        m, d, ell = self.mass_kg, self.diameter_m, self.length_m
        return m * (d**2 + ell**2) / 12.0 + m * (ell / 2.0) ** 2


@dataclass(frozen=True)
class HoleConfig:
    """The hole: two rigid chamfered walls and a rigid bottom, welded to the world."""

    # 0.033 mm diametral clearance with the default peg.
    diameter_m: float = described(
        PAPER.hole_diameter_m, "hole diameter D, of the paper's Whitney parameters"
    )
    # 10 mm puts the entrance at y = 0 with the hole frame H at y_H = −0.01 m (paper Table 4).
    depth_m: float = described(0.010, "depth from the hole's top surface to its bottom")
    chamfer_angle_deg: float = described(
        math.degrees(PAPER.chamfer_angle_rad), "Whitney's chamfer angle α (docs/whitney.md)"
    )
    # Not given by the paper; 2.5 mm captures a 2 mm offset (ε0' ≈ 1.98 mm ≤ W) even with a
    # 1 mm fillet, which takes ≈0.4 mm off the chamfer's lower end.
    chamfer_width_m: float = described(PAPER.chamfer_width_m, "horizontal chamfer width W")
    # A sharp rigid edge gives the chamfer normal while the peg is already in one-point contact
    # on the wall (Fz ≈ 4|Fx|, unphysical; docs/simulation.md). 0.1 mm keeps the chamfer whole
    # (a 1 mm fillet clips its lower end; docs/validation.md).
    fillet_radius_m: float = described(
        1.0e-4, "radius of the rounded chamfer–wall edge (0: a sharp edge; not in the paper)"
    )
    fillet_facets: int = described(9, "straight segments of the fillet's arc")
    # Large enough that a peg landing beside the hole (the planner starts 30–40 mm away) still
    # rests on the hole's top surface.
    wall_width_m: float = described(0.060, "width of each wall block beyond the chamfer")
    thickness_m: float = described(
        0.020, "out-of-plane extrusion of the walls (wider than the peg)"
    )
    x_m: float = described(
        0.0, "x of the hole frame H, the bottom centre of the hole (paper Table 4: x_H = 0)"
    )
    y_m: float = described(-0.010, "y of the hole frame H (paper Table 4: y_H = −0.01 m)")

    def validate(self, prefix: str = "") -> None:
        require_positive(self, ("diameter_m", "depth_m", "wall_width_m", "thickness_m"), prefix)
        require(
            0.0 < self.chamfer_angle_deg < 90.0,
            prefix + "chamfer_angle_deg",
            "an angle in (0, 90) degrees",
            self.chamfer_angle_deg,
        )
        require(
            math.isfinite(self.chamfer_width_m) and self.chamfer_width_m >= 0.0,
            prefix + "chamfer_width_m",
            "a width >= 0 m",
            self.chamfer_width_m,
        )
        require(
            self.chamfer_height_m < self.depth_m,
            prefix + "chamfer_width_m",
            f"a chamfer shallower than the hole (height W·tan α < depth_m = {self.depth_m})",
            self.chamfer_width_m,
        )
        require(
            math.isfinite(self.fillet_radius_m) and self.fillet_radius_m >= 0.0,
            prefix + "fillet_radius_m",
            "a radius >= 0 m",
            self.fillet_radius_m,
        )
        require(
            self.fillet_facets >= 1, prefix + "fillet_facets", "an integer >= 1", self.fillet_facets
        )
        require_finite(prefix + "x_m", self.x_m)
        require_finite(prefix + "y_m", self.y_m)

    @property
    def chamfer_height_m(self) -> float:
        return self.chamfer_width_m * math.tan(math.radians(self.chamfer_angle_deg))

    @property
    def top_y_m(self) -> float:
        return self.y_m + self.depth_m

    @property
    def entrance_y_m(self) -> float:
        """Whitney's hole entrance: the bottom of the chamfer, where insertion depth ℓ = 0."""
        return self.top_y_m - self.chamfer_height_m


@dataclass(frozen=True)
class MaterialConfig:
    """The peg's contact material: hydroelastic or point-contact stiffness, dissipation, friction."""

    # 20 GPa is the validation rule's choice: the only admissible modulus in Whitney's
    # quasi-static limit (200 GPa's Table 2 errors reach 117 %; docs/validation.md).
    hydroelastic_modulus_pa: float = described(
        2.0e10,
        "hydroelastic modulus of the compliant peg (paper §2.4: Young's modulus of steel, 200 GPa)",
    )
    hunt_crossley_dissipation_s_per_m: float = described(
        30.0, "Hunt–Crossley dissipation (paper §2.4)"
    )
    friction: float = described(PAPER.friction, "friction coefficient μ, steel on steel (Table 4)")
    # It acts like a thinner clearance (16.5 µm per side): with 5 µm (which TAMSI needed) the
    # validation's r(F_x) falls to 0.01 and planning rollouts insert half as often; `lagged`
    # needs none (docs/simulation.md, docs/validation.md).
    margin_m: float = described(0.0, "Drake's hydroelastic margin (not in the paper)")
    # Chosen so the point-contact penetration at the validation's forces (≤ 25 N) stays ≤ 25 µm,
    # about the per-side clearance.
    point_stiffness_n_per_m: float = described(
        1.0e6,
        "contact stiffness of the point-contact model (solver.contact_model point, the comparison "
        "beyond the paper; not in the paper)",
    )

    def validate(self, prefix: str = "") -> None:
        require_positive(self, ("hydroelastic_modulus_pa", "point_stiffness_n_per_m"), prefix)
        names = ("hunt_crossley_dissipation_s_per_m", "friction", "margin_m")
        require_positive(self, names, prefix, allow_zero=True)


MIN_TIME_STEP_S = 1.0e-5
MAX_TIME_STEP_S = 2.0e-3
ContactModel = Literal["hydroelastic", "hydroelastic_with_fallback", "point"]
DiscreteApproximation = Literal["sap", "similar", "lagged"]


@dataclass(frozen=True)
class SolverConfig:
    """The simulator: time step, Drake's contact model and solver, and divergence limits."""

    # At 1 ms and 2 ms pegs that jam at the chamfer at finer steps slide in; 0.5 ms agrees with
    # a 0.0625 ms reference on 233 of 240 recorded planning rollouts but not with its own half
    # step (benchmarks/step_convergence.py, docs/simulation.md). The explicit spring diverges at
    # 2.5 ms.
    time_step_s: float = described(5.0e-4, "the simulator's time step")
    retry_time_step_s: float = described(
        2.5e-4,
        "a check interval that diverges at time_step_s (an overlap above the limit as a tilted "
        "peg snaps off the chamfer edge) is run once more at this finer step from its start "
        "state, sampled at time_step_s, and the rollout goes on at time_step_s; 0: no retry",
    )
    # `lagged` gets every validation offset through with the best agreement, and ran 295
    # planning rollouts with no failure (docs/simulation.md).
    discrete_contact_approximation: DiscreteApproximation = described(
        "lagged",
        "Drake's discrete contact solver (MultibodyPlantConfig.discrete_contact_approximation)",
        removed={"tamsi": "Drake 1.57 removed TAMSI (its measurements: docs/validation.md)"},
    )
    contact_model: ContactModel = described(
        "hydroelastic",
        "Drake's contact model: hydroelastic (the paper's), hydroelastic with point-contact "
        "fallback, or point contact",
    )
    stiction_tolerance_m_per_s: float = described(
        1.0e-4,
        "Drake's regularised-friction stiction tolerance: the slip speed below which friction is "
        "treated as sticking (MultibodyPlantConfig.stiction_tolerance; Drake's default 1e-4 m/s)",
    )
    max_contact_force_n: float = described(
        1.0e3,
        "a rollout whose contact force exceeds this is diverged (the paper's forces are ≤ 25 N)",
    )
    max_distance_from_hole_m: float = described(
        0.2, "a rollout whose peg centre leaves a disc of this radius around H is diverged"
    )
    # Steady hydroelastic contact at 200 GPa overlaps by µm; a tilted peg snapping off the chamfer
    # edge at ~0.2 m/s can miss contact for one 2 ms step and overlap 0.2–0.8 mm before it
    # recovers (measured); those transients are kept (see the trace's penetration_m) and not
    # flagged.
    max_penetration_m: float = described(
        1.0e-3,
        "a rollout whose peg and hole geometries overlap by more than this is diverged (gross "
        "tunnelling)",
    )
    check_interval_s: float = described(
        0.25,
        "how often (simulated time) the running rollout is checked for divergence: the stretch "
        "rerun at retry_time_step_s when it diverged",
    )
    log_contact_patches: bool = described(
        True,
        "count the contact patches carrying force each step (a Python callback: ≈10–20 % slower)",
    )
    # Off gives the same trajectory ≈5 % faster, but the force log then evaluates the geometry at
    # a non-finite state before the per-step monitor can stop the rollout, and Drake's assertion
    # ends the process (docs/simulation.md).
    sampled_output_ports: bool = described(
        True,
        "Drake's sampled output ports (MultibodyPlantConfig.use_sampled_output_ports): on, the "
        "logged contact force is the step's own result",
    )

    def validate(self, prefix: str = "") -> None:
        require(
            MIN_TIME_STEP_S <= self.time_step_s <= MAX_TIME_STEP_S,
            prefix + "time_step_s",
            f"a step in [{MIN_TIME_STEP_S:g}, {MAX_TIME_STEP_S:g}] s (the explicit spring "
            "diverges at 2.5 ms, measured; see docs/simulation.md)",
            self.time_step_s,
        )
        retry = self.retry_time_step_s
        require(
            retry == 0
            or (
                MIN_TIME_STEP_S <= retry < self.time_step_s
                and abs(self.time_step_s / retry - round(self.time_step_s / retry)) < 1e-9
            ),
            prefix + "retry_time_step_s",
            f"0 (no retry) or a step >= {MIN_TIME_STEP_S:g} s that divides time_step_s = "
            f"{self.time_step_s:g} s a whole number of times",
            self.retry_time_step_s,
        )
        steps = self.check_interval_s / self.time_step_s
        require(
            steps >= 1 - 1e-9 and abs(steps - round(steps)) < 1e-9,
            prefix + "check_interval_s",
            f"a whole number (>= 1) of time steps of {self.time_step_s:g} s (a rerun interval "
            "starts on a step)",
            self.check_interval_s,
        )
        names = (
            "time_step_s",
            "stiction_tolerance_m_per_s",
            "max_contact_force_n",
            "max_distance_from_hole_m",
            "max_penetration_m",
            "check_interval_s",
        )
        require_positive(self, names, prefix)


@dataclass(frozen=True)
class SpringConfig:
    """The virtual-robot spring–damper between the robot frame and the peg top P1 (eq. 7–10)."""

    stiffness: tuple[float, float, float] = described(
        (PAPER.k_x_n_per_m, PAPER.k_x_n_per_m, PAPER.k_theta_nm_per_rad),
        "k_x N/m, k_y N/m, k_θ N·m/rad (paper Table 4: 1000, 1000, 1)",
    )
    # The spring is explicit (evaluated at the start of each step); full critical damping was
    # unstable above 0.83 ms while 0.3 was stable at 1–2 ms (docs/simulation.md).
    damping_ratio: float = described(
        0.3, "damping as a fraction of each DoF's critical damping 2·sqrt(k·m) (not in the paper)"
    )

    def validate(self, prefix: str = "") -> None:
        require(
            all(math.isfinite(k) and k > 0 for k in self.stiffness),
            prefix + "stiffness",
            "three finite values > 0 (k_x N/m, k_y N/m, k_θ N·m/rad)",
            self.stiffness,
        )
        require(
            math.isfinite(self.damping_ratio) and self.damping_ratio >= 0,
            prefix + "damping_ratio",
            "a finite value >= 0",
            self.damping_ratio,
        )


@dataclass(frozen=True)
class SceneConfig:
    """The simulated scene (paper §2, Table 4; docs/simulation.md)."""

    peg: PegConfig = field(default_factory=PegConfig)
    hole: HoleConfig = field(default_factory=HoleConfig)
    material: MaterialConfig = field(default_factory=MaterialConfig)
    solver: SolverConfig = field(default_factory=SolverConfig)
    spring: SpringConfig = field(default_factory=SpringConfig)

    def validate(self, prefix: str = "") -> None:
        for section in ("peg", "hole", "material", "solver", "spring"):
            getattr(self, section).validate(f"{prefix}{section}.")
        require(
            self.peg.diameter_m < self.hole.diameter_m,
            prefix + "peg.diameter_m",
            f"a peg narrower than the hole (hole.diameter_m = {self.hole.diameter_m})",
            self.peg.diameter_m,
        )
        require(
            self.material.margin_m <= 0.25 * (self.hole.diameter_m - self.peg.diameter_m),
            prefix + "material.margin_m",
            "a margin at most half the per-side clearance (D − d)/4",
            self.material.margin_m,
        )

    def replace(self, **sections: object) -> SceneConfig:
        """Copy with whole sections or ``section__field`` values replaced."""
        updates: dict[str, dict[str, object]] = {}
        direct: dict[str, object] = {}
        for key, value in sections.items():
            if "__" in key:
                section, name = key.split("__", 1)
                updates.setdefault(section, {})[name] = value
            else:
                direct[key] = value
        for section, values in updates.items():
            direct[section] = dataclasses.replace(getattr(self, section), **values)
        new = dataclasses.replace(self, **direct)
        new.validate()
        return new

    @property
    def spring_damping(self) -> NDArray[np.float64]:
        """D = ζ · 2·sqrt(k·m) per DoF, with m the peg mass (x, y) and inertia about P1 (θ)."""
        k = np.asarray(self.spring.stiffness)
        m = np.array([self.peg.mass_kg, self.peg.mass_kg, self.peg.inertia_about_top_kg_m2])
        return self.spring.damping_ratio * 2.0 * np.sqrt(k * m)

    def simulator_settings(self) -> dict[str, object]:
        """The settings recorded in provenance."""
        return {
            "time_step_s": self.solver.time_step_s,
            "contact_model": self.solver.contact_model,
            "discrete_contact_approximation": self.solver.discrete_contact_approximation,
            "hydroelastic_modulus_pa": self.material.hydroelastic_modulus_pa,
            "margin_m": self.material.margin_m,
            "hunt_crossley_dissipation_s_per_m": self.material.hunt_crossley_dissipation_s_per_m,
            "friction": self.material.friction,
        }


# --------------------------------------------------------------------------------------------
# Geometry


def wall_profile(hole: HoleConfig) -> NDArray[np.float64]:
    """Counter-clockwise (x, y) outline of the right wall in the hole frame H (x = 0 on the axis,
    y = 0 at the bottom): convex, with the chamfer cut into its top inner edge and the
    chamfer–wall edge rounded by a polygonal fillet. The left wall is its mirror image."""
    R = hole.diameter_m / 2.0
    top, bottom = hole.depth_m, 0.0
    outer = R + hole.chamfer_width_m + hole.wall_width_m
    alpha = math.radians(hole.chamfer_angle_deg)
    chamfer_bottom = top - hole.chamfer_height_m
    points: list[tuple[float, float]] = [(R, bottom), (outer, bottom), (outer, top)]
    points.append((R + hole.chamfer_width_m, top))
    # Fillet between the chamfer face (direction down-inwards) and the vertical wall. The
    # interior angle there is 90° + α; the arc turns by 90° − α.
    turn = math.pi / 2 - alpha
    r = hole.fillet_radius_m
    if r > 0 and hole.chamfer_width_m > 0 and turn > 0:
        tangent = r * math.tan(turn / 2)
        tangent = min(tangent, 0.5 * hole.chamfer_width_m / math.cos(alpha), 0.5 * chamfer_bottom)
        r = tangent / math.tan(turn / 2)
        centre = (R + r, chamfer_bottom - tangent)
        # Arc from the chamfer tangency point to the wall tangency point (angles of the
        # radius vector measured from +x): chamfer normal points up-left (π − (π/2 − α)… ).
        start = math.pi / 2 + alpha
        stop = math.pi
        for a in np.linspace(start, stop, hole.fillet_facets + 1):
            points.append((centre[0] + r * math.cos(a), centre[1] + r * math.sin(a)))
    else:
        points.append((R, chamfer_bottom))
    return np.array(points)


def hole_outline(hole: HoleConfig) -> list[NDArray[np.float64]]:
    """World (x, y) outlines of the two walls: the right wall profile and its mirror."""
    right = wall_profile(hole) + [hole.x_m, hole.y_m]
    left = right * [-1.0, 1.0] + [2.0 * hole.x_m, 0.0]
    return [np.vstack([w, w[:1]]) for w in (right, left)]
