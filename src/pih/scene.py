"""Planar peg-in-hole scene in Drake with hydroelastic contact (paper §2.1–2.2).

A steel peg moves in the vertical (x, y) plane with 3 DoF (x, y, θ). Its planar joint sits at the
peg top centre P1, so the joint coordinates *are* q_P1 and the virtual-robot spring of eq. 7–10
is a joint-space spring–damper τ = K(q_R − q_P1) + D(q̇_R − q̇_P1), built from Drake's C++
``MatrixGain`` and ``Adder`` systems feeding the plant's applied generalized force. The hole
is two rigid chamfered walls (convex prisms with a small fillet at the chamfer–wall edge) and a
rigid bottom, welded to the world; the peg is compliant-hydroelastic (rigid–compliant is Drake's
best-conditioned hydroelastic pairing). Gravity is off, as in Whitney's theory.

Drake's world is x–z with z up; the paper's (x, y, θ) map to Drake (x, z, rotation about −y).
One :class:`PegInHoleScene` builds the diagram once; :meth:`PegInHoleScene.rollout` resets it for
each robot trajectory, so thousands of rollouts share one process and one diagram.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from pydrake.common import MemoryFile
from pydrake.geometry import (
    AddCompliantHydroelasticProperties,
    AddContactMaterial,
    AddRigidHydroelasticProperties,
    Box,
    Convex,
    InMemoryMesh,
    ProximityProperties,
)
from pydrake.math import RigidTransform, RotationMatrix
from pydrake.multibody.plant import (
    AddMultibodyPlant,
    CoulombFriction,
    MultibodyPlantConfig,
)
from pydrake.multibody.tree import FixedOffsetFrame, PlanarJoint, SpatialInertia, UnitInertia
from pydrake.systems.analysis import Simulator
from pydrake.systems.framework import DiagramBuilder, EventStatus
from pydrake.systems.primitives import (
    Adder,
    LogVectorOutput,
    MatrixGain,
    TrajectorySource,
)
from pydrake.trajectories import PiecewisePolynomial

from pih.config import require, require_finite, require_positive
from pih.frames import offset_along_axis, spring_energy, spring_force

# --------------------------------------------------------------------------------------------
# Configuration


@dataclass(frozen=True)
class PegConfig:
    # d of the paper's Whitney parameters (docs/whitney.md).
    diameter_m: float = 12.672e-3
    # Whitney's L_g = 45 mm: the spring point P1 (peg top centre) is 45 mm above the tip P2.
    length_m: float = 0.045
    # Out-of-plane extrusion of the planar peg. Not in the paper; 10 mm keeps the peg's
    # hydroelastic patches well inside the 20 mm-thick hole walls.
    thickness_m: float = 0.010
    # Steel (the paper's material).
    density_kg_per_m3: float = 7850.0

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
    # D of the paper's Whitney parameters: 0.033 mm diametral clearance with the default peg.
    diameter_m: float = 12.705e-3
    # Top surface to bottom. 10 mm puts the entrance at y = 0 with the hole frame H at
    # y_H = −0.01 m (paper Table 4).
    depth_m: float = 0.010
    # Whitney's α (docs/whitney.md).
    chamfer_angle_deg: float = 45.0
    # Horizontal chamfer width W. Not given by the paper; 2.5 mm captures a 2 mm offset
    # (ε0' ≈ 1.98 mm ≤ W) even after the fillet takes ≈0.4 mm off the chamfer's lower end.
    chamfer_width_m: float = 2.5e-3
    # Round the chamfer–wall edge: a sharp rigid edge gives the chamfer normal while the peg is
    # already in one-point contact on the wall (Fz ≈ 4|Fx|, unphysical; docs/simulation.md).
    fillet_radius_m: float = 1.0e-3
    fillet_facets: int = 9
    # Width of each wall block beyond the chamfer; large enough that a peg landing beside the
    # hole (the planner starts 30–40 mm away) still rests on the hole's top surface.
    wall_width_m: float = 0.060
    # Out-of-plane extrusion of the walls; wider than the peg.
    thickness_m: float = 0.020
    # Hole frame H = bottom centre of the hole (paper Table 4: x_H = 0, y_H = −0.01 m, θ_H = 0).
    x_m: float = 0.0
    y_m: float = -0.010

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
    # Paper §2.4: steel, hydroelastic modulus = Young's modulus 200 GPa.
    hydroelastic_modulus_pa: float = 2.0e11
    # Paper §2.4: 30 s/m.
    hunt_crossley_dissipation_s_per_m: float = 30.0
    # Paper Table 4 (steel on steel).
    friction: float = 0.6
    # Hydroelastic margin. Not in the paper; 200 GPa needs one (docs/simulation.md); it acts like a
    # thinner clearance (16.5 µm per side). Measured at the 1 mm validation offset: 10 µm moves
    # the start of two-point contact from 2.9 to 3.3 mm (theory 2.3 mm) and doubles the final
    # angle error; 1–2 µm lose solver convergence at 1.5–2 mm offsets; 5 µm is the compromise.
    margin_m: float = 5.0e-6
    # Point-contact model only (the "beyond the paper" comparison): contact stiffness.
    # Not in the paper; chosen so the point-contact penetration at the validation's forces
    # (≤ 25 N) stays ≤ 25 µm, about the per-side clearance.
    point_stiffness_n_per_m: float = 1.0e6

    def validate(self, prefix: str = "") -> None:
        require_positive(self, ("hydroelastic_modulus_pa", "point_stiffness_n_per_m"), prefix)
        names = ("hunt_crossley_dissipation_s_per_m", "friction", "margin_m")
        require_positive(self, names, prefix, allow_zero=True)


MIN_TIME_STEP_S = 1.0e-5
MAX_TIME_STEP_S = 2.0e-3
ContactModel = Literal["hydroelastic", "hydroelastic_with_fallback", "point"]
DiscreteApproximation = Literal["tamsi", "sap", "similar", "lagged"]


@dataclass(frozen=True)
class SolverConfig:
    # 2 ms with TAMSI gave the same final depth as 0.5 and 1 ms (to 0.01 mm) at
    # 200 GPa, 2.5–4× faster.
    time_step_s: float = 2.0e-3
    # TAMSI is the only approximation that ran the planner's rollouts without contact-force
    # blow-ups (measured in docs/simulation.md), though Drake 1.51 deprecates it.
    discrete_contact_approximation: DiscreteApproximation = "tamsi"
    contact_model: ContactModel = "hydroelastic"
    # A rollout whose contact force exceeds this is "diverged" (the paper's forces are ≤ 25 N).
    max_contact_force_n: float = 1.0e3
    # ...or whose peg centre leaves a disc of this radius around the hole frame.
    max_distance_from_hole_m: float = 0.2
    # ...or whose peg and hole geometries overlap by more than this (gross tunnelling). Steady
    # hydroelastic contact at 200 GPa overlaps by µm; a tilted peg snapping off the chamfer edge
    # at ~0.2 m/s can miss contact for one 2 ms step and overlap 0.2–0.8 mm before it recovers
    # (measured); those transients are kept (see the trace's penetration_m) and not flagged.
    max_penetration_m: float = 1.0e-3
    # How often (simulated time) the running rollout is checked for divergence.
    check_interval_s: float = 0.25
    # Count contact patches carrying force each step (a Python callback: ≈10–20 % slower).
    log_contact_patches: bool = True

    def validate(self, prefix: str = "") -> None:
        require(
            MIN_TIME_STEP_S <= self.time_step_s <= MAX_TIME_STEP_S,
            prefix + "time_step_s",
            f"a step in [{MIN_TIME_STEP_S:g}, {MAX_TIME_STEP_S:g}] s (the explicit spring "
            "diverges at 2.5 ms, measured; see docs/simulation.md)",
            self.time_step_s,
        )
        require(
            self.check_interval_s >= self.time_step_s,
            prefix + "check_interval_s",
            f"an interval >= time_step_s = {self.time_step_s:g} s",
            self.check_interval_s,
        )
        names = (
            "time_step_s",
            "max_contact_force_n",
            "max_distance_from_hole_m",
            "max_penetration_m",
            "check_interval_s",
        )
        require_positive(self, names, prefix)


@dataclass(frozen=True)
class SpringConfig:
    # Paper Table 4: k_x = k_y = 1000 N/m, k_θ = 1 N·m/rad.
    stiffness: tuple[float, float, float] = (1000.0, 1000.0, 1.0)
    # Damping as a fraction of each DoF's critical damping 2·sqrt(k·m). Not in the paper; the
    # spring is explicit (evaluated at the start of each step); full critical damping was
    # unstable above 0.83 ms while 0.3 was stable at 1–2 ms (docs/simulation.md).
    damping_ratio: float = 0.3

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
# Robot trajectory and rollout trace


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

    @property
    def ok(self) -> bool:
        return self.status == "ok"

    def __len__(self) -> int:
        return int(self.time_s.size)


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


def _extruded_obj(profile: NDArray[np.float64], thickness: float) -> str:
    """OBJ text of a planar (x, z) polygon extruded ±thickness/2 along Drake's y."""
    n = len(profile)
    lines = []
    for y in (-thickness / 2, thickness / 2):
        lines += [f"v {x:.9g} {y:.9g} {z:.9g}" for x, z in profile]
    # Side faces (quads split into triangles); caps as fans. Convex only needs the vertices,
    # but a valid closed mesh keeps other tools happy.
    for i in range(n):
        j = (i + 1) % n
        a, b, c, d = i + 1, j + 1, j + 1 + n, i + 1 + n
        lines += [f"f {a} {b} {c}", f"f {a} {c} {d}"]
    lines += [f"f 1 {i + 1} {i}" for i in range(n - 1, 1, -1)]
    lines += [f"f {n + 1} {n + i} {n + i + 1}" for i in range(2, n)]
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------------------------
# Scene


class PegInHoleScene:
    """The Drake diagram for one :class:`SceneConfig`, built once and reused across rollouts."""

    def __init__(self, config: SceneConfig | None = None) -> None:
        self.config = config or SceneConfig()
        self.config.validate()
        self._build()
        profile = self._wall_profile = wall_profile(self.config.hole)
        edges = np.roll(profile, -1, axis=0) - profile
        self._wall_normals = (
            np.column_stack([edges[:, 1], -edges[:, 0]]) / np.hypot(*edges.T)[:, None]
        )
        self._wall_offsets = np.sum(self._wall_normals * profile, axis=1)

    # -- construction -------------------------------------------------------------------------
    def _build(self) -> None:
        cfg = self.config
        builder = DiagramBuilder()
        plant_config = MultibodyPlantConfig(
            time_step=cfg.solver.time_step_s,
            discrete_contact_approximation=cfg.solver.discrete_contact_approximation,
            contact_model=cfg.solver.contact_model,
        )
        plant, _ = AddMultibodyPlant(plant_config, builder)
        plant.mutable_gravity_field().set_gravity_vector([0.0, 0.0, 0.0])
        self._register_hole(plant)
        peg_instance = plant.AddModelInstance("peg")
        peg = plant.AddRigidBody(
            "peg",
            peg_instance,
            SpatialInertia(
                cfg.peg.mass_kg,
                np.zeros(3),
                UnitInertia.SolidBox(cfg.peg.diameter_m, cfg.peg.thickness_m, cfg.peg.length_m),
            ),
        )
        self._register_peg(plant, peg)
        # Joint frames rotated +90° about x: the joint's plane is Drake's x–z, its coordinates
        # are (x, z, rotation about −y) = the paper's (x, y, θ) of P1.
        to_plane = RotationMatrix.MakeXRotation(math.pi / 2)
        frame_on_world = plant.AddFrame(
            FixedOffsetFrame("planar_parent", plant.world_frame(), RigidTransform(to_plane))
        )
        frame_on_peg = plant.AddFrame(
            FixedOffsetFrame(
                "peg_top_P1",
                peg.body_frame(),
                RigidTransform(to_plane, [0, 0, cfg.peg.length_m / 2]),
            )
        )
        plant.AddJoint(PlanarJoint("peg_planar", frame_on_world, frame_on_peg))
        plant.Finalize()

        self._robot_source = builder.AddSystem(
            TrajectorySource(PiecewisePolynomial.FirstOrderHold([0.0, 1.0], np.zeros((3, 2))), 1)
        )
        self._robot_source.set_name("robot_trajectory")
        # The spring of eq. 7–10, τ = [K D](x_R − x_P1), stateless and evaluated at the start of
        # each step. (Drake's PidController adds a continuous integrator state, which turns every
        # discrete step into an error-controlled integration; measured in docs/simulation.md.)
        gains = np.hstack([np.diag(cfg.spring.stiffness), np.diag(self.config.spring_damping)])
        robot_term = builder.AddSystem(MatrixGain(gains))
        peg_term = builder.AddSystem(MatrixGain(-gains))
        spring = builder.AddSystem(Adder(2, 3))
        spring.set_name("virtual_robot_spring")
        builder.Connect(self._robot_source.get_output_port(), robot_term.get_input_port())
        builder.Connect(plant.get_state_output_port(peg_instance), peg_term.get_input_port())
        builder.Connect(robot_term.get_output_port(), spring.get_input_port(0))
        builder.Connect(peg_term.get_output_port(), spring.get_input_port(1))
        builder.Connect(spring.get_output_port(), plant.get_applied_generalized_force_input_port())

        period = cfg.solver.time_step_s
        self._state_log = LogVectorOutput(
            plant.get_state_output_port(peg_instance), builder, period
        )
        self._robot_log = LogVectorOutput(self._robot_source.get_output_port(), builder, period)
        self._contact_port = plant.get_generalized_contact_forces_output_port(peg_instance)
        self._contact_log = LogVectorOutput(self._contact_port, builder, period)
        self._diagram = builder.Build()
        self._plant = plant
        self._peg_instance = peg_instance
        self._simulator = Simulator(self._diagram)
        self._context = self._simulator.get_mutable_context()
        self._plant_context = plant.GetMyMutableContextFromRoot(self._context)
        self._patch_counts: list[tuple[float, int]] = []
        counts = self._patch_counts
        plant_context = self._plant_context
        contact_results = plant.get_contact_results_output_port()
        log_patches = cfg.solver.log_contact_patches
        # The plant's state [q_P1, v]; a reference into the context, valid across steps. Reading
        # three scalars is cheap; GetPositions copies and cost ≈100 µs a step (measured).
        state = plant_context.get_discrete_state_vector()

        def after_step(context):
            # A non-finite pose must stop the step loop here: the next step would hand it to
            # Drake's geometry, whose assertion aborts the whole process (measured at 2.5 ms).
            pose_sum = state.GetAtIndex(0) + state.GetAtIndex(1) + state.GetAtIndex(2)
            if not math.isfinite(pose_sum):  # NaN or ±inf in any coordinate
                return EventStatus.Failed(None, "non-finite peg state")
            if log_patches:
                count = _patches_with_force(contact_results.Eval(plant_context))
                counts.append((context.get_time(), count))
            return EventStatus.Succeeded()

        self._simulator.set_monitor(after_step)

    def _register_hole(self, plant) -> None:
        cfg = self.config
        props = self._proximity(rigid=True)
        profile = wall_profile(cfg.hole)
        obj = _extruded_obj(profile, cfg.hole.thickness_m)
        wall = Convex(InMemoryMesh(mesh_file=MemoryFile(obj, ".obj", "hole_wall")))
        world = plant.world_body()
        for side, sign in (("right", 1.0), ("left", -1.0)):
            # Mirror the left wall by rotating the right one 180° about Drake's z (vertical).
            rotation = RotationMatrix() if sign > 0 else RotationMatrix.MakeZRotation(math.pi)
            X = RigidTransform(rotation, [cfg.hole.x_m, 0.0, cfg.hole.y_m])
            plant.RegisterCollisionGeometry(world, X, wall, f"hole_wall_{side}", props)
        half_width = cfg.hole.diameter_m / 2 + cfg.hole.chamfer_width_m + cfg.hole.wall_width_m
        bottom = Box(2 * half_width, cfg.hole.thickness_m, 0.01)
        X_bottom = RigidTransform([cfg.hole.x_m, 0.0, cfg.hole.y_m - 0.005])
        plant.RegisterCollisionGeometry(world, X_bottom, bottom, "hole_bottom", props)

    def _register_peg(self, plant, peg) -> None:
        cfg = self.config
        shape = Box(cfg.peg.diameter_m, cfg.peg.thickness_m, cfg.peg.length_m)
        plant.RegisterCollisionGeometry(
            peg, RigidTransform(), shape, "peg_collision", self._proximity(rigid=False)
        )

    def _proximity(self, rigid: bool) -> ProximityProperties:
        material = self.config.material
        props = ProximityProperties()
        AddContactMaterial(
            dissipation=material.hunt_crossley_dissipation_s_per_m,
            point_stiffness=material.point_stiffness_n_per_m,
            friction=CoulombFriction(material.friction, material.friction),
            properties=props,
        )
        if rigid:
            AddRigidHydroelasticProperties(props)
        else:
            AddCompliantHydroelasticProperties(
                resolution_hint=1.0,
                hydroelastic_modulus=material.hydroelastic_modulus_pa,
                properties=props,
            )
        props.AddProperty("hydroelastic", "margin", material.margin_m)
        return props

    # -- geometry helpers ------------------------------------------------------------------
    def peg_top_from_bottom(self, q_bottom: ArrayLike) -> NDArray[np.float64]:
        """q_P1 of the peg whose tip P2 is at ``q_bottom``."""
        return offset_along_axis(q_bottom, self.config.peg.length_m)

    def peg_bottom_from_top(self, q_top: ArrayLike) -> NDArray[np.float64]:
        """q_P2 of the peg whose top P1 is at ``q_top``."""
        return offset_along_axis(q_top, -self.config.peg.length_m)

    def insertion_depth(self, q_bottom: ArrayLike) -> NDArray[np.float64]:
        """Whitney's ℓ: depth of P2 below the hole entrance (bottom of the chamfer)."""
        return self.config.hole.entrance_y_m - np.asarray(q_bottom, dtype=float)[..., 1]

    def penetration_depth(self, q_peg: ArrayLike) -> NDArray[np.float64]:
        """Deepest penetration (m, ≥ 0) of the peg's corners into the walls or the bottom, per pose."""
        q = np.atleast_2d(np.asarray(q_peg, dtype=float))
        half = np.array([self.config.peg.diameter_m, self.config.peg.length_m]) / 2
        c, s = np.cos(q[:, 2:3]), np.sin(q[:, 2:3])
        signs = np.array([[-1, -1], [1, -1], [1, 1], [-1, 1]]) * half  # (4, 2) in the peg frame
        corners = (
            np.stack(
                [
                    q[:, 0:1] + c * signs[:, 0] - s * signs[:, 1],
                    q[:, 1:2] + s * signs[:, 0] + c * signs[:, 1],
                ],
                axis=-1,
            )
            - self.hole_pose[:2]
        )  # (n, 4, 2) in the hole frame
        depth = np.maximum(0.0, -corners[..., 1])  # below the hole bottom
        for mirror in (1.0, -1.0):  # right wall, left wall (its mirror image)
            depth = np.maximum(
                depth,
                _depth_inside(self._wall_normals, self._wall_offsets, corners * [mirror, 1.0]),
            )
        # ...and the walls' vertices (chamfer edge, fillet) inside the peg rectangle.
        vertices = (
            np.vstack([self._wall_profile, self._wall_profile * [-1.0, 1.0]]) + self.hole_pose[:2]
        )
        rel = vertices[None, :, :] - q[:, None, :2]  # (n, m, 2) world offsets from the peg centre
        along_x = np.abs(c * rel[..., 0] + s * rel[..., 1])
        along_y = np.abs(-s * rel[..., 0] + c * rel[..., 1])
        inside = np.maximum(0.0, np.minimum(half[0] - along_x, half[1] - along_y))
        return np.maximum(depth.max(axis=1), inside.max(axis=1))

    @property
    def hole_pose(self) -> NDArray[np.float64]:
        """True hole frame H (bottom centre), q_H = (x_H, y_H, 0)."""
        return np.array([self.config.hole.x_m, self.config.hole.y_m, 0.0])

    # -- simulation ----------------------------------------------------------------------------
    def rollout(self, robot: RobotTrajectory) -> Trace:
        """Simulate the peg pulled by the robot trajectory q_R(t) (eq. 1); never raises on
        simulation failure: the trace then ends early with status ``diverged`` and a reason."""
        if not isinstance(robot, RobotTrajectory):
            raise TrajectoryError(f"rollout() takes a RobotTrajectory, got {type(robot).__name__}")
        cfg = self.config
        self._robot_source.UpdateTrajectory(
            PiecewisePolynomial.FirstOrderHold(robot.times_s, robot.poses.T)
        )
        context = self._context
        context.SetTime(0.0)
        self._diagram.SetDefaultContext(context)
        context.SetTime(0.0)
        self._plant.SetPositions(self._plant_context, self._peg_instance, robot.poses[0])
        self._plant.SetVelocities(self._plant_context, self._peg_instance, np.zeros(3))
        for log in (self._state_log, self._robot_log, self._contact_log):
            log.FindMutableLog(context).Clear()
        self._patch_counts.clear()
        self._simulator.Initialize()

        reason = ""
        t_end = robot.duration_s
        t = 0.0
        while t < t_end and not reason:
            t = min(t + cfg.solver.check_interval_s, t_end)
            try:
                self._simulator.AdvanceTo(t)
            except RuntimeError as error:
                reason = f"simulator error at t = {context.get_time():.4f} s: {error}".splitlines()[
                    0
                ]
                break
            reason = self._check_state(context.get_time())
        return self._trace(robot, "" if reason == "stop" else reason)

    def _check_state(self, t: float) -> str:
        """Stop a running rollout early on the divergence criteria (the full trace is checked
        again afterwards, sample by sample, to find the first bad step)."""
        cfg = self.config.solver
        q = self._plant.GetPositions(self._plant_context, self._peg_instance)
        v = self._plant.GetVelocities(self._plant_context, self._peg_instance)
        force = self._contact_port.Eval(self._plant_context)
        if not (np.all(np.isfinite(q)) and np.all(np.isfinite(v)) and np.all(np.isfinite(force))):
            return f"non-finite peg state or force at t = {t:.4f} s"
        q_peg = offset_along_axis(q, -self.config.peg.length_m / 2)
        if (
            np.hypot(force[0], force[1]) > cfg.max_contact_force_n
            or np.hypot(*(q_peg[:2] - self.hole_pose[:2])) > cfg.max_distance_from_hole_m
            or self.penetration_depth(q_peg)[0] > cfg.max_penetration_m
        ):
            return "stop"  # the reason is worded from the logged samples in _trace
        return ""

    def _trace(self, robot: RobotTrajectory, reason: str) -> Trace:
        cfg = self.config
        context = self._context
        state_log = self._state_log.FindLog(context)
        times = state_log.sample_times()
        state = state_log.data().T
        robot_q = self._robot_log.FindLog(context).data().T[:, :3]
        generalized = self._contact_log.FindLog(context).data().T
        q_top = state[:, :3]
        q_peg = offset_along_axis(q_top, -cfg.peg.length_m / 2)
        q_bottom = self.peg_bottom_from_top(q_top)
        # Generalized contact force of the planar joint = (F_x, F_y, moment about P1); shift the
        # moment to P: M_P = M_P1 + (r_P1 − r_P) × F.
        lever = q_top[:, :2] - q_peg[:, :2]
        moment_p = (
            generalized[:, 2] + lever[:, 0] * generalized[:, 1] - lever[:, 1] * generalized[:, 0]
        )
        contact = np.column_stack([generalized[:, 0], generalized[:, 1], moment_p])
        patches = self._aligned_patch_counts(times)

        finite = np.all(np.isfinite(state), axis=1) & np.all(np.isfinite(generalized), axis=1)
        too_strong = np.hypot(contact[:, 0], contact[:, 1]) > cfg.solver.max_contact_force_n
        too_far = (
            np.hypot(*(q_peg[:, :2] - self.hole_pose[:2]).T) > cfg.solver.max_distance_from_hole_m
        )
        penetration = self.penetration_depth(q_peg)
        too_deep = penetration > cfg.solver.max_penetration_m
        bad = ~finite | too_strong | too_far | too_deep
        n = times.size
        if np.any(bad):
            first = int(np.argmax(bad))
            if not reason:
                if not finite[first]:
                    reason = f"non-finite state or force at t = {times[first]:.4f} s"
                elif too_strong[first]:
                    reason = (
                        f"contact force {np.hypot(*contact[first, :2]):.3g} N exceeds "
                        f"solver.max_contact_force_n = {cfg.solver.max_contact_force_n:g} N "
                        f"at t = {times[first]:.4f} s"
                    )
                elif too_deep[first]:
                    reason = (
                        f"peg penetrated the hole by {1e3 * penetration[first]:.2f} mm "
                        f"(> solver.max_penetration_m = {cfg.solver.max_penetration_m:g} m) at t = {times[first]:.4f} s"
                    )
                else:
                    reason = (
                        f"peg left the scene (more than solver.max_distance_from_hole_m = "
                        f"{cfg.solver.max_distance_from_hole_m:g} m from the hole) at t = {times[first]:.4f} s"
                    )
            n = first
        elif (
            not reason
            and times.size
            and times[-1] < robot.duration_s - 0.5 * cfg.solver.time_step_s
        ):
            reason = f"simulation stopped at t = {times[-1]:.4f} s before the trajectory ended"
        cut = slice(0, n)
        return Trace(
            time_s=times[cut],
            q_robot=robot_q[cut],
            q_peg=q_peg[cut],
            q_peg_top=q_top[cut],
            q_peg_bottom=q_bottom[cut],
            contact_force=contact[cut],
            contact_patches=patches[cut],
            spring_force=spring_force(robot_q[cut], q_top[cut], cfg.spring.stiffness),
            spring_energy_j=spring_energy(robot_q[cut], q_top[cut], cfg.spring.stiffness),
            insertion_depth_m=self.insertion_depth(q_bottom[cut]),
            penetration_m=penetration[cut],
            status="diverged" if reason else "ok",
            reason=reason,
        )

    def _aligned_patch_counts(self, times: NDArray[np.float64]) -> NDArray[np.int64]:
        """Patch counts sampled at the logged times (−1 where not logged)."""
        if not self._patch_counts:
            return np.full(times.size, -1, dtype=np.int64)
        when, count = np.array(self._patch_counts).T
        index = np.clip(np.searchsorted(when, times - 1e-9), 0, when.size - 1)
        return count[index].astype(np.int64)


def _depth_inside(normals: NDArray, offsets: NDArray, points: NDArray) -> NDArray[np.float64]:
    """Depth of points inside a convex polygon given by outward edge normals n and offsets b
    (inside: n·p < b for every edge): min over edges of b − n·p, clipped at 0."""
    return np.maximum(0.0, np.min(offsets - points @ normals.T, axis=-1))


def _patches_with_force(results) -> int:
    """Contact patches (hydroelastic surfaces and point pairs) transmitting a non-zero force."""
    count = 0
    for i in range(results.num_hydroelastic_contacts()):
        if np.any(results.hydroelastic_contact_info(i).F_Ac_W().translational() != 0.0):
            count += 1
    for i in range(results.num_point_pair_contacts()):
        if np.any(results.point_pair_contact_info(i).contact_force() != 0.0):
            count += 1
    return count
