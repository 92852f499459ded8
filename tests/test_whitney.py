"""Tests for pih.whitney.theory against the project's formula sheet docs/whitney.md (§ numbers are its).

Its tables are in mm, N and N*mm; the module is SI, so depths are converted with MM.
Printed table values are checked to their printed precision (half a unit of the last digit).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from pih.whitney.jamming import jamming_diagram
from pih.whitney.theory import (
    WhitneyInvalidError,
    WhitneyParams,
    chamfer_height,
    curve,
    line_contact_depth,
    onset_angle,
    peak_force_depth,
    phase_boundaries,
    state_at,
    two_point_range,
    wedging_possible,
)

MM = 1e-3
CHAMFER_PEAK = -1e-15  # l -> 0-: depth on the chamfer just above the entrance [m]
REGULAR_PHASES = ["chamfer", "one_point", "two_point", "one_point_after", "line"]


def assert_printed(value: float, printed: str, ulps: float = 0.5) -> None:
    """``value`` rounds to ``printed`` (within ``ulps`` units of its last printed digit)."""
    decimals = len(printed.split(".")[1]) if "." in printed else 0
    tol = ulps * 10.0**-decimals * (1 + 1e-9)
    assert abs(value - float(printed)) <= tol, f"{value!r} does not print as {printed}"


def paper(offset_mm: float) -> WhitneyParams:
    """The paper's parameters (docs/whitney.md §2). Its Whitney curves use the stored clearance
    ratio c = 0.0026 exactly, i.e. d = D (1 - c) = 12.67197 mm rather than 12.672 mm; that
    difference moves l2, l* and F_z* in their 4th digit, so the table (§8.1) is reproduced with
    d = D (1 - c)."""
    hole = 12.705 * MM
    return WhitneyParams(peg_diameter_m=hole * (1 - 0.0026), offset_m=offset_mm * MM)


def phase_runs(phases) -> list[str]:
    """Phase labels with consecutive repeats collapsed."""
    runs: list[str] = []
    for phase in phases:
        if not runs or runs[-1] != phase:
            runs.append(phase)
    return runs


# ---------------------------------------------------------------------------------------------
# docs/whitney.md §8.1 table, every cell (TABLE_9_2: it was §9.2 of the original reference sheet)
# ---------------------------------------------------------------------------------------------
# eps0, z_c, chamfer peak (F_z, F_x, theta), one-point at l=0 (F_z, F_x, theta), l2, theta2,
# l*, F_z*, F_x(l*), l2', l_line, line contact (F_z, F_x)
TABLE_9_2 = [
    ("0.5", "0.4835", ("1.0262", "-0.2566", "0.00504"), ("0.1016", "-0.1694", "0.00698"),
     "4.627", "0.00714", "8.561", "1.233", "-0.343", "39.45", "41.20", "0.2901", "-0.4835"),
    ("1.0", "0.9835", ("2.0875", "-0.5219", "0.01026"), ("0.2068", "-0.3446", "0.01420"),
     "2.298", "0.01438", "4.424", "5.171", "-0.680", "40.36", "41.20", "0.5901", "-0.9835"),
    ("1.5", "1.4835", ("3.1488", "-0.7872", "0.01547"), ("0.3119", "-0.5198", "0.02142"),
     "1.529", "0.02160", "2.982", "11.809", "-1.018", "40.65", "41.20", "0.8901", "-1.4835"),
    ("2.0", "1.9835", ("4.2100", "-1.0525", "0.02069"), ("0.4170", "-0.6950", "0.02863"),
     "1.146", "0.02882", "2.249", "21.148", "-1.356", "40.79", "41.20", "1.1901", "-1.9835"),
]  # fmt: skip


@pytest.mark.parametrize("row", TABLE_9_2, ids=[row[0] for row in TABLE_9_2])
def test_table_9_2(row):
    eps0, z_c, chamfer, one_point, l2, theta2, l_star, fz_star, fx_star, l2p, l_line, fz_line, \
        fx_line = row  # fmt: skip
    p = paper(float(eps0))
    assert_printed(chamfer_height(p) / MM, z_c)

    peak = state_at(p, CHAMFER_PEAK)
    assert peak.phase == "chamfer"
    for value, printed in zip((peak.f_z_n, peak.f_x_n, peak.theta_rad), chamfer, strict=True):
        assert_printed(value, printed)

    start = state_at(p, 0.0)
    assert start.phase == "one_point"
    for value, printed in zip((start.f_z_n, start.f_x_n, start.theta_rad), one_point, strict=True):
        assert_printed(value, printed)

    lo, hi = two_point_range(p)
    assert_printed(lo / MM, l2)
    assert_printed(onset_angle(p), theta2)
    ls = peak_force_depth(p)
    assert_printed(ls / MM, l_star)
    at_peak = state_at(p, ls)
    assert at_peak.phase == "two_point"
    assert_printed(at_peak.f_z_n, fz_star)
    assert_printed(at_peak.f_x_n, fx_star)
    assert_printed(hi / MM, l2p)
    assert_printed(line_contact_depth(p) / MM, l_line)

    line = state_at(p, 43 * MM)
    assert line.phase == "line"
    assert line.theta_rad == 0.0
    assert_printed(line.f_z_n, fz_line)
    assert_printed(line.f_x_n, fx_line)


def test_chamfer_to_one_point_discontinuity_default_params():
    """docs/whitney.md §4.2, §8.1: at l = 0 the contact jumps from chamfer to hole edge
    (eps0 = 1 mm: 2.0875 -> 0.207 N, theta 0.0103 -> 0.0142), with the module's default parameters
    (d = 12.672 mm). The original reference sheet printed "2.087", the table's 2.0875 cut short;
    with d = 12.672 mm the peak is 2.08753 N, so check 2.0875."""
    p = WhitneyParams()
    before, after = state_at(p, CHAMFER_PEAK), state_at(p, 0.0)
    assert (before.phase, after.phase) == ("chamfer", "one_point")
    assert_printed(before.f_z_n, "2.0875")
    assert_printed(after.f_z_n, "0.207")
    assert_printed(before.theta_rad, "0.0103")
    assert_printed(after.theta_rad, "0.0142")


# ---------------------------------------------------------------------------------------------
# docs/whitney.md §8.2 Whitney's experiment, §8.3 looser SI fit
# ---------------------------------------------------------------------------------------------
FIG_10_24 = WhitneyParams(
    k_x_n_per_m=7000.0,  # 7 N/mm
    k_theta_nm_per_rad=53.0,  # 53000 N*mm/rad
    friction=0.1,
    compliance_length_m=45 * MM,
    offset_m=0.83 * MM,
    theta0_rad=0.0,
    chamfer_width_m=2.5 * MM,  # eps0' = 0.81 mm must land on the chamfer
)
FIG_10_25 = dataclasses.replace(
    FIG_10_24, compliance_length_m=1 * MM, offset_m=1.35 * MM, theta0_rad=0.0006
)


def test_fig_10_24():
    p = FIG_10_24
    assert_printed(state_at(p, CHAMFER_PEAK).f_z_n, "5.70")
    assert_printed(two_point_range(p)[0] / MM, "10.5")
    ls = peak_force_depth(p)
    assert_printed(ls / MM, "16.5")
    assert_printed(state_at(p, ls).f_z_n, "1.03")
    one_point = curve(p, np.linspace(0.0, 10 * MM, 11))
    assert (one_point.phase == "one_point").all()
    assert one_point.f_z_n.between(0.45, 0.495).all()  # docs/whitney.md §8.2


def test_fig_10_25_no_two_point_contact():
    p = FIG_10_25
    assert two_point_range(p) is None
    assert onset_angle(p) is None and peak_force_depth(p) is None
    assert not wedging_possible(p)
    assert_printed(state_at(p, CHAMFER_PEAK).f_z_n, "11.4")
    df = curve(p)
    assert phase_runs(df.phase) == ["chamfer", "one_point", "line"]
    after = df[df.depth_m >= 0]
    assert np.allclose(after.f_z_n, 0.93, atol=0.01)
    assert np.allclose(after.f_x_n, -9.3, atol=0.05)


def si_set(offset_mm: float) -> WhitneyParams:
    return WhitneyParams(
        hole_diameter_m=12.2 * MM, peg_diameter_m=12.0 * MM, chamfer_width_m=2.5 * MM,
        offset_m=offset_mm * MM,
    )  # fmt: skip


def test_si_set_no_two_point_at_half_mm():
    p = si_set(0.5)
    assert two_point_range(p) is None and not wedging_possible(p)
    assert phase_runs(curve(p).phase) == ["chamfer", "one_point", "line"]


def test_si_set_one_mm():
    p = si_set(1.0)
    assert_printed(chamfer_height(p) / MM, "0.90")
    assert_printed(state_at(p, CHAMFER_PEAK).f_z_n, "1.85")
    lo, hi = two_point_range(p)
    assert_printed(lo / MM, "15.1")
    assert_printed(onset_angle(p), "0.0133")
    ls = peak_force_depth(p)
    assert_printed(ls / MM, "22.9")
    assert_printed(state_at(p, ls).f_z_n, "0.65")
    assert_printed(hi / MM, "34.5")
    assert_printed(p.friction * p.peg_diameter_m / MM, "7.2")
    assert not wedging_possible(p)


@pytest.mark.parametrize(
    ("offset_mm", "l2", "l2_ulps", "fz_star", "l_star", "wedging"),
    [
        # docs/whitney.md §8.3 prints 9.6 for l2 = 9.5496 mm (rounded via 9.55): allow 0.6 ulp
        (1.5, "9.6", 0.6, "1.66", "16.2", False),
        (2.0, "7.06", 0.5, "3.12", "12.5", True),
    ],
)
def test_si_set_larger_offsets(offset_mm, l2, l2_ulps, fz_star, l_star, wedging):
    p = si_set(offset_mm)
    assert_printed(two_point_range(p)[0] / MM, l2, ulps=l2_ulps)
    ls = peak_force_depth(p)
    assert_printed(ls / MM, l_star)
    assert_printed(state_at(p, ls).f_z_n, fz_star)
    assert wedging_possible(p) is wedging


# ---------------------------------------------------------------------------------------------
# Continuity, sheet-form identities, contact forces
# ---------------------------------------------------------------------------------------------
COLUMNS = ["f_x_n", "f_z_n", "moment_nm", "theta_rad", "u_m"]


@pytest.mark.parametrize("offset_mm", [0.5, 1.0, 2.0])
@pytest.mark.parametrize("key", ["two_point_start", "two_point_end"])
def test_continuity_at_two_point_boundaries(offset_mm, key):
    p = paper(offset_mm)
    boundary = phase_boundaries(p)[key]
    df = curve(p, np.array([np.nextafter(boundary, -np.inf), boundary]))
    assert df.phase[0] != df.phase[1]
    for col in COLUMNS:
        assert df[col][1] == pytest.approx(df[col][0], rel=1e-9, abs=1e-15), col


def test_continuity_at_line_contact():
    p = paper(1.0)
    l_line = line_contact_depth(p)
    df = curve(p, np.array([np.nextafter(l_line, -np.inf), l_line]))
    assert list(df.phase) == ["one_point_after", "line"]
    for col in COLUMNS:
        assert df[col][1] == pytest.approx(df[col][0], rel=1e-9, abs=1e-12), col


def test_onset_angle_is_geometric_two_point_angle():
    """(W-19) at l2 equals the two-point geometry cD/l2 (10-2)."""
    for offset in (0.5, 1.0, 2.0):
        p = paper(offset)
        l2 = two_point_range(p)[0]
        assert onset_angle(p) == pytest.approx(p.diametral_clearance_m / l2, rel=1e-12)
        assert state_at(p, l2).theta_rad == pytest.approx(onset_angle(p), rel=1e-12)


def test_sheet_forms_of_each_phase():
    """Each phase's loads equal the phase-specific forms of docs/whitney.md §4.2, 4.3, 4.4, 4.5."""
    p = dataclasses.replace(paper(1.0), theta0_rad=0.002)
    k_x, k_t, l_g, th0 = p.k_x_n_per_m, p.k_theta_nm_per_rad, p.compliance_length_m, p.theta0_rad
    mu, r, c_d = p.friction, p.peg_radius_m, p.diametral_clearance_m

    mid = state_at(p, -0.5 * p.z_c)  # chamfer: linear in z, F_x = -(B/A) F_z, M = r F_z
    peak = state_at(p, CHAMFER_PEAK)
    assert mid.f_z_n == pytest.approx(0.5 * peak.f_z_n, rel=1e-9)
    assert mid.theta_rad - th0 == pytest.approx(0.5 * (peak.theta_rad - th0), rel=1e-9)
    assert mid.f_x_n == pytest.approx(-p.B / p.A * mid.f_z_n, rel=1e-12)
    assert mid.moment_nm == pytest.approx(r * mid.f_z_n, rel=1e-12)
    assert state_at(p, -p.z_c).f_z_n == pytest.approx(0.0, abs=1e-15)

    # one-point: F_z = -mu F_x, M = (l + mu r) K_x (U0 - U), U = cR + (L_g - l) theta
    depth = 1 * MM
    s = state_at(p, depth)
    assert s.phase == "one_point"
    assert s.f_z_n == pytest.approx(-mu * s.f_x_n, rel=1e-12)
    assert s.moment_nm == pytest.approx((depth + mu * r) * -s.f_x_n, rel=1e-12)
    assert s.u_m == pytest.approx(p.radial_clearance_m + (l_g - depth) * s.theta_rad, rel=1e-12)

    depth = 10 * MM  # two-point: (10-43), (10-44)
    s = state_at(p, depth)
    assert s.phase == "two_point"
    assert s.theta_rad == pytest.approx(c_d / depth, rel=1e-12)
    assert s.f_x_n == pytest.approx(p.G * (th0 - c_d / depth) - p.F / l_g, rel=1e-12)
    assert s.moment_nm == pytest.approx(p.Dk * (th0 - c_d / depth) + p.F, rel=1e-12)

    s = state_at(p, 44.5 * MM)  # line contact (§4.5)
    assert s.phase == "line"
    base = p.eps0_prime_m + l_g * th0
    assert s.f_x_n == pytest.approx(-k_x * base, rel=1e-12)
    assert s.f_z_n == pytest.approx(mu * k_x * base, rel=1e-12)
    assert s.moment_nm == pytest.approx(k_x * l_g * base + k_t * th0, rel=1e-12)


def test_two_point_contact_forces_nonnegative_and_f2_vanishes_at_ends():
    """f1 = (M + mu r F_x)/l >= 0, f2 = f1 + F_x >= 0, with f2 = 0 at l2 and l2' (§4.4, §5)."""
    p = paper(1.0)
    lo, hi = two_point_range(p)
    df = curve(p, np.linspace(lo, hi, 200))
    f1 = (df.moment_nm + p.friction * p.peg_radius_m * df.f_x_n) / df.depth_m
    f2 = f1 + df.f_x_n
    assert (f1 > 0).all() and (f2 >= -1e-12).all()
    assert abs(f2.iloc[0]) < 1e-12 and abs(f2.iloc[-1]) < 1e-12
    assert df.f_z_n.to_numpy() == pytest.approx(p.friction * (f1 + f2).to_numpy(), rel=1e-12)


def test_peak_force_depth_is_maximum():
    p = paper(1.0)
    ls = peak_force_depth(p)
    f_z = curve(p, np.linspace(*two_point_range(p), 2001)).f_z_n
    assert state_at(p, ls).f_z_n >= f_z.max() - 1e-12
    assert state_at(p, ls).f_z_n == pytest.approx(f_z.max(), rel=1e-5)


def test_peak_force_depth_none_without_friction():
    p = dataclasses.replace(paper(1.0), friction=0.0)
    assert two_point_range(p) is not None
    assert peak_force_depth(p) is None


# ---------------------------------------------------------------------------------------------
# docs/whitney.md §6.1 wedging, §6.2 jamming
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize(
    ("offset_mm", "l2", "theta2", "design_tilt"),
    [(0.5, "4.63", "0.0071", "0.0074"), (1.0, "2.30", "0.0144", "0.0149"),
     (1.5, "1.53", "0.0216", "0.0223"), (2.0, "1.15", "0.0288", "0.0298")],
)  # fmt: skip
def test_wedging_table(offset_mm, l2, theta2, design_tilt):
    p = paper(offset_mm)
    assert_printed(p.friction * p.peg_diameter_m / MM, "7.60")
    assert_printed(p.wedging_angle_rad, "0.00433")
    assert_printed(two_point_range(p)[0] / MM, l2)
    assert_printed(onset_angle(p), theta2)
    assert_printed(abs(p.design_tilt_rad), design_tilt)
    assert onset_angle(p) > p.wedging_angle_rad
    assert wedging_possible(p)


@pytest.mark.parametrize("lam", [0.5, 1.0, 2.5])
def test_jamming_diagram(lam):
    mu, d = 0.6, 12.672 * MM
    jd = jamming_diagram(lam * mu * d, mu, d)
    assert jd["lambda"] == pytest.approx(lam, rel=1e-12)
    assert jd["wedged"] is (lam < 1.0)
    assert jd["x_edge"] == pytest.approx(1 / mu)
    assert jd["upper_y_intercept"] == pytest.approx(lam)
    assert jd["lower_y_intercept"] == pytest.approx(-lam)
    assert jd["upper_x_intercept"] == pytest.approx(lam / ((lam + 1) * mu))
    assert jd["lower_x_intercept"] == pytest.approx(-lam / ((lam + 1) * mu))
    assert jd["slope"] == pytest.approx(-mu * (1 + lam))
    expected = [(-1 / mu, 2 * lam + 1), (1 / mu, -1), (1 / mu, -(2 * lam + 1)), (-1 / mu, 1)]
    assert np.allclose(jd["vertices"], expected, rtol=1e-12)
    (x0, y0), (x1, y1), (x2, y2), (x3, y3) = jd["vertices"]
    # the upper line runs through vertices 0, 1 and its X intercept; the lower through 2, 3
    upper = jd["upper_y_intercept"] + jd["slope"] * np.array([x0, x1, jd["upper_x_intercept"]])
    lower = jd["lower_y_intercept"] + jd["slope"] * np.array([x2, x3, jd["lower_x_intercept"]])
    assert np.allclose(upper, [y0, y1, 0.0], atol=1e-12)
    assert np.allclose(lower, [y2, y3, 0.0], atol=1e-12)


def test_jamming_diagram_rejects_zero_friction():
    with pytest.raises(WhitneyInvalidError, match="friction"):
        jamming_diagram(0.01, 0.0, 0.012)


# ---------------------------------------------------------------------------------------------
# Validity errors
# ---------------------------------------------------------------------------------------------
def test_error_chamfer_steeper_than_friction_cone():
    p = WhitneyParams(chamfer_angle_rad=math.radians(30), friction=0.6)
    with pytest.raises(WhitneyInvalidError, match="chamfer_angle_rad") as info:
        p.validate()
    assert "friction" in str(info.value) and "cannot slide" in str(info.value)
    for func in (chamfer_height, two_point_range, phase_boundaries, curve):
        with pytest.raises(WhitneyInvalidError):
            func(p)
    with pytest.raises(WhitneyInvalidError):
        state_at(p, 0.0)


def test_error_offset_beyond_chamfer():
    p = WhitneyParams(offset_m=3.0 * MM, chamfer_width_m=2.5 * MM)
    with pytest.raises(WhitneyInvalidError, match="offset_m") as info:
        state_at(p, 0.0)
    upper = p.radial_clearance_m + p.chamfer_width_m
    assert repr(upper) in str(info.value) and repr(p.radial_clearance_m) in str(info.value)


def test_error_offset_inside_clearance():
    with pytest.raises(WhitneyInvalidError, match="offset_m.*already inside the hole"):
        WhitneyParams(offset_m=0.01 * MM).validate()


@pytest.mark.parametrize(
    ("change", "name"),
    [
        ({"peg_diameter_m": 12.8 * MM}, "peg_diameter_m"),
        ({"k_x_n_per_m": 0.0}, "k_x_n_per_m"),
        ({"k_theta_nm_per_rad": -1.0}, "k_theta_nm_per_rad"),
        ({"compliance_length_m": 0.0}, "compliance_length_m"),
        ({"friction": -0.1}, "friction"),
        ({"theta0_rad": -0.001}, "theta0_rad"),
        ({"chamfer_angle_rad": math.radians(90)}, "chamfer_angle_rad"),
    ],
)
def test_error_invalid_parameters(change, name):
    with pytest.raises(WhitneyInvalidError, match=name):
        WhitneyParams(**change).validate()
    assert issubclass(WhitneyInvalidError, ValueError)


def test_error_chamfer_without_finite_solution():
    """B > 0 but B*Dk - E <= 0 (10-34): tiny K_theta with a shallow chamfer."""
    p = WhitneyParams(k_theta_nm_per_rad=1e-3, compliance_length_m=10 * MM,
                      chamfer_angle_rad=math.radians(35))  # fmt: skip
    assert p.B > 0
    with pytest.raises(WhitneyInvalidError, match="B\\*Dk - E"):
        p.validate()


# ---------------------------------------------------------------------------------------------
# curve()
# ---------------------------------------------------------------------------------------------
@pytest.mark.parametrize("offset_mm", [1.0, 2.0])
def test_curve_default_grid(offset_mm):
    p = paper(offset_mm)
    df = curve(p)
    assert list(df.columns) == ["depth_m", *COLUMNS, "phase"]
    depth = df.depth_m.to_numpy()
    assert (np.diff(depth) > 0).all()
    assert depth[0] == pytest.approx(-p.z_c) and depth[-1] == pytest.approx(p.compliance_length_m)
    assert phase_runs(df.phase) == REGULAR_PHASES
    bounds = phase_boundaries(p)
    assert bounds == pytest.approx({
        "chamfer_start": -p.z_c, "one_point_start": 0.0,
        "two_point_start": two_point_range(p)[0], "two_point_end": two_point_range(p)[1],
        "line_start": line_contact_depth(p),
    })  # fmt: skip
    assert set(bounds.values()) <= set(depth)
    # both sides of the l = 0 jump: chamfer peak just above, one-point value at 0
    i0 = int(np.flatnonzero(depth == 0.0)[0])
    assert df.phase[i0 - 1] == "chamfer" and df.phase[i0] == "one_point"
    assert -depth[i0 - 1] < 1e-6 * p.z_c * 1.0001
    assert df.f_z_n[i0 - 1] == pytest.approx(state_at(p, CHAMFER_PEAK).f_z_n, rel=1e-5)
    assert df.f_z_n[i0] == pytest.approx(state_at(p, 0.0).f_z_n, rel=1e-12)
    # dense right after l2, where F_z rises steeply
    l2, ls = bounds["two_point_start"], peak_force_depth(p)
    just_after = depth[(depth > l2) & (depth < l2 + 0.01 * (ls - l2))]
    assert len(just_after) >= 40
    assert np.diff(df.f_z_n[(depth >= l2) & (depth <= ls)]).max() < 0.02 * df.f_z_n.max()


def test_curve_matches_state_at_and_respects_max_depth():
    p = paper(1.5)
    df = curve(p, max_depth_m=10 * MM)
    assert df.depth_m.iloc[-1] == pytest.approx(10 * MM)
    assert phase_runs(df.phase) == ["chamfer", "one_point", "two_point"]
    for _, row in df.iloc[:: len(df) // 7].iterrows():
        s = state_at(p, row.depth_m)
        assert s.phase == row.phase
        assert [getattr(s, c) for c in COLUMNS] == pytest.approx([row[c] for c in COLUMNS])
    before = curve(p, np.array([-2 * p.z_c]))
    assert before.phase[0] == "no_contact" and before.f_z_n[0] == 0.0
    assert before.u_m[0] == pytest.approx(p.u0_m)
    with pytest.raises(ValueError):
        curve(p, np.array([0.0]), max_depth_m=0.01)


# ---------------------------------------------------------------------------------------------
# docs/whitney.md §4.6: tip on the wall, mirror two-point contact
# ---------------------------------------------------------------------------------------------
def test_tip_on_wall_and_mirror_two_point():
    p = WhitneyParams(compliance_length_m=2 * MM, offset_m=1 * MM)  # L_g < mu r = 3.8 mm
    assert state_at(p, 0.0).theta_rad < 0.0
    assert two_point_range(p) is None and peak_force_depth(p) is None
    assert line_contact_depth(p) == math.inf
    bounds = phase_boundaries(p)
    assert set(bounds) == {"chamfer_start", "tip_on_wall_start", "two_point_mirror_start"}
    wall = state_at(p, 0.0)
    l_m = bounds["two_point_mirror_start"]
    assert l_m == pytest.approx(p.diametral_clearance_m / -wall.theta_rad, rel=1e-12)
    assert not wedging_possible(p)  # l_m = 18.6 mm > mu d

    df = curve(p)
    assert phase_runs(df.phase) == ["chamfer", "tip_on_wall", "two_point_mirror"]
    on_wall = df[df.phase == "tip_on_wall"]
    for col in COLUMNS:
        assert np.allclose(on_wall[col], getattr(wall, col), rtol=1e-12, atol=0.0), col
    edge = curve(p, np.array([np.nextafter(l_m, -np.inf), l_m]))
    for col in COLUMNS:
        assert edge[col][1] == pytest.approx(edge[col][0], rel=1e-9, abs=1e-15), col

    mirror = df[df.phase == "two_point_mirror"]
    assert mirror.theta_rad.to_numpy() == pytest.approx(-p.diametral_clearance_m / mirror.depth_m)
    g1 = -(mirror.moment_nm + p.friction * p.peg_radius_m * mirror.f_x_n) / mirror.depth_m
    g2 = g1 - mirror.f_x_n
    assert (g1 >= -1e-12).all() and (g2 > 0).all()
    assert mirror.f_z_n.to_numpy() == pytest.approx(p.friction * (g1 + g2).to_numpy())


def test_frictionless_peg_has_an_infinite_wedging_angle():
    assert WhitneyParams(friction=0.0).wedging_angle_rad == math.inf
    assert WhitneyParams(friction=0.6).wedging_angle_rad == pytest.approx(
        WhitneyParams().clearance_ratio / 0.6
    )
