"""Hydroelastic (and point-contact) simulation vs Whitney's theory (paper §2.4, Tables 2–3).

The experiment: the robot moves straight down at a slow constant speed with the spring base
laterally fixed at an offset ε0 from the hole axis (θ0 = 0), as in Whitney's quasi-static model.
The comparison maps the simulated trace to Whitney's conventions (docs/whitney.md: +u toward the
error side, F_x < 0, F_z > 0 downward push, θ > 0 leaning toward +u), aligns it in depth on the
first force peak as the paper does (and reports that shift, the hydroelastic "depth delay"), and
computes Pearson r of F_x and F_z over the aligned insertion (Table 3) and relative errors of the
initial (chamfer-peak) and final forces and the final angle (Table 2).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from pih.records.outputs import markdown_table
from pih.records.sampling import envelope_indices
from pih.scene.config import SceneConfig
from pih.scene.trace import RobotTrajectory, Trace
from pih.validation.config import ValidationConfig
from pih.whitney import theory as whitney
from pih.whitney.frame import error_side

if TYPE_CHECKING:
    from pih.scene.simulation import PegInHoleScene

ENTRANCE_SIDE_M = 1e-9
TABLE2_FEATURES = {
    "initial_f_x": "n",
    "initial_f_z": "n",
    "final_f_x": "n",
    "final_f_z": "n",
    "final_theta": "rad",
}
"""Table 2's features (the chamfer peak and the final values) and their units."""
# Paper Table 2: relative error (%) of the hydroelastic model against Whitney, per offset ε0 (m).
PAPER_RELATIVE_ERROR_PCT: dict[str, dict[float, float]] = {
    "initial_f_x": {0.0005: 10.7575, 0.001: 6.9288, 0.0015: 0.9780, 0.002: 2.9370},
    "final_f_x": {0.0005: 0.2918, 0.001: 0.3686, 0.0015: 0.5088, 0.002: 0.8534},
    "initial_f_z": {0.0005: 0.026, 0.001: 2.7455, 0.0015: 5.0961, 0.002: 7.8345},
    "final_f_z": {0.0005: 12.7314, 0.001: 11.7067, 0.0015: 10.4138, 0.002: 7.3891},
    "final_theta": {0.0005: 25.7437, 0.001: 22.9141, 0.0015: 19.2098, 0.002: 14.3666},
}
# Paper Table 3: Pearson r over the aligned insertion, all offsets.
PAPER_PEARSON_R = {"r_f_x": 0.9954, "r_f_z": 0.9032}
ADMISSIBLE_TABLE2_PCT = max(max(cells.values()) for cells in PAPER_RELATIVE_ERROR_PCT.values())
"""The selection rule's bound on every Table 2 cell: the paper's own worst cell (25.7 %)."""


def whitney_params(scene: SceneConfig, offset_m: float) -> whitney.WhitneyParams:
    """Whitney's parameters of the simulated scene (compliance centre = spring point P1)."""
    params = whitney.WhitneyParams(
        k_x_n_per_m=scene.spring.stiffness[0],
        k_theta_nm_per_rad=scene.spring.stiffness[2],
        hole_diameter_m=scene.hole.diameter_m,
        peg_diameter_m=scene.peg.diameter_m,
        compliance_length_m=scene.peg.length_m,
        friction=scene.material.friction,
        chamfer_angle_rad=math.radians(scene.hole.chamfer_angle_deg),
        chamfer_width_m=scene.hole.chamfer_width_m,
        theta0_rad=0.0,
        offset_m=abs(offset_m),
    )
    params.validate()
    return params


def straight_down(
    scene: PegInHoleScene, offset_m: float, config: ValidationConfig
) -> RobotTrajectory:
    """Constant-speed descent with the spring base at x_H − offset (the paper's x_P < 0)."""
    hole = scene.config.hole
    start = scene.peg_top_from_bottom(
        [hole.x_m - offset_m, hole.top_y_m + config.start_height_m, 0.0]
    )
    travel = config.start_height_m + config.robot_depth_m
    duration = travel / config.speed_m_per_s
    t = np.linspace(0.0, duration, max(2, round(duration / 0.01) + 1))
    poses = np.tile(start, (t.size, 1))
    poses[:, 1] -= config.speed_m_per_s * t
    return RobotTrajectory(t, poses)


def run_insertion(scene: PegInHoleScene, offset_m: float, config: ValidationConfig) -> Trace:
    """Simulate the quasi-static straight-down insertion at lateral offset ε0 = ``offset_m``."""
    whitney_params(scene.config, offset_m)  # reject offsets outside the theory's range first
    return scene.rollout(straight_down(scene, offset_m, config))


def to_whitney_frame(trace: Trace, hole_x_m: float) -> pd.DataFrame:
    """Depth ℓ, F_x, F_z and θ of a trace in Whitney's conventions, first pass of each depth only
    (samples where ℓ exceeds every earlier ℓ), so the curve is a function of depth."""
    side = error_side(trace.q_robot[0, 0], hole_x_m)
    frame = pd.DataFrame(
        {
            "depth_m": trace.insertion_depth_m,
            "f_x_n": side * trace.contact_force[:, 0],
            "f_z_n": trace.contact_force[:, 1],
            "theta_rad": -side * trace.q_peg[:, 2],
            "time_s": trace.time_s,
        }
    )
    deeper = frame["depth_m"] > frame["depth_m"].cummax().shift(fill_value=-np.inf)
    return frame[deeper].reset_index(drop=True)


def first_peak_depth(sim: pd.DataFrame, params: whitney.WhitneyParams) -> float:
    """Depth of the simulated chamfer-crossing force peak: max F_z within the chamfer window
    (from first contact to one chamfer height past the entrance)."""
    z_c = whitney.chamfer_height(params)
    window = sim[(sim["depth_m"] >= -z_c - 1e-3) & (sim["depth_m"] <= z_c) & (sim["f_z_n"] > 0)]
    if window.empty:
        raise ValueError(
            "no contact force in the chamfer window: the peg never touched the chamfer"
        )
    return float(window["depth_m"].iloc[int(np.argmax(window["f_z_n"].to_numpy()))])


CONTACT_THRESHOLD_N = 1e-3
"""F_z above which the simulated peg counts as touching the chamfer (chamfer_start alignment)."""
ALIGNMENTS: tuple[str, ...] = ("chamfer_start", "first_peak")
"""Depth alignments, primary first: the paper's (first simulated contact on Whitney's chamfer
start −z_c) and ours before (the first simulated force peak on Whitney's peak at ℓ → 0⁻)."""


def first_contact_depth(sim: pd.DataFrame, threshold_n: float = CONTACT_THRESHOLD_N) -> float:
    """Unaligned depth where the simulated F_z first exceeds ``threshold_n``, interpolated
    linearly between samples: the start of the chamfer crossing."""
    f, d = sim["f_z_n"].to_numpy(), sim["depth_m"].to_numpy()
    above = np.flatnonzero(f > threshold_n)
    if above.size == 0:
        raise ValueError("no contact force: the peg never touched the chamfer")
    i = int(above[0])
    if i == 0:
        return float(d[0])
    return float(d[i - 1] + (threshold_n - f[i - 1]) / (f[i] - f[i - 1]) * (d[i] - d[i - 1]))


STORED_COLUMNS: tuple[str, ...] = (
    "time_s",
    *(f"{frame}_{axis}" for frame in ("robot", "peg") for axis in ("x_m", "y_m", "theta_rad")),
    "contact_fx_n",
    "contact_fy_n",
    "contact_moment_nm",
    "insertion_depth_m",
)
"""The columns a validation trace file keeps: what the comparison reads, and the poses and
contact wrench that draw the insertion again (the spring and the peg's other points follow from
them)."""
STORED_BIN_RATE_HZ = 100.0
"""Past the depths the comparison reads, a trace file keeps each 1/rate s bin's extremes."""


def stored_samples(
    trace: Trace, scene: SceneConfig, offset_m: float, config: ValidationConfig
) -> NDArray[np.intp]:
    """The steps a validation trace file keeps: every one until the tip first passes the deepest
    depth any comparison reads (the final depth under either alignment, and the chamfer height,
    up to which the first peak is looked for), then each 1/:data:`STORED_BIN_RATE_HZ` s bin's
    first, lowest and highest F_x, F_z, θ and depth, and the last. :func:`compare`'s metrics and
    aligned window from the kept steps are the whole trace's, value for value (its whole
    simulated curve is thinned past them); a trace without chamfer contact is kept whole."""
    params = whitney_params(scene, offset_m)
    sim = to_whitney_frame(trace, scene.hole.x_m)
    try:
        shifts = [alignment_shift(sim, params, alignment) for alignment in ALIGNMENTS]
    except ValueError:
        return np.arange(len(trace))
    depth = trace.insertion_depth_m
    # The negation of compare()'s window test, written alike, so no rounding tells them apart.
    beyond = depth > whitney.chamfer_height(params)
    for shift in shifts:
        beyond &= depth + shift > config.final_depth_m
    passed = np.flatnonzero(beyond)
    if passed.size == 0:
        return np.arange(len(trace))
    cut = int(passed[0]) + 1
    time_s = trace.time_s[cut:]
    series = (
        trace.contact_force[cut:, 0],
        trace.contact_force[cut:, 1],
        trace.q_peg[cut:, 2],
        depth[cut:],
    )
    tail = [envelope_indices(time_s, values, STORED_BIN_RATE_HZ, 0.0) for values in series]
    return np.concatenate([np.arange(cut), cut + np.unique(np.concatenate(tail))])


def alignment_shift(sim: pd.DataFrame, params: whitney.WhitneyParams, alignment: str) -> float:
    """The depth shift that aligns the simulated curve ``sim`` (:func:`to_whitney_frame`) under
    ``alignment`` (:data:`ALIGNMENTS`)."""
    if alignment == "chamfer_start":
        return -whitney.chamfer_height(params) - first_contact_depth(sim)
    if alignment == "first_peak":
        # Whitney's chamfer peak is at l → 0⁻: put the simulated peak just before the entrance,
        # not on l = 0 itself, where the theory has already jumped to its one-point value.
        return -ENTRANCE_SIDE_M - first_peak_depth(sim, params)
    raise ValueError(f"alignment must be one of {ALIGNMENTS}, got {alignment!r}")


@dataclass(frozen=True)
class Comparison:
    """One offset's Table 2/3 metrics, the aligned curves in the metrics window (sim and theory
    at the same depths), and the whole aligned simulated curve (for figures)."""

    metrics: dict[str, float | str]
    aligned: pd.DataFrame
    simulated: pd.DataFrame


def compare(
    trace: Trace,
    scene: SceneConfig,
    offset_m: float,
    config: ValidationConfig,
    alignment: str = ALIGNMENTS[0],
) -> Comparison:
    """Table 2/3 metrics of one trace under one depth alignment (:data:`ALIGNMENTS`)."""
    params = whitney_params(scene, offset_m)
    sim = to_whitney_frame(trace, scene.hole.x_m)
    z_c = whitney.chamfer_height(params)
    shift = alignment_shift(sim, params, alignment)
    sim["depth_m"] = sim["depth_m"] + shift
    window = sim[(sim["depth_m"] >= -z_c) & (sim["depth_m"] <= config.final_depth_m)].reset_index(
        drop=True
    )
    theory = whitney.curve(params, window["depth_m"].to_numpy())
    aligned = pd.DataFrame(
        {
            "depth_m": window["depth_m"],
            "sim_f_x_n": window["f_x_n"],
            "sim_f_z_n": window["f_z_n"],
            "sim_theta_rad": window["theta_rad"],
            "theory_f_x_n": theory["f_x_n"].to_numpy(),
            "theory_f_z_n": theory["f_z_n"].to_numpy(),
            "theory_theta_rad": theory["theta_rad"].to_numpy(),
        }
    )
    reached = float(sim["depth_m"].max())
    peak_theory = whitney.state_at(params, -1e-9 * z_c)
    # The simulated "initial" value: the largest F_z in the aligned chamfer (not a chatter spike
    # after the entrance), else the sample nearest the entrance.
    chamfer = sim[(sim["depth_m"] >= -z_c - 1e-4) & (sim["depth_m"] < 0.0)]
    peak_sim = (
        chamfer.iloc[int(np.argmax(chamfer["f_z_n"].to_numpy()))]
        if len(chamfer)
        else sim.iloc[int(np.argmin(np.abs(sim["depth_m"].to_numpy())))]
    )
    metrics: dict[str, float | str] = {
        "offset_m": offset_m,
        "alignment_shift_m": shift,
        "reached_depth_m": reached,
        "trace_status": trace.status,
        "n_samples": float(len(aligned)),
        "r_f_x": _pearson(aligned["sim_f_x_n"], aligned["theory_f_x_n"]),
        "r_f_z": _pearson(aligned["sim_f_z_n"], aligned["theory_f_z_n"]),
        "initial_f_x_sim_n": float(peak_sim["f_x_n"]),
        "initial_f_x_theory_n": peak_theory.f_x_n,
        "initial_f_z_sim_n": float(peak_sim["f_z_n"]),
        "initial_f_z_theory_n": peak_theory.f_z_n,
    }
    final = aligned[aligned["depth_m"] >= config.final_depth_m - config.final_window_m]
    complete = reached >= config.final_depth_m and not final.empty
    for quantity, unit in (("f_x", "n"), ("f_z", "n"), ("theta", "rad")):
        for source in ("sim", "theory"):
            column = f"{source}_{quantity}_{unit}"
            value = float(final[column].mean()) if complete else math.nan
            metrics[f"final_{quantity}_{source}_{unit}"] = value
    for key, unit in TABLE2_FEATURES.items():
        metrics[f"rel_err_{key}_pct"] = _relative_error(
            metrics[f"{key}_sim_{unit}"], metrics[f"{key}_theory_{unit}"]
        )
    metrics["trace_status"] = plausibility(metrics, trace.status)
    return Comparison(metrics=metrics, aligned=aligned, simulated=sim)


IMPLAUSIBLE_RATIO = 10.0
"""A simulated force this many times larger or smaller than the theory's is not a model error
but a broken setting (e.g. a 1 Pa modulus gives µN forces against Whitney's newtons)."""


def plausibility(metrics: Mapping[str, float | str], status: str) -> str:
    """``implausible`` when the chamfer-peak or final F_z is off the theory by more than
    :data:`IMPLAUSIBLE_RATIO` either way; otherwise the trace's own status."""
    for when in ("initial", "final"):
        sim, theory = float(metrics[f"{when}_f_z_sim_n"]), float(metrics[f"{when}_f_z_theory_n"])
        if math.isfinite(sim) and math.isfinite(theory) and theory > 0:
            ratio = abs(sim) / theory
            if not 1 / IMPLAUSIBLE_RATIO <= ratio <= IMPLAUSIBLE_RATIO:
                return "implausible"
    return status


def pooled_correlation(aligned: list[pd.DataFrame]) -> dict[str, float]:
    """r of F_x and F_z over the samples of all offsets together (the paper's Table 3)."""
    both = pd.concat(aligned, ignore_index=True)
    return {
        "r_f_x": _pearson(both["sim_f_x_n"], both["theory_f_x_n"]),
        "r_f_z": _pearson(both["sim_f_z_n"], both["theory_f_z_n"]),
        "n_samples": float(len(both)),
    }


def _pearson(a: pd.Series, b: pd.Series) -> float:
    x, y = np.asarray(a, float), np.asarray(b, float)
    if x.size < 3 or np.std(x) == 0 or np.std(y) == 0:
        return math.nan
    return float(np.corrcoef(x, y)[0, 1])


def _relative_error(sim: float | str, theory: float | str) -> float:
    sim, theory = float(sim), float(theory)
    if not (math.isfinite(sim) and math.isfinite(theory)) or theory == 0.0:
        return math.nan
    return 100.0 * abs(sim - theory) / abs(theory)


def phase_markers(params: whitney.WhitneyParams) -> dict[str, float]:
    """The paper's figure markers: CFC, 1PC, S2PC, E2PC (depth, m)."""
    bounds = whitney.phase_boundaries(params)
    labels = {
        "CFC": "chamfer_start",
        "1PC": "one_point_start",
        "S2PC": "two_point_start",
        "E2PC": "two_point_end",
    }
    return {label: bounds[key] for label, key in labels.items() if key in bounds}


SETTING_COLUMNS: dict[str, tuple[str, str]] = {
    "contact_model": ("", "Drake contact model"),
    "discrete_contact_approximation": ("", "Drake's discrete contact solver"),
    "fillet_radius_m": ("m", "chamfer-wall fillet radius"),
    "margin_m": ("m", "hydroelastic margin"),
    "hydroelastic_modulus_pa": ("Pa", "hydroelastic modulus of the peg"),
    "point_stiffness_n_per_m": ("N/m", "point-contact stiffness"),
    "time_step_s": ("s", "simulator time step"),
}
COMPARISON_COLUMNS: dict[str, tuple[str, str]] = {
    "variant": ("", "validation variant (validation.variants)"),
    **SETTING_COLUMNS,
    "alignment": ("", "depth alignment: chamfer_start (the paper's) or first_peak"),
    "offset": ("", "lateral offset label, or 'pooled' for all offsets of the variant"),
    "offset_m": ("m", "lateral offset eps0 of the spring base from the hole axis"),
    "trace_status": (
        "",
        "ok; diverged (metrics cover the depth reached); implausible (F_z off the theory by > 10x)",
    ),
    "note": ("", "why a run stopped or could not be compared"),
    "alignment_shift_m": ("m", "depth shift applied to the simulated curve by the alignment"),
    "reached_depth_m": ("m", "deepest aligned insertion depth reached"),
    "n_samples": ("1", "samples in the correlation window"),
    "r_f_x": ("1", "Pearson r of F_x, simulated vs theory (Table 3)"),
    "r_f_z": ("1", "Pearson r of F_z, simulated vs theory (Table 3)"),
    **{
        f"{when}_{q}_{source}_{unit}": (unit_name, f"{when} {q} ({source})")
        for when in ("initial", "final")
        for q, unit, unit_name in (("f_x", "n", "N"), ("f_z", "n", "N"), ("theta", "rad", "rad"))
        for source in ("sim", "theory")
        if not (when == "initial" and q == "theta")
    },
    **{
        f"rel_err_{key}_pct": ("%", f"relative error of the {key.replace('_', ' ')} (Table 2)")
        for key in TABLE2_FEATURES
    },
}
VARIANT_COLUMNS: dict[str, tuple[str, str]] = {
    **COMPARISON_COLUMNS,
    "complete": ("", "pooled rows: every offset ran through the final depth without divergence"),
    "max_rel_err_pct": ("%", "pooled rows: the largest Table 2 error over all offsets"),
    "admissible": (
        "",
        "pooled rows: complete, and every Table 2 error within the paper's worst (25.7 %)",
    ),
    "r_min": ("1", "pooled rows: the weaker of r(F_x) and r(F_z), what the rule ranks"),
    "chosen": ("", "pooled rows: the selection rule's choice for its contact model"),
}
ALIGNED_COLUMNS: dict[str, tuple[str, str]] = {
    "variant": ("", "validation variant"),
    "offset_m": ("m", "lateral offset eps0"),
    "depth_m": ("m", "aligned insertion depth l"),
    "f_x_n": ("N", "lateral contact force, Whitney's sign (negative toward the error side)"),
    "f_z_n": ("N", "insertion force (upward contact force = downward push)"),
    "theta_rad": ("rad", "peg tilt, positive toward the error side"),
    "time_s": ("s", "simulated time"),
}


def variant_settings(scene: SceneConfig) -> dict[str, float | str]:
    """The contact settings a variant can change, as table columns."""
    return {
        "contact_model": scene.solver.contact_model,
        "discrete_contact_approximation": scene.solver.discrete_contact_approximation,
        "fillet_radius_m": scene.hole.fillet_radius_m,
        "margin_m": scene.material.margin_m,
        "hydroelastic_modulus_pa": scene.material.hydroelastic_modulus_pa,
        "point_stiffness_n_per_m": scene.material.point_stiffness_n_per_m,
        "time_step_s": scene.solver.time_step_s,
    }


def comparison_table(
    traces: Mapping[tuple[str, float], Trace],
    scenes: Mapping[str, SceneConfig],
    config: ValidationConfig,
) -> tuple[pd.DataFrame, dict[tuple[str, float], Comparison]]:
    """Table 2/3 rows per (variant, alignment, offset) and a pooled row per variant and
    alignment; ``traces`` are keyed by (variant, offset) and ``scenes`` give each variant's
    scene. The comparisons (for figures) use the primary alignment. A trace that cannot be
    compared (no chamfer contact) gets a row with its status and NaN metrics."""
    rows: list[dict] = []
    comparisons: dict[tuple[str, float], Comparison] = {}
    for variant in dict.fromkeys(v for v, _ in traces):
        settings = {"variant": variant, **variant_settings(scenes[variant])}
        for alignment in ALIGNMENTS:
            aligned = []
            for (trace_variant, offset), trace in traces.items():
                if trace_variant != variant:
                    continue
                row = {
                    **settings,
                    "alignment": alignment,
                    "offset": f"{1e3 * offset:g} mm",
                    "offset_m": offset,
                }
                try:
                    result = compare(trace, scenes[variant], offset, config, alignment)
                except ValueError as error:
                    # The experiment puts the peg on the chamfer by construction: no measurable
                    # contact there is a broken setting, not a result.
                    rows.append({**row, "trace_status": "implausible", "note": str(error)})
                    continue
                if alignment == ALIGNMENTS[0]:
                    comparisons[(variant, offset)] = result
                aligned.append(result.aligned)
                rows.append({**row, **result.metrics, "note": trace.reason})
            pooled = pooled_correlation(aligned) if aligned else {}
            rows.append({**settings, "alignment": alignment, "offset": "pooled", **pooled})
    table = pd.DataFrame(rows).reindex(columns=list(COMPARISON_COLUMNS))
    table["note"] = table["note"].fillna("")
    return table, comparisons


def choose_variants(table: pd.DataFrame, alignment: str = ALIGNMENTS[0]) -> pd.DataFrame:
    """The variants table: ``table`` (from :func:`comparison_table`) with, on each pooled row,
    whether the variant is *complete* (every offset ``ok`` through the final depth), its largest
    Table 2 error, whether it is *admissible*, the weaker of its pooled r, and whether it is
    *chosen*. The selection rule (docs/validation.md) reads everything Whitney gives: per contact
    model, among the admissible variants (complete, every Table 2 cell within the paper's own
    worst, :data:`ADMISSIBLE_TABLE2_PCT`), the one whose weaker pooled r of F_x and F_z (Table 3)
    is highest under ``alignment`` (the paper's chamfer-start alignment). A variant cannot buy
    F_x agreement with F_z."""
    out = table.copy()
    per_offset = out[out["offset"] != "pooled"]
    errors = [f"rel_err_{key}_pct" for key in TABLE2_FEATURES]
    complete, worst = {}, {}
    for (variant, align), runs in per_offset.groupby(["variant", "alignment"], sort=False):
        complete[(variant, align)] = bool(
            (runs["trace_status"] == "ok").all() and runs[errors[-1]].notna().all()
        )
        worst[(variant, align)] = float(runs[errors].max(axis=None))
    pooled = out["offset"] == "pooled"
    keys = list(zip(out["variant"], out["alignment"]))
    out["complete"] = pd.array(
        [complete.get(k, False) if p else None for k, p in zip(keys, pooled)], dtype="boolean"
    )
    out["max_rel_err_pct"] = [
        worst.get(k, math.nan) if p else math.nan for k, p in zip(keys, pooled)
    ]
    within = out["max_rel_err_pct"] <= ADMISSIBLE_TABLE2_PCT
    out["admissible"] = pd.array(
        [bool(c and w) if p else None for c, w, p in zip(out["complete"], within, pooled)],
        dtype="boolean",
    )
    out["r_min"] = out[["r_f_x", "r_f_z"]].min(axis=1, skipna=False).where(pooled)
    out["chosen"] = False
    candidates = out[pooled & (out["alignment"] == alignment) & out["admissible"].fillna(False)]
    family = candidates["contact_model"].replace({"hydroelastic_with_fallback": "hydroelastic"})
    for _, group in candidates.groupby(family):
        if group["r_min"].notna().any():
            out.loc[group["r_min"].idxmax(), "chosen"] = True
    return out.reindex(columns=list(VARIANT_COLUMNS))


def variants_markdown(table: pd.DataFrame, overrides: Mapping[str, Mapping[str, object]]) -> str:
    """``variants.md``: the pooled comparison per variant and alignment (with the rule's choice),
    then every offset's Table 2/3 numbers."""
    pooled = table[table["offset"] == "pooled"]
    summary = pd.DataFrame(
        {
            "variant": pooled["variant"],
            "changes": [
                ", ".join(
                    f"{k}={x:g}" if isinstance(x, float) else f"{k}={x}"
                    for k, x in overrides.get(v, {}).items()
                )
                or "(base)"
                for v in pooled["variant"]
            ],
            "alignment": pooled["alignment"],
            "r(F_x)": pooled["r_f_x"],
            "r(F_z)": pooled["r_f_z"],
            "max Table 2 error (%)": pooled["max_rel_err_pct"],
            "complete": pooled["complete"],
            "admissible": pooled["admissible"],
            "weaker r (1)": pooled["r_min"],
            "chosen": pooled["chosen"].map({True: "**chosen**", False: ""}),
        }
    )
    runs = table[table["offset"] != "pooled"]
    detail = pd.DataFrame(
        {
            "variant": runs["variant"],
            "alignment": runs["alignment"],
            "ε0 (mm)": 1e3 * runs["offset_m"],
            "status": runs["trace_status"],
            "reached (mm)": 1e3 * runs["reached_depth_m"],
            "shift (mm)": 1e3 * runs["alignment_shift_m"],
            "r(F_x)": runs["r_f_x"],
            "r(F_z)": runs["r_f_z"],
            **{
                f"{key.replace('_', ' ')} (%)": runs[f"rel_err_{key}_pct"]
                for key in TABLE2_FEATURES
            },
        }
    )
    return f"""# Validation variants against Whitney's theory

Every variant is the validation scene (`validation.scene_overrides`) with the listed changes,
run at every offset. Pooled r is over all offsets' samples (paper Table 3); the Table 2 error is
the largest relative error of the chamfer-peak and final values over all offsets. *complete*:
every offset ran through the final depth without divergence.

**Selection rule** (docs/validation.md): per contact model, among the *admissible* variants
(complete, and every Table 2 error within the paper's own worst cell, {ADMISSIBLE_TABLE2_PCT:.1f} %),
the one whose weaker pooled r of F_x and F_z is highest, under the paper's alignment
(chamfer_start). Nothing is tuned per offset.

{markdown_table(summary, "{:.4g}")}
## Per offset

{markdown_table(detail, "{:.3g}")}"""


def aligned_curves(comparisons: Mapping[tuple[str, float], Comparison]) -> pd.DataFrame:
    """Every aligned simulated curve, in Whitney's conventions, as one table."""
    return pd.concat(
        [c.simulated.assign(variant=v, offset_m=o) for (v, o), c in comparisons.items()],
        ignore_index=True,
    )[list(ALIGNED_COLUMNS)]
