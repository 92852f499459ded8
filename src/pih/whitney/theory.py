"""Whitney's planar quasi-static peg-in-hole theory: the analytical benchmark.

Implements the project's formula sheet ``docs/whitney.md`` (equation numbers (10-xx) are
Whitney's book chapter 10, (W-xx) his 1982 paper; § numbers are those of docs/whitney.md).
Conventions are Whitney's (docs/whitney.md §1): ``u`` points toward the side of the initial
lateral error ``eps0 > 0``; ``theta > 0`` when the peg top leans toward +u; ``F_z > 0`` is the
downward insertion force the support applies; ``F_x = -K_x (U0 - U) < 0`` during insertion; ``M``
is the support moment about the peg tip in the +theta sense. Depth ``l`` is the tip depth below
the hole entrance (bottom of the chamfer); the chamfer is crossed for ``-z_c <= l < 0``.

All quantities are SI: metres, newtons, N*m, N*m/rad, radians.

Phase sequence (§4) for the regular case (one-point tilt ``theta(l=0) >= 0``)::

    no_contact -> chamfer -> one_point -> [two_point -> one_point_after] -> line

and for the tip-on-wall case of §4.6 (one-point tilt already negative at ``l = 0``)::

    no_contact -> chamfer -> tip_on_wall -> two_point_mirror
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import pandas as pd

__all__ = [
    "PHASES",
    "WhitneyInvalidError",
    "WhitneyParams",
    "WhitneyState",
    "chamfer_height",
    "curve",
    "line_contact_depth",
    "onset_angle",
    "peak_force_depth",
    "phase_boundaries",
    "state_at",
    "two_point_range",
    "wedging_possible",
]

PHASES: tuple[str, ...] = (
    "no_contact",
    "chamfer",
    "one_point",
    "two_point",
    "one_point_after",
    "line",
    "tip_on_wall",
    "two_point_mirror",
)
"""Every phase label ``state_at``/``curve`` can return."""

CURVE_COLUMNS: dict[str, tuple[str, str]] = {
    "depth_m": ("m", "insertion depth l of the tip below the hole entrance"),
    "f_x_n": ("N", "lateral force, Whitney's sign (negative toward the error side)"),
    "f_z_n": ("N", "insertion force (downward push)"),
    "moment_nm": ("N*m", "support moment about the tip"),
    "theta_rad": ("rad", "peg tilt, positive toward the error side"),
    "u_m": ("m", "lateral position of the compliance centre"),
    "phase": ("", "contact phase"),
}
"""Units and descriptions of the columns of :func:`curve`."""

# Key of each phase's start depth in ``phase_boundaries``.
_BOUNDARY_KEYS: dict[str, str] = {
    "chamfer": "chamfer_start",
    "one_point": "one_point_start",
    "two_point": "two_point_start",
    "one_point_after": "two_point_end",
    "line": "line_start",
    "tip_on_wall": "tip_on_wall_start",
    "two_point_mirror": "two_point_mirror_start",
}


class WhitneyInvalidError(ValueError):
    """Parameters for which Whitney's theory is invalid (message names parameter and range)."""


@dataclass(frozen=True)
class WhitneyParams:
    """Support, geometry and friction parameters (SI); defaults: docs/whitney.md §2."""

    k_x_n_per_m: float = 1000.0
    k_theta_nm_per_rad: float = 1.0
    hole_diameter_m: float = 12.705e-3
    peg_diameter_m: float = 12.672e-3
    compliance_length_m: float = 0.045
    """L_g: distance of the compliance centre above the peg tip."""
    friction: float = 0.6
    chamfer_angle_rad: float = math.radians(45)
    """alpha: chamfer face angle from the horizontal hole face."""
    chamfer_width_m: float = 2.5e-3
    """W: horizontal chamfer width (capture range, (10-8))."""
    theta0_rad: float = 0.0
    offset_m: float = 1.0e-3
    """eps0 > 0: initial lateral error of the peg tip centre."""

    # --- geometry (docs/whitney.md §1, §3) -----------------------------------------------------
    @property
    def clearance_ratio(self) -> float:
        """c = (D - d)/D (10-3)."""
        return (self.hole_diameter_m - self.peg_diameter_m) / self.hole_diameter_m

    @property
    def peg_radius_m(self) -> float:
        """r = d/2."""
        return 0.5 * self.peg_diameter_m

    @property
    def radial_clearance_m(self) -> float:
        """cR = R - r."""
        return 0.5 * (self.hole_diameter_m - self.peg_diameter_m)

    @property
    def diametral_clearance_m(self) -> float:
        """cD = D - d."""
        return self.hole_diameter_m - self.peg_diameter_m

    @property
    def eps0_prime_m(self) -> float:
        """eps0' = eps0 - cR (10-27)."""
        return self.offset_m - self.radial_clearance_m

    @property
    def eps0_dprime_m(self) -> float:
        """eps0'' = eps0 + cR (10-31)."""
        return self.offset_m + self.radial_clearance_m

    @property
    def u0_m(self) -> float:
        """U0 = eps0 + L_g theta0 (10-15): spring-free lateral position of the compliance centre."""
        return self.offset_m + self.compliance_length_m * self.theta0_rad

    @property
    def z_c(self) -> float:
        """z_c = eps0' tan(alpha) (§4.2): vertical extent of the chamfer crossing [m]."""
        return self.eps0_prime_m * math.tan(self.chamfer_angle_rad)

    @property
    def max_entry_angle_rad(self) -> float:
        """theta_m = sqrt(2c) (10-4)."""
        return math.sqrt(2.0 * self.clearance_ratio)

    @property
    def wedging_angle_rad(self) -> float:
        """theta_w = c/mu (10-6); without friction (mu = 0) a peg cannot wedge: infinite."""
        return self.clearance_ratio / self.friction if self.friction > 0 else math.inf

    @property
    def design_tilt_rad(self) -> float:
        """theta0 + S eps0 (10-7): tilt the check (10-9) compares with c/mu."""
        return self.theta0_rad + self.S * self.offset_m

    # --- Whitney's auxiliaries (docs/whitney.md §1); capitalised names are his symbols -----------
    @property
    def A(self) -> float:
        """A = cos(alpha) + mu sin(alpha) (10-18)."""
        return math.cos(self.chamfer_angle_rad) + self.friction * math.sin(self.chamfer_angle_rad)

    @property
    def B(self) -> float:
        """B = sin(alpha) - mu cos(alpha) (10-18)."""
        return math.sin(self.chamfer_angle_rad) - self.friction * math.cos(self.chamfer_angle_rad)

    def C(self, depth_m: np.ndarray | float) -> np.ndarray | float:
        """C(l) = K_x (L_g - l - mu r) (10-26)."""
        return self.k_x_n_per_m * (
            self.compliance_length_m - depth_m - self.friction * self.peg_radius_m
        )

    @property
    def Dk(self) -> float:
        """Bold D = K_x L_g^2 + K_theta (10-35)."""
        return self.k_x_n_per_m * self.compliance_length_m**2 + self.k_theta_nm_per_rad

    @property
    def E(self) -> float:
        """E = K_x L_g r A (10-36)."""
        return self.k_x_n_per_m * self.compliance_length_m * self.peg_radius_m * self.A

    @property
    def F(self) -> float:
        """F = K_x L_g eps0'' (10-46)."""
        return self.k_x_n_per_m * self.compliance_length_m * self.eps0_dprime_m

    @property
    def G(self) -> float:
        """G = -K_x L_g (10-47)."""
        return -self.k_x_n_per_m * self.compliance_length_m

    @property
    def S(self) -> float:
        """S = K_x L_g / (K_x L_g^2 + K_theta) (10-7)."""
        return self.k_x_n_per_m * self.compliance_length_m / self.Dk

    def one_point_denominator(self, depth_m: np.ndarray | float) -> np.ndarray | float:
        """C(l) (L_g - l) + K_theta: denominator of (10-24), (10-25), (10-37)."""
        return self.C(depth_m) * (self.compliance_length_m - depth_m) + self.k_theta_nm_per_rad

    # --- validity ------------------------------------------------------------------------------
    def validate(self) -> None:
        """Raise WhitneyInvalidError where the theory (docs/whitney.md §3, §4) does not apply."""
        for name in (
            "k_x_n_per_m",
            "k_theta_nm_per_rad",
            "hole_diameter_m",
            "peg_diameter_m",
            "compliance_length_m",
            "chamfer_width_m",
            "offset_m",
        ):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0.0):
                raise WhitneyInvalidError(f"{name}={value!r} must be finite and > 0")
        if not (math.isfinite(self.friction) and self.friction >= 0.0):
            raise WhitneyInvalidError(f"friction={self.friction!r} must be finite and >= 0")
        if not 0.0 < self.chamfer_angle_rad < 0.5 * math.pi:
            raise WhitneyInvalidError(
                f"chamfer_angle_rad={self.chamfer_angle_rad!r} must lie in (0, pi/2)"
            )
        if not (math.isfinite(self.theta0_rad) and self.theta0_rad >= 0.0):
            raise WhitneyInvalidError(
                f"theta0_rad={self.theta0_rad!r} must be >= 0: the phase sequence of §4 assumes "
                "the initial tilt does not lean away from the error side"
            )
        if self.peg_diameter_m >= self.hole_diameter_m:
            raise WhitneyInvalidError(
                f"peg_diameter_m={self.peg_diameter_m!r} must be < hole_diameter_m="
                f"{self.hole_diameter_m!r} (peg wider than hole, no clearance)"
            )
        if self.B <= 0.0:
            raise WhitneyInvalidError(
                f"chamfer_angle_rad={self.chamfer_angle_rad!r} and friction={self.friction!r}: "
                f"tan(alpha)={math.tan(self.chamfer_angle_rad):.4g} <= friction, so B <= 0 (10-18): "
                "no valid theory, the peg cannot slide down the chamfer (need tan(alpha) > friction)"
            )
        if self.B * self.Dk - self.E <= 0.0:
            raise WhitneyInvalidError(
                f"B*Dk - E = {self.B * self.Dk - self.E:.4g} <= 0 (10-34): the chamfer crossing has "
                "no finite solution; increase chamfer_angle_rad or k_theta_nm_per_rad, or reduce "
                "friction"
            )
        c_r = self.radial_clearance_m
        if self.offset_m <= c_r:
            raise WhitneyInvalidError(
                f"offset_m={self.offset_m!r} <= radial clearance cR={c_r!r}: the peg is already "
                f"inside the hole without chamfer contact; need {c_r!r} < offset_m <= "
                f"{c_r + self.chamfer_width_m!r} (cR < eps0 <= cR + W, (10-8))"
            )
        if self.eps0_prime_m > self.chamfer_width_m:
            raise WhitneyInvalidError(
                f"offset_m={self.offset_m!r} is outside the chamfer capture range: eps0' = "
                f"{self.eps0_prime_m!r} > chamfer_width_m={self.chamfer_width_m!r}; need "
                f"{c_r!r} < offset_m <= {c_r + self.chamfer_width_m!r} (10-8)"
            )
        # The one-point denominator C(l)(L_g - l) + K_theta = K_x x (x - mu r) + K_theta with
        # x = L_g - l must stay positive over the one-point depths [0, max(l_line, 0)].
        l_line = max(_line_depth(self), 0.0)
        x = min(
            max(0.5 * self.friction * self.peg_radius_m, self.compliance_length_m - l_line),
            self.compliance_length_m,
        )
        if self.one_point_denominator(self.compliance_length_m - x) <= 0.0:
            raise WhitneyInvalidError(
                f"k_theta_nm_per_rad={self.k_theta_nm_per_rad!r} is too small: the one-point "
                "equilibrium (10-24) has a non-positive denominator C(l)(L_g - l) + K_theta within "
                f"0 <= l <= {l_line!r}"
            )


@dataclass(frozen=True)
class WhitneyState:
    """Quasi-static state at one insertion depth (support loads referred to the peg tip)."""

    depth_m: float
    f_x_n: float
    f_z_n: float
    moment_nm: float
    theta_rad: float
    u_m: float
    """U: lateral position of the compliance centre (+u toward the error side)."""
    phase: str


# ------------------------------------------------------------------------------------------------
# Phase formulas. Each returns (theta, U0 - U, F_z) for an array of depths; F_x and M then follow
# from the support springs (10-19) in `_support_loads`.
# ------------------------------------------------------------------------------------------------
_PhaseValues = tuple[np.ndarray, np.ndarray, np.ndarray]


def _support_loads(
    p: WhitneyParams, theta: np.ndarray, du: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """(F_x, M) = (-K_x (U0 - U), K_x L_g (U0 - U) - K_theta (theta - theta0)) (10-19)."""
    f_x = -p.k_x_n_per_m * du
    moment = p.k_x_n_per_m * p.compliance_length_m * du - p.k_theta_nm_per_rad * (
        theta - p.theta0_rad
    )
    return f_x, moment


def _no_contact(p: WhitneyParams, depth: np.ndarray) -> _PhaseValues:
    """Free peg above the chamfer: springs relaxed."""
    zero = np.zeros_like(depth)
    return zero + p.theta0_rad, zero, zero


def _chamfer(p: WhitneyParams, depth: np.ndarray) -> _PhaseValues:
    """Chamfer crossing, z = l + z_c: (10-21), (10-22), (10-34)."""
    s = (depth + p.z_c) / math.tan(p.chamfer_angle_rad)  # z / tan(alpha)
    den = p.B * p.Dk - p.E
    l_g, r = p.compliance_length_m, p.peg_radius_m
    theta = p.theta0_rad + p.k_x_n_per_m * s * (l_g * p.B - r * p.A) / den
    du = p.k_theta_nm_per_rad * s * p.B / den
    f_z = p.k_x_n_per_m * p.k_theta_nm_per_rad * p.A * s / den
    return theta, du, f_z


def _one_point(p: WhitneyParams, depth: np.ndarray) -> _PhaseValues:
    """One-point contact at the hole edge: (10-24), (10-25), (10-37)."""
    den = p.one_point_denominator(depth)
    k_t, th0 = p.k_theta_nm_per_rad, p.theta0_rad
    theta = (p.C(depth) * (p.eps0_prime_m + p.compliance_length_m * th0) + k_t * th0) / den
    du = k_t * (p.eps0_prime_m + depth * th0) / den
    return theta, du, p.friction * p.k_x_n_per_m * du


def _tip_on_wall(p: WhitneyParams, depth: np.ndarray) -> _PhaseValues:
    """§4.6: tip corner sliding on the error-side wall = one-point state at l = 0, constant."""
    return _one_point(p, np.zeros_like(depth))


def _two_point(p: WhitneyParams, depth: np.ndarray) -> _PhaseValues:
    """Two-point contact: theta = cD/l (10-2), (10-30), F_z (10-45) via (10-43), (10-44)."""
    theta = p.diametral_clearance_m / depth
    du = p.eps0_dprime_m + p.compliance_length_m * (p.theta0_rad - theta)
    f_x, moment = _support_loads(p, theta, du)
    mu = p.friction
    f_z = 2.0 * mu / depth * moment + mu * (1.0 + mu * p.peg_diameter_m / depth) * f_x
    return theta, du, f_z


def _two_point_mirror(p: WhitneyParams, depth: np.ndarray) -> _PhaseValues:
    """§4.6 mirror two-point contact: theta = -cD/l, tip corner on the +u wall."""
    theta = -p.diametral_clearance_m / depth
    du = p.eps0_prime_m + p.compliance_length_m * (p.theta0_rad - theta)
    f_x, moment = _support_loads(p, theta, du)
    mu = p.friction
    f_z = -2.0 * mu / depth * moment - mu * (1.0 + mu * p.peg_diameter_m / depth) * f_x
    return theta, du, f_z


def _line(p: WhitneyParams, depth: np.ndarray) -> _PhaseValues:
    """Line contact (§4.5): theta = 0, U0 - U = eps0' + L_g theta0, F_z = mu K_x (U0 - U)."""
    zero = np.zeros_like(depth)
    du = zero + p.eps0_prime_m + p.compliance_length_m * p.theta0_rad
    return zero, du, p.friction * p.k_x_n_per_m * du


_PHASE_FORMULAS: dict[str, Callable[[WhitneyParams, np.ndarray], _PhaseValues]] = {
    "no_contact": _no_contact,
    "chamfer": _chamfer,
    "one_point": _one_point,
    "two_point": _two_point,
    "one_point_after": _one_point,
    "line": _line,
    "tip_on_wall": _tip_on_wall,
    "two_point_mirror": _two_point_mirror,
}


# ------------------------------------------------------------------------------------------------
# Phase boundaries
# ------------------------------------------------------------------------------------------------
def _line_depth(p: WhitneyParams) -> float:
    """l_line = L_g - mu r + K_theta theta0 / (K_x (eps0' + L_g theta0)) (§5); zero of theta(l)."""
    return (
        p.compliance_length_m
        - p.friction * p.peg_radius_m
        + p.k_theta_nm_per_rad
        * p.theta0_rad
        / (p.k_x_n_per_m * (p.eps0_prime_m + p.compliance_length_m * p.theta0_rad))
    )


def _tip_on_wall_case(p: WhitneyParams) -> bool:
    """§4.6: the one-point theta(0) < 0, equivalently l_line < 0 (the numerator of (10-24) is
    linear and decreasing in l, the denominator positive)."""
    return _line_depth(p) < 0.0


def _phase_plan(p: WhitneyParams) -> list[tuple[str, float]]:
    """Ordered (phase, start depth) list; each phase lasts until the next one starts."""
    p.validate()
    plan = [("no_contact", -math.inf), ("chamfer", -p.z_c)]
    if _tip_on_wall_case(p):
        theta_wall = float(_one_point(p, np.zeros(1))[0][0])
        plan += [("tip_on_wall", 0.0), ("two_point_mirror", p.diametral_clearance_m / -theta_wall)]
        return plan
    plan.append(("one_point", 0.0))
    roots = two_point_range(p)
    if roots is not None:
        plan += [("two_point", roots[0]), ("one_point_after", roots[1])]
    plan.append(("line", _line_depth(p)))
    return plan


def chamfer_height(p: WhitneyParams) -> float:
    """z_c = eps0' tan(alpha) (§4.2) [m]; the chamfer is crossed for -z_c <= l < 0."""
    p.validate()
    return p.z_c


def two_point_range(p: WhitneyParams) -> tuple[float, float] | None:
    """(l2, l2') [m]: roots of a l^2 - b l + g = 0 (W-21, W-22) with mu r (docs/whitney.md §5).

    None if b^2 < 4ag, or in the tip-on-wall case of §4.6 (then only a mirror two-point
    contact can occur, see ``phase_boundaries``).
    """
    p.validate()
    if _tip_on_wall_case(p):
        return None
    k_x, l_g, c_d = p.k_x_n_per_m, p.compliance_length_m, p.diametral_clearance_m
    mu_r = p.friction * p.peg_radius_m
    a = k_x * (p.eps0_dprime_m + l_g * p.theta0_rad)
    b = (l_g - mu_r) * a + k_x * l_g * c_d + p.k_theta_nm_per_rad * p.theta0_rad
    g = c_d * (p.Dk - k_x * l_g * mu_r)
    disc = b * b - 4.0 * a * g
    if disc < 0.0:
        return None
    root = math.sqrt(disc)
    return (b - root) / (2.0 * a), (b + root) / (2.0 * a)


def onset_angle(p: WhitneyParams) -> float | None:
    """theta_2 at the onset of two-point contact (W-19); equals cD/l2. None without two-point."""
    roots = two_point_range(p)
    if roots is None:
        return None
    l2 = roots[0]
    k_x, l_g = p.k_x_n_per_m, p.compliance_length_m
    mu_r = p.friction * p.peg_radius_m
    return p.theta0_rad + k_x * p.eps0_dprime_m * (l_g - l2 - mu_r) / (
        p.Dk - k_x * l_g * (l2 + mu_r)
    )


def peak_force_depth(p: WhitneyParams) -> float | None:
    """l* [m] where the two-point F_z (10-45) peaks: derived form of (W-82), docs/whitney.md §5,

    l* = 2 cD (2 Dk + mu d G) / (2 Dk theta0 + F (2 - mu d/L_g) + G (mu d theta0 - cD)).

    None when there is no two-point contact or F_z has no interior maximum in [l2, l2']
    (zero friction, F_z not concave in 1/l, or the stationary point outside the range).
    """
    roots = two_point_range(p)
    if roots is None:
        return None
    mu_d, c_d = p.friction * p.peg_diameter_m, p.diametral_clearance_m
    curvature = 2.0 * p.Dk + mu_d * p.G  # F_z is concave in 1/l iff mu * curvature > 0
    den = (
        2.0 * p.Dk * p.theta0_rad
        + p.F * (2.0 - mu_d / p.compliance_length_m)
        + p.G * (mu_d * p.theta0_rad - c_d)
    )
    if p.friction <= 0.0 or curvature <= 0.0 or den <= 0.0:
        return None
    l_star = 2.0 * c_d * curvature / den
    return l_star if roots[0] <= l_star <= roots[1] else None


def line_contact_depth(p: WhitneyParams) -> float:
    """l_line [m] (§4.5, §5) where the one-point theta returns to 0 and line contact starts.

    ``math.inf`` in the tip-on-wall case of §4.6, where line contact is never reached.
    """
    p.validate()
    return math.inf if _tip_on_wall_case(p) else _line_depth(p)


def wedging_possible(p: WhitneyParams) -> bool:
    """True if two-point contact (regular or mirror) starts at l < mu d (§6.1, (10-5))."""
    bounds = phase_boundaries(p)
    start = bounds.get("two_point_start", bounds.get("two_point_mirror_start"))
    return start is not None and start < p.friction * p.peg_diameter_m


def phase_boundaries(p: WhitneyParams) -> dict[str, float]:
    """Start depths [m] of the phases present, e.g. chamfer_start (-z_c), one_point_start (0),
    two_point_start (l2), two_point_end (l2'), line_start (l_line); or, in the tip-on-wall case
    (§4.6), tip_on_wall_start (0) and two_point_mirror_start (cD/|theta(0)|)."""
    return {_BOUNDARY_KEYS[name]: start for name, start in _phase_plan(p)[1:]}


# ------------------------------------------------------------------------------------------------
# Evaluation
# ------------------------------------------------------------------------------------------------
_COLUMNS = ("f_x_n", "f_z_n", "moment_nm", "theta_rad", "u_m")


def _evaluate(p: WhitneyParams, depth: np.ndarray) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """Vectorized state at ``depth`` [m]: column arrays and the phase label of each point."""
    plan = _phase_plan(p)
    starts = np.array([start for _, start in plan])
    # Last phase whose start <= depth (later phase wins at a shared start).
    index = np.searchsorted(starts, depth, side="right") - 1
    theta, du, f_z = (np.empty_like(depth) for _ in range(3))
    for k, (name, _) in enumerate(plan):
        mask = index == k
        if mask.any():
            theta[mask], du[mask], f_z[mask] = _PHASE_FORMULAS[name](p, depth[mask])
    f_x, moment = _support_loads(p, theta, du)
    columns = dict(zip(_COLUMNS, (f_x, f_z, moment, theta, p.u0_m - du), strict=True))
    phases = np.array([name for name, _ in plan], dtype=object)[index]
    return columns, phases


def state_at(p: WhitneyParams, depth_m: float) -> WhitneyState:
    """State at insertion depth ``depth_m`` [m] (l < 0 on the chamfer, l = 0 is one-point)."""
    if not math.isfinite(depth_m):
        raise ValueError(f"depth_m={depth_m!r} must be finite")
    columns, phases = _evaluate(p, np.array([float(depth_m)]))
    values = {name: float(col[0]) for name, col in columns.items()}
    return WhitneyState(depth_m=float(depth_m), phase=str(phases[0]), **values)


def _default_depths(p: WhitneyParams, max_depth_m: float | None) -> np.ndarray:
    """Grid from -z_c to max depth: uniform, plus phase starts, the two sides of the l = 0 jump
    (l = -1e-6 z_c on the chamfer, l = 0 one-point) and refinement over [l_o, 2 l_o] after the
    onset l_o of two-point contact, where F_z rises steeply (§4.4), geometric close to l_o."""
    bounds = phase_boundaries(p)
    start = bounds["chamfer_start"]
    if max_depth_m is not None:
        end = float(max_depth_m)
    elif "line_start" in bounds:
        l_line = bounds["line_start"]
        end = 1.1 * l_line
        if p.compliance_length_m > l_line:  # cap at L_g unless that would cut off line contact
            end = min(end, p.compliance_length_m)
    else:
        end = 2.0 * bounds["two_point_mirror_start"]
    if not (math.isfinite(end) and end > start):
        raise ValueError(f"max_depth_m={max_depth_m!r} must be finite and > -z_c = {start!r}")
    parts = [
        np.linspace(start, 1e-6 * start, 41),
        np.linspace(0.0, end, 601),
        np.array([*bounds.values(), end]),
    ]
    onset = bounds.get("two_point_start", bounds.get("two_point_mirror_start"))
    if onset is not None:
        stop = bounds.get("two_point_end", math.inf)
        rise = onset * np.concatenate([np.geomspace(1e-6, 0.1, 60), np.linspace(0.0, 1.0, 241)])
        parts.append(np.minimum(onset + rise, stop))
    grid = np.unique(np.concatenate(parts))
    return grid[(grid >= start) & (grid <= end)]


def curve(
    p: WhitneyParams,
    depth_m: np.ndarray | None = None,
    *,
    max_depth_m: float | None = None,
) -> pd.DataFrame:
    """Force/angle curve vs depth: columns depth_m, f_x_n, f_z_n, moment_nm, theta_rad, u_m, phase.

    ``depth_m`` evaluates at the given depths [m]. Otherwise a default grid runs from -z_c to
    ``max_depth_m`` (default: 1.1 l_line, capped at L_g when L_g > l_line; twice the mirror
    onset in the tip-on-wall case) and is refined right after the onset of two-point contact.
    """
    if depth_m is None:
        depth = _default_depths(p, max_depth_m)
    else:
        if max_depth_m is not None:
            raise ValueError("give either depth_m or max_depth_m, not both")
        depth = np.asarray(depth_m, dtype=float).ravel()
        if not np.isfinite(depth).all():
            raise ValueError("depth_m must be finite")
    columns, phases = _evaluate(p, depth)
    return pd.DataFrame({"depth_m": depth, **columns, "phase": phases})
