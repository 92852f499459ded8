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
from dataclasses import dataclass

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

from pih.scene.config import SceneConfig, SolverConfig, wall_profile
from pih.scene.frames import offset_along_axis, spring_energy, spring_force
from pih.scene.trace import RobotTrajectory, Trace, TrajectoryError

# --------------------------------------------------------------------------------------------
# Geometry


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
        self._fine: PegInHoleScene | None = None  # the retry step's scene (see _retry)
        self._last_sample_time_s = -math.inf  # samples up to here are already taken (_advance)
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
            stiction_tolerance=cfg.solver.stiction_tolerance_m_per_s,
            use_sampled_output_ports=cfg.solver.sampled_output_ports,
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
        self._fresh_sampled_outputs = [
            self._plant_context.get_abstract_state(i).Clone()
            for i in range(self._plant_context.num_abstract_states())
        ]
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
                return EventStatus.Failed(plant, "non-finite peg state")
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
        simulation failure: the trace then ends early with status ``diverged`` and a reason.

        The rollout runs in check intervals (``solver.check_interval_s``). An interval that
        diverges is run once more at ``solver.retry_time_step_s`` from its start state, on a
        second diagram built on first use, and the rollout then goes on at the configured step
        (docs/simulation.md)."""
        if not isinstance(robot, RobotTrajectory):
            raise TrajectoryError(f"rollout() takes a RobotTrajectory, got {type(robot).__name__}")
        solver = self.config.solver
        self._start(robot, _Snapshot.at_rest(robot.poses[0]))
        parts: list[_Samples] = []
        reason = ""
        retried = False
        t, t_end = 0.0, robot.duration_s
        while t < t_end and not reason:
            t_next = t + solver.check_interval_s
            # The last interval runs a nanosecond past the end, so a step due at the end time
            # (k·h in floating point, which may lie just above a given t_end) is still taken.
            t_next = t_next if t_next < t_end else t_end + 1e-9
            before = self._snapshot()
            part, reason = self._advance(t_next)
            if reason and solver.retry_time_step_s > 0:
                retried = True
                part, reason = self._retry(robot, before, t_next, reason)
            parts.append(part)
            t = t_next
        return self._trace(robot, _Samples.concatenate(parts), reason, retried)

    def _start(self, robot: RobotTrajectory, snapshot: _Snapshot) -> None:
        """Load the robot trajectory and put the diagram in ``snapshot``'s state, logs empty."""
        self._robot_source.UpdateTrajectory(
            PiecewisePolynomial.FirstOrderHold(robot.times_s, robot.poses.T)
        )
        context = self._context
        context.SetTime(0.0)
        self._diagram.SetDefaultContext(context)
        self._restore(snapshot)
        self._last_sample_time_s = -math.inf if snapshot.time_s == 0.0 else snapshot.time_s
        for log in (self._state_log, self._robot_log, self._contact_log):
            log.FindMutableLog(context).Clear()
        self._patch_counts.clear()
        self._simulator.Initialize()

    def _snapshot(self) -> _Snapshot:
        return _Snapshot(
            time_s=self._context.get_time(),
            state=self._plant.GetPositionsAndVelocities(self._plant_context).copy(),
        )

    def _restore(self, snapshot: _Snapshot) -> None:
        # SetDefaultContext keeps the plant's sampled output ports (abstract state): without
        # resetting them the first logged contact force would be the previous rollout's last one.
        # They are never copied from the other scene (their contact results name that scene's
        # geometry); the sample they feed at the snapshot's time is the other scene's anyway.
        for index, value in enumerate(self._fresh_sampled_outputs):
            self._plant_context.get_mutable_abstract_state(index).SetFrom(value)
        self._context.SetTime(snapshot.time_s)
        self._plant.SetPositionsAndVelocities(self._plant_context, snapshot.state)

    def _advance(self, t_s: float) -> tuple[_Samples, str]:
        """Advance to ``t_s``: the new logged samples, cut before the first that diverged, and
        why it diverged ("" if it did not)."""
        context = self._context
        reason = ""
        try:
            self._simulator.AdvanceTo(t_s)
        except RuntimeError as error:
            reason = f"simulator error at t = {context.get_time():.4f} s: {error}".splitlines()[0]
        logs = [
            self._state_log.FindLog(context),
            self._robot_log.FindLog(context),
            self._contact_log.FindLog(context),
        ]
        times = logs[0].sample_times()
        new = times > self._last_sample_time_s
        # Copies: the logs' arrays are views into buffers the next interval overwrites.
        state, robot_q, generalized = (log.data().T[new].copy() for log in logs)
        times = times[new].copy()
        for log in logs:
            log.Clear()
        if times.size:
            self._last_sample_time_s = float(times[-1])
        part = _Samples(
            time_s=times,
            state=state,
            robot=robot_q[:, :3],
            generalized=generalized,
            patches=self._aligned_patch_counts(times),
            penetration=np.zeros(times.size),
        )
        self._patch_counts.clear()
        return self._check(part, reason)

    def _check(self, part: _Samples, reason: str) -> tuple[_Samples, str]:
        """Fill in the samples' penetration and cut them before the first that exceeds a
        divergence limit of ``solver`` (docs/simulation.md)."""
        q_peg = offset_along_axis(part.state[:, :3], -self.config.peg.length_m / 2)
        finite = np.all(np.isfinite(part.state), axis=1) & np.all(
            np.isfinite(part.generalized), axis=1
        )
        violations = self._limit_violations(q_peg, part.generalized[:, :2])
        part.penetration = violations["max_penetration_m"][1]
        bad = ~finite
        for exceeded, _ in violations.values():
            bad = bad | exceeded
        if not np.any(bad):
            return part, reason
        first = int(np.argmax(bad))
        reason = reason or _divergence_reason(
            part.time_s[first], finite[first], violations, first, self.config.solver
        )
        return part.take(slice(0, first)), reason

    def _retry(
        self, robot: RobotTrajectory, before: _Snapshot, t_s: float, first_reason: str
    ) -> tuple[_Samples, str]:
        """The interval from ``before`` to ``t_s`` once more at ``solver.retry_time_step_s``,
        sampled at the configured step; on success this diagram continues from its end."""
        solver = self.config.solver
        fine = self._retry_scene()
        fine._start(robot, before)
        part, fine_reason = fine._advance(t_s)
        steps = part.time_s / solver.time_step_s
        part = part.take(np.abs(steps - np.round(steps)) < 1e-6)
        if not fine_reason:
            self._restore(fine._snapshot())
            self._simulator.Initialize()
            self._last_sample_time_s = fine._last_sample_time_s
            return part, ""
        retry, step = (f"{1e3 * t:g} ms" for t in (solver.retry_time_step_s, solver.time_step_s))
        return part, f"at the {retry} retry: {fine_reason} (at {step}: {first_reason})"

    def _retry_scene(self) -> PegInHoleScene:
        """The diagram at ``solver.retry_time_step_s`` (with no retry of its own), built once."""
        if self._fine is None:
            solver = self.config.solver
            self._fine = PegInHoleScene(
                self.config.replace(
                    solver__time_step_s=solver.retry_time_step_s, solver__retry_time_step_s=0.0
                )
            )
        return self._fine

    def _limit_violations(
        self, q_peg: NDArray[np.float64], contact_xy_n: NDArray[np.float64]
    ) -> dict[str, tuple[NDArray[np.bool_], NDArray[np.float64]]]:
        """Per sample, each divergence limit of ``solver`` (docs/simulation.md): where it is
        exceeded, and the measured value."""
        cfg = self.config.solver
        force = np.hypot(contact_xy_n[:, 0], contact_xy_n[:, 1])
        distance = np.hypot(*(q_peg[:, :2] - self.hole_pose[:2]).T)
        penetration = self.penetration_depth(q_peg)
        return {
            "max_contact_force_n": (force > cfg.max_contact_force_n, force),
            "max_penetration_m": (penetration > cfg.max_penetration_m, penetration),
            "max_distance_from_hole_m": (distance > cfg.max_distance_from_hole_m, distance),
        }

    def _trace(
        self, robot: RobotTrajectory, samples: _Samples, reason: str, retried: bool
    ) -> Trace:
        cfg = self.config
        times = samples.time_s
        q_top = samples.state[:, :3]
        q_peg = offset_along_axis(q_top, -cfg.peg.length_m / 2)
        q_bottom = self.peg_bottom_from_top(q_top)
        generalized = samples.generalized
        # Generalized contact force of the planar joint = (F_x, F_y, moment about P1); shift the
        # moment to P: M_P = M_P1 + (r_P1 − r_P) × F.
        lever = q_top[:, :2] - q_peg[:, :2]
        moment_p = (
            generalized[:, 2] + lever[:, 0] * generalized[:, 1] - lever[:, 1] * generalized[:, 0]
        )
        if (
            not reason
            and times.size
            and times[-1] < robot.duration_s - 0.5 * cfg.solver.time_step_s
        ):
            reason = f"simulation stopped at t = {times[-1]:.4f} s before the trajectory ended"
        robot_q = samples.robot
        return Trace(
            time_s=times,
            q_robot=robot_q,
            q_peg=q_peg,
            q_peg_top=q_top,
            q_peg_bottom=q_bottom,
            contact_force=np.column_stack([generalized[:, 0], generalized[:, 1], moment_p]),
            contact_patches=samples.patches,
            spring_force=spring_force(robot_q, q_top, cfg.spring.stiffness),
            spring_energy_j=spring_energy(robot_q, q_top, cfg.spring.stiffness),
            insertion_depth_m=self.insertion_depth(q_bottom),
            penetration_m=samples.penetration,
            status="diverged" if reason else "ok",
            reason=reason,
            time_step_s=cfg.solver.retry_time_step_s if retried else cfg.solver.time_step_s,
        )

    def _aligned_patch_counts(self, times: NDArray[np.float64]) -> NDArray[np.int64]:
        """Patch counts sampled at the logged times (−1 where not logged)."""
        if not self._patch_counts:
            return np.full(times.size, -1, dtype=np.int64)
        when, count = np.array(self._patch_counts).T
        index = np.clip(np.searchsorted(when, times - 1e-9), 0, when.size - 1)
        return count[index].astype(np.int64)


@dataclass(frozen=True)
class _Snapshot:
    """The diagram's state at one time: the plant's [q_P1, v]."""

    time_s: float
    state: NDArray[np.float64]

    @staticmethod
    def at_rest(q_p1: NDArray[np.float64]) -> _Snapshot:
        return _Snapshot(0.0, np.concatenate([q_p1, np.zeros(3)]))


@dataclass
class _Samples:
    """Logged samples of a stretch of a rollout: times (n,), the plant's state [q_P1, v] (n, 6),
    robot pose (n, 3), generalized contact force at P1 (n, 3), patch counts and penetration (n,)."""

    time_s: NDArray[np.float64]
    state: NDArray[np.float64]
    robot: NDArray[np.float64]
    generalized: NDArray[np.float64]
    patches: NDArray[np.int64]
    penetration: NDArray[np.float64]

    def take(self, which: slice | NDArray[np.bool_]) -> _Samples:
        return _Samples(*(getattr(self, f.name)[which] for f in dataclasses.fields(self)))

    @staticmethod
    def concatenate(parts: list[_Samples]) -> _Samples:
        return _Samples(
            *(
                np.concatenate([getattr(p, f.name) for p in parts])
                for f in dataclasses.fields(_Samples)
            )
        )


def _divergence_reason(
    t: float,
    finite: bool,
    violations: dict[str, tuple[NDArray[np.bool_], NDArray[np.float64]]],
    index: int,
    solver: SolverConfig,
) -> str:
    """Why the sample at ``index`` diverged, naming the limit's config key."""
    if not finite:
        return f"non-finite state or force at t = {t:.4f} s"
    force, force_limit = violations["max_contact_force_n"][1][index], solver.max_contact_force_n
    depth, depth_limit = violations["max_penetration_m"][1][index], solver.max_penetration_m
    if violations["max_contact_force_n"][0][index]:
        return (
            f"contact force {force:.3g} N exceeds solver.max_contact_force_n = {force_limit:g} N "
            f"at t = {t:.4f} s"
        )
    if violations["max_penetration_m"][0][index]:
        return (
            f"peg penetrated the hole by {1e3 * depth:.2f} mm (> solver.max_penetration_m = "
            f"{depth_limit:g} m) at t = {t:.4f} s"
        )
    if violations["max_distance_from_hole_m"][0][index]:
        return (
            "peg left the scene (more than solver.max_distance_from_hole_m = "
            f"{solver.max_distance_from_hole_m:g} m from the hole) at t = {t:.4f} s"
        )
    raise AssertionError("no limit exceeded")


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
