"""Figures of the study (matplotlib; each written as PNG and PDF, axes with units)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
import pandas as pd

from pih.analysis.aggregate import compared_rows, headline_std, on_training_scene
from pih.analysis.run_summary import best_training_rows
from pih.planning.run_record import Phase, phase_rows
from pih.records.outputs import write_with
from pih.records.provenance import canonical_json, stable
from pih.scene.config import HoleConfig, hole_outline

QUANTITIES = {
    "f_x_n": ("$F_x$ (N)", "Insertion force $F_x$ vs depth (paper Fig. 4)"),
    "f_z_n": ("$F_z$ (N)", "Insertion force $F_z$ vs depth (paper Fig. A1)"),
    "theta_rad": ("$\\theta$ (rad)", "Insertion angle vs depth (paper Fig. A2)"),
}
# Line styles of the figure variants (validation.figure_variants), by name or first word.
VARIANT_STYLE = {
    "hydroelastic": {"color": "tab:blue", "lw": 1.2},
    "point": {"color": "tab:orange", "lw": 1.0, "ls": "--"},
}


def variant_style(variant: str) -> dict[str, object]:
    """A variant's line style, by its name or its name's first word (``point_1e7`` → point)."""
    return VARIANT_STYLE.get(variant, VARIANT_STYLE.get(variant.split("_")[0], {}))


def save(
    fig: plt.Figure,
    png: str | Path,
    pdf: str | Path | None = None,
    provenance: Mapping[str, Any] | None = None,
) -> None:
    """Atomically write a figure as PNG (and PDF), then close it. The PNG carries the stable
    provenance record (no time or host) as a ``pih.provenance`` text chunk, the PDF its run id
    and hashes; neither carries a creation date, so reruns write identical files."""
    record = stable(provenance or {})
    metadata = {
        ".png": {"Software": "pih", "pih.provenance": canonical_json(record)},
        ".pdf": {
            "Creator": "pih",
            "Subject": str(record.get("run_id", "")),
            "Keywords": " ".join(
                f"{key}={record[key]}"
                for key in ("config_sha256", "library_sha256")
                if key in record
            ),
            "CreationDate": None,
        },
    }
    for path in (png, pdf):
        if path is not None:
            suffix = Path(path).suffix

            def write(target: Path, suffix: str = suffix) -> None:
                # A PDF's rasterized artists (dense scatters) at print resolution.
                dpi = 300 if suffix == ".pdf" else 150
                fig.savefig(target, dpi=dpi, bbox_inches="tight", metadata=metadata[suffix])

            write_with(path, write)
    plt.close(fig)


def validation_curves(
    simulated: Mapping[tuple[str, float], pd.DataFrame],
    theory: Mapping[float, pd.DataFrame],
    markers: Mapping[float, Mapping[str, float]],
    quantity: str,
) -> plt.Figure:
    """One panel per offset: Whitney's curve, the aligned simulations (over the theory's depth
    range), and the phase markers."""
    offsets = sorted(theory)
    label, title = QUANTITIES[quantity]
    fig, axes = plt.subplots(
        1, len(offsets), figsize=(4.2 * len(offsets), 4.0), squeeze=False, layout="constrained"
    )
    phases = []  # per panel, the (depth in mm, name) of the phase markers it shows
    for ax, offset in zip(axes[0], offsets):
        curve = theory[offset]
        ax.plot(1e3 * curve["depth_m"], curve[quantity], color="black", lw=1.5, label="Whitney")
        shown = (curve["depth_m"].min(), curve["depth_m"].max())
        for (variant, off), frame in simulated.items():
            if off == offset:
                frame = frame[frame["depth_m"].between(*shown)]
                ax.plot(
                    1e3 * frame["depth_m"],
                    frame[quantity],
                    label=f"Drake {variant}",
                    **variant_style(variant),
                )
        shown_markers = sorted(
            (depth, name)
            for name, depth in markers[offset].items()
            if shown[0] <= depth <= shown[1]
        )
        for depth, _ in shown_markers:
            ax.axvline(1e3 * depth, color="grey", lw=0.6, ls=":")
        phases.append([(1e3 * depth, name) for depth, name in shown_markers])
        ax.set_xlabel("insertion depth $\\ell$ (mm, aligned)")
        ax.set_ylabel(label)
        ax.grid(alpha=0.3)
    # Below the panels, so it never covers a curve (Fig. 4's asymptote at -1 N).
    handles, labels = axes[0][0].get_legend_handles_labels()
    fig.legend(handles, labels, fontsize=7, loc="outside lower center", ncol=len(labels))
    fig.suptitle(title, fontsize=10)
    fig.draw_without_rendering()  # lay out first: the phase names are placed at the final width
    for ax, offset, shown_phases in zip(axes[0], offsets, phases):
        rows = _phase_labels(ax, shown_phases)
        ax.set_title(
            f"$\\epsilon_0$ = {1e3 * offset:g} mm ($x_P$ = {-1e3 * offset:g} mm)",
            fontsize=9,
            pad=6 + PHASE_ROW_PT * rows,
        )
    return fig


PHASE_ROW_PT = 9.0  # height of one row of phase labels above a panel, in points


def _phase_labels(ax: plt.Axes, markers: list[tuple[float, str]]) -> int:
    """Write each phase marker's name above the panel, centred on its line, in the first row
    where it overlaps no other name (phases can start within a millimetre of each other), so
    names collide neither with each other nor with the curves. Returns the rows used."""
    renderer = ax.figure.canvas.get_renderer()
    lo, hi = ax.get_xlim()
    width_pt = ax.get_window_extent(renderer).width * 72 / ax.figure.dpi
    ends: list[float] = []  # per row, the right end (points from the left spine) of its last name
    for x, name in markers:
        text = ax.annotate(
            name,
            (x, 1.0),
            xycoords=("data", "axes fraction"),
            xytext=(0, 2),
            textcoords="offset points",
            fontsize=7,
            va="bottom",
            ha="center",
            color="dimgrey",
            annotation_clip=False,
        )
        half = text.get_window_extent(renderer).width * 36 / ax.figure.dpi + 2
        centre = (x - lo) / (hi - lo) * width_pt
        row = next((k for k, end in enumerate(ends) if centre - half > end), len(ends))
        if row == len(ends):
            ends.append(0.0)
        ends[row] = centre + half
        text.xyann = (0, 2 + PHASE_ROW_PT * row)
    return len(ends)


def force_scatter(aligned: Mapping[tuple[str, float], pd.DataFrame]) -> plt.Figure:
    """Simulated vs theoretical F_x and F_z at the same aligned depth (paper Fig. 5)."""
    fig, axes = plt.subplots(1, 2, figsize=(9, 4))
    offsets = sorted({off for _, off in aligned})
    offset_markers = "os^Dv"
    for ax, quantity in zip(axes, ("f_x_n", "f_z_n")):
        for (variant, offset), frame in aligned.items():
            k = offsets.index(offset)
            ax.plot(
                frame[f"theory_{quantity}"],
                frame[f"sim_{quantity}"],
                offset_markers[k % len(offset_markers)],
                ms=1.5,
                alpha=0.6,
                color=variant_style(variant).get("color", "grey"),
                label=f"{variant}, $\\epsilon_0$ = {1e3 * offset:g} mm",
                # ~3.6e5 points an offset: as vectors the PDF is 44 MB; axes and text stay vector.
                rasterized=True,
            )
        lo, hi = ax.get_xlim()
        ax.plot([lo, hi], [lo, hi], color="black", lw=0.8, label="$y = x$ (simulation = theory)")
        name = QUANTITIES[quantity][0]
        ax.set_xlabel(f"Whitney {name}")
        ax.set_ylabel(f"simulated {name}")
        ax.grid(alpha=0.3)
        # Above the diagonal's left end, where agreeing points are not.
        ax.legend(fontsize=6, markerscale=4, loc="upper left")
    fig.suptitle(
        "Simulated vs theoretical contact force at the same aligned depth (paper Fig. 5)",
        fontsize=10,
    )
    fig.tight_layout()
    return fig


BAND_STYLES = [  # Fig. 9's groups: line style, marker and band hatching, besides colour
    {"ls": "-", "marker": "o", "hatch": "////"},
    {"ls": "--", "marker": "s", "hatch": "\\\\\\\\"},
    {"ls": "-.", "marker": "^", "hatch": "||"},
    {"ls": ":", "marker": "D", "hatch": "--"},
    {"ls": (0, (5, 1)), "marker": "v", "hatch": "xx"},
]


def cost_band_figure(bands: pd.DataFrame, group: str = "method") -> plt.Figure:
    """Mean ± one standard deviation of the best inner cost per iteration (paper Fig. 9)."""
    fig, ax = plt.subplots(figsize=(6.5, 4))
    for k, (level, part) in enumerate(bands.groupby(group)):
        part = part.sort_values("iteration")
        mean, std = part["mean"].to_numpy(), np.nan_to_num(part["std"].to_numpy())
        style = BAND_STYLES[k % len(BAND_STYLES)]
        line = ax.plot(
            part["iteration"],
            mean,
            ls=style["ls"],
            marker=style["marker"],
            ms=3,
            zorder=3,
            label=f"{group} = {level} (n = {int(part['count'].max())})",
        )[0]
        # Bands overlap: each is light, hatched its own way and edged, so none hides another.
        low, high = np.maximum(mean - std, 1e-12), mean + std
        ax.fill_between(
            part["iteration"],
            low,
            high,
            facecolor=line.get_color(),
            alpha=0.12,
            lw=0,
            zorder=1,
        )
        ax.fill_between(
            part["iteration"],
            low,
            high,
            facecolor="none",
            edgecolor=line.get_color(),
            hatch=style["hatch"],
            alpha=0.5,
            lw=0,
            zorder=2,
        )
        for edge in (np.where(mean - std > 0, low, np.nan), high):
            ax.plot(part["iteration"], edge, color=line.get_color(), lw=0.6, ls=style["ls"])
    if (bands["mean"] > 0).any():
        ax.set_yscale("log")
    else:
        ax.text(
            0.5, 0.5, "no finite cost: every rollout diverged", transform=ax.transAxes, ha="center"
        )
    ax.set_xlabel("iteration")
    ax.xaxis.set_major_locator(matplotlib.ticker.MaxNLocator(integer=True))
    ax.set_ylabel("best inner cost $J_{inn}$ (eq. 11, dimensionless)")
    ax.grid(alpha=0.3, which="both")
    ax.legend(fontsize=8)
    ax.set_title(
        "Mean and ±1 s.d. band of the best cost over starts and noise seeds (paper Fig. 9)",
        fontsize=9,
    )
    fig.tight_layout()
    return fig


METHOD_MARKERS = "osD^vP*X"  # deployment figure: one marker per method, besides its colour


def deploy_success_figure(success: pd.DataFrame, robustness: pd.DataFrame) -> plt.Figure:
    """Deployment success with its 95 % interval over runs, the headline filled: from starts
    offset by the smallest σ redeployed (``robustness``, on the training scene), hollow beside
    it from the training start (``success``, :func:`pih.analysis.aggregate.ablation_table`'s
    rows). One bold heading per level of a compared dimension (none when there is none: the
    rows are then all runs), one row per method, named with its run count and drawn in its own
    colour and marker."""
    compared = compared_rows(success)
    table = compared if len(compared) else success[success["dimension"] == "all"]
    trained_scene = on_training_scene(robustness)
    std = headline_std(trained_scene)
    offset = trained_scene[trained_scene["start_std_m"] == std]
    groups = list(dict.fromkeys(zip(table["dimension"], table["level"])))
    methods = sorted(table["method"].unique())
    headed = [group for group in groups if group[0] != "all"]
    fig, ax = plt.subplots(figsize=(8, 0.32 * (len(headed) + len(table)) + 1.4))
    colours = plt.get_cmap("tab10")
    offset_name = f"from starts {1e3 * std:g} mm off" if std else "from offset starts"
    y = 0.0
    ticks, labels, headings = [], [], []
    shown: set[str] = set()
    for dimension, level in groups:
        part = table[(table["dimension"] == dimension) & (table["level"] == level)]
        if dimension != "all":
            ticks.append(y)
            labels.append(f"{dimension.rsplit('.', 1)[-1]} = {level}")
            headings.append(len(labels) - 1)
            y -= 1
        for m, method in enumerate(methods):
            row = part[part["method"] == method]
            if row.empty:
                continue
            nominal = row.iloc[0]
            off = offset[offset["method"] == method]
            if dimension != "all":
                off = off[off[dimension].astype(str) == str(level)]
            marker = METHOD_MARKERS[m % len(METHOD_MARKERS)]
            points = [(nominal, -0.3, "white", f"{method}, from the training start")]
            if len(off):
                points.insert(0, (off.iloc[0], 0.0, colours(m), f"{method}, {offset_name}"))
            for values, shift, face, name in points:
                rate = values["deploy_success_rate"]
                if not np.isfinite(rate):
                    continue
                ax.errorbar(
                    rate,
                    y + shift,
                    xerr=[[rate - values["deploy_ci_low"]], [values["deploy_ci_high"] - rate]],
                    fmt=marker,
                    color=colours(m),
                    mfc=face,
                    ms=6,
                    lw=1.0 if shift == 0 else 0.6,
                    capsize=3,
                    label=None if name in shown else name,
                )
                shown.add(name)
            ticks.append(y)
            labels.append(f"{method} (n = {int(nominal['runs'])} runs)")
            y -= 1
        y -= 0.3
    ax.set_yticks(ticks, labels, fontsize=7)
    for k in headings:
        ax.get_yticklabels()[k].set_fontweight("bold")
    ax.set_ylim(y + 0.6, 0.6)
    ax.set_xlim(-0.02, 1.02)
    ax.set_xlabel(
        "deployment success rate (fraction of trials that inserted; 95 % interval over runs)"
    )
    ax.grid(alpha=0.3, axis="x")
    ax.set_title("Would the learned policy insert if deployed? (beyond the paper)", fontsize=9)
    ax.legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.01, 1.0), borderaxespad=0)
    fig.tight_layout()
    return fig


def scene_figure(scene: Any, start_x_m: float, start_height_m: float) -> plt.Figure:
    """The planar scene at a glance (paper Fig. 2): the hole's chamfered walls and its frame H,
    the peg at its start (tip P2 ``start_height_m`` above the top surface, centre at
    ``start_x_m``) and inserted, and the virtual robot's frame R pulling the peg's top centre P1
    through the spring K = diag(k_x, k_y, k_θ)."""
    hole, peg = scene.hole, scene.peg
    top = hole.y_m + hole.depth_m
    fig, ax = plt.subplots(figsize=(7.5, 3.6), layout="constrained")
    for wall in hole_outline(hole):
        ax.fill(1e3 * wall[:, 0], 1e3 * wall[:, 1], color="tab:brown", alpha=0.35, lw=1)
    half, length = peg.diameter_m / 2, peg.length_m
    poses = (
        (start_x_m, top + start_height_m, "peg at its start", 1.0),
        (hole.x_m, hole.y_m, "inserted: P2 at H", 0.35),
    )
    for x, tip_y, label, alpha in poses:
        outline = np.array([[-half, 0], [half, 0], [half, length], [-half, length], [-half, 0]])
        ax.fill(
            1e3 * (x + outline[:, 0]),
            1e3 * (tip_y + outline[:, 1]),
            color="tab:blue",
            alpha=0.5 * alpha,
            lw=1,
            label=label,
        )
    x, tip_y = start_x_m, top + start_height_m
    p1 = np.array([x, tip_y + length])
    r = p1 + [0.008, 0.004]
    coils = np.linspace(0, 1, 41)
    zigzag = np.outer(coils, r - p1) + p1
    normal = np.array([-(r - p1)[1], (r - p1)[0]]) / np.linalg.norm(r - p1)
    zigzag += np.outer(0.0012 * np.sin(coils * 8 * np.pi) * (coils > 0.1) * (coils < 0.9), normal)
    ax.plot(1e3 * zigzag[:, 0], 1e3 * zigzag[:, 1], color="tab:green", lw=1.2)
    for point, name, offset in (
        (p1, "P1 (peg top centre)", (-80, 6)),
        ((x, tip_y), "P2 (tip)", (-40, -10)),
        (
            r,
            "R: the virtual robot, pulling P1\nthrough the spring K = diag(k_x, k_y, k_θ)",
            (8, -4),
        ),
        ((hole.x_m, hole.y_m), "H", (6, -10)),
    ):
        ax.plot(1e3 * point[0], 1e3 * point[1], "k.", ms=5)
        ax.annotate(
            name, 1e3 * np.asarray(point), xytext=offset, textcoords="offset points", fontsize=7
        )
    ax.set_xlim(1e3 * (start_x_m - 0.02), 1e3 * (hole.x_m + 0.045))
    ax.set_ylim(1e3 * (hole.y_m - 0.005), 1e3 * (top + start_height_m + length + 0.012))
    ax.set_aspect("equal")
    ax.set_xlabel("x (mm)")
    ax.set_ylabel("y (mm)")
    ax.legend(fontsize=7, loc="center right")
    ax.set_title(
        "The planar peg-in-hole scene (x, y, θ): the robot's path is what the planner learns",
        fontsize=9,
    )
    return fig


def ladder_figure(ladder: pd.DataFrame, compared: list[str]) -> plt.Figure:
    """The deployment ladder's picture (:func:`pih.analysis.ladder.ladder_table`): each method's
    deployment success against how far the real hole moved after training, with its 95 %
    interval over runs, 0 the training scene from the same offset starts; one panel per joint
    level of the ``compared`` dimensions. Where the fixed goals fall below one-level's line, its fresh
    sensing (which moves with the hole) has overtaken them."""
    holes = ladder[ladder["hole_shift_m"].notna()]
    std = holes.loc[holes["hole_shift_m"] != 0, "start_std_m"]
    holes = holes[holes["start_std_m"] == (std.iloc[0] if len(std) else holes["start_std_m"].min())]
    panels = list(holes.groupby(compared)) if compared else [((), holes)]
    fig, axes = plt.subplots(
        1, len(panels), figsize=(4.2 * len(panels) + 1.6, 3.6), sharey=True, squeeze=False
    )
    colours = plt.get_cmap("tab10")
    methods = sorted(ladder["method"].unique())
    for ax, (levels, part) in zip(axes[0], panels, strict=True):
        for m, method in enumerate(methods):
            rows = part[part["method"] == method].sort_values("hole_shift_m")
            if rows.empty:
                continue
            shift = 1e3 * rows["hole_shift_m"].to_numpy()
            rate = rows["deploy_success_rate"].to_numpy()
            ax.errorbar(
                shift + 0.03 * (m - (len(methods) - 1) / 2),
                rate,
                yerr=[rate - rows["deploy_ci_low"], rows["deploy_ci_high"] - rate],
                fmt=f"{METHOD_MARKERS[m % len(METHOD_MARKERS)]}-",
                color=colours(m),
                ms=5,
                lw=1.0,
                capsize=2,
                label=f"{method} (n = {int(rows['runs'].max())})",
            )
        levels = levels if isinstance(levels, tuple) else (levels,)
        named = [f"{k.rsplit('.', 1)[-1]} = {v}" for k, v in zip(compared, levels, strict=True)]
        ax.set_title(
            ", ".join(n for n in named if not n.endswith("= None")) or "all runs", fontsize=8
        )
        ax.set_xlabel("real hole moved after training, x (mm)")
        ax.axvline(0, color="grey", lw=0.6, ls=":")
        ax.set_ylim(-0.03, 1.03)
        ax.grid(alpha=0.3)
    std_mm = 1e3 * holes["start_std_m"].iloc[0] if len(holes) else float("nan")
    axes[0][0].set_ylabel(
        f"deployment success rate\n(starts {std_mm:g} mm off; 95 % interval over runs)"
    )
    axes[0][-1].legend(fontsize=7, loc="upper left", bbox_to_anchor=(1.02, 1.0), borderaxespad=0)
    fig.suptitle("The deployment ladder: when does a fixed goal stop inserting?", fontsize=9)
    fig.tight_layout()
    return fig


def run_figure(
    rollouts: pd.DataFrame, best_paths: pd.DataFrame, hole: HoleConfig, title: str
) -> plt.Figure:
    """One planning run: best J_inn per iteration (and the mean weights' J_inn where evaluated),
    the goal's true distance from the hole, and the best peg-tip paths (darker = later), with the
    deployment outcome in the title. Every panel is titled, iterations are whole numbers and a
    legend names only what is drawn."""
    best = best_training_rows(rollouts)
    deploy = phase_rows(rollouts, Phase.DEPLOY)
    fig, (cost_ax, goal_ax, path_ax) = plt.subplots(1, 3, figsize=(14, 4.2))
    cost_ax.plot(best["iteration"], best["cost"], marker=".", label="best rollout")
    means = phase_rows(rollouts, Phase.MEAN)
    if len(means):  # deploy_policy last_inserted_mean: the mean weights' own rollout
        inserted = means[means["success"]]
        cost_ax.plot(means["iteration"], means["cost"], color="tab:orange", lw=0.8, label="mean")
        if len(inserted):
            cost_ax.plot(
                inserted["iteration"],
                inserted["cost"],
                "o",
                color="tab:orange",
                ms=3,
                label="mean inserted",
            )
    cost_ax.legend(fontsize=8)
    if (rollouts["cost"] > 0).any():
        cost_ax.set_yscale("log")
    cost_ax.set_title("(a) inner cost per iteration", fontsize=9)
    cost_ax.set_ylabel("inner cost $J_{inn}$ (eq. 11, dimensionless)")
    goal_ax.plot(best["iteration"], 1e3 * best["target_hole_error_m"], marker=".", label="goal")
    goal_ax.axhline(1.0, color="grey", ls=":", label="1 mm")
    goal_ax.set_title("(b) the best rollout's goal: distance from the true hole", fontsize=9)
    goal_ax.set_ylabel("distance from the hole (mm)")
    goal_ax.set_ylim(bottom=0)
    goal_ax.legend(fontsize=8)
    for ax in (cost_ax, goal_ax):
        ax.set_xlabel("iteration")
        ax.xaxis.set_major_locator(matplotlib.ticker.MaxNLocator(integer=True))
    iterations = sorted(best_paths["iteration"].unique())
    for wall in hole_outline(hole):
        path_ax.plot(1e3 * wall[:, 0], 1e3 * wall[:, 1], color="tab:brown", lw=1)
    for k, iteration in enumerate(iterations):
        part = best_paths[best_paths["iteration"] == iteration]
        shade = plt.get_cmap("Greys")(0.25 + 0.75 * k / max(1, len(iterations) - 1))
        path_ax.plot(
            1e3 * part["peg_bottom_x_m"],
            1e3 * part["peg_bottom_y_m"],
            color=shade,
            lw=0.8,
            label="best peg-tip P2 paths" if k == len(iterations) - 1 else None,
        )
    path_ax.plot(1e3 * hole.x_m, 1e3 * hole.y_m, "r+", ms=10, label="true hole H")
    path_ax.set_title("(c) best paths, iteration 1 light to the last dark", fontsize=9)
    path_ax.set_aspect("equal")
    path_ax.set_xlim(-45, 20)
    path_ax.set_ylim(-15, 15)
    path_ax.set_xlabel("x (mm)")
    path_ax.set_ylabel("y (mm)")
    path_ax.legend(fontsize=7, loc="upper right")
    for ax in (cost_ax, goal_ax, path_ax):
        ax.grid(alpha=0.3)
    outcome = f"deployment {deploy['success'].mean():.0%} of {len(deploy)}" if len(deploy) else ""
    final_mean = phase_rows(rollouts, Phase.DEPLOY_FINAL_MEAN)
    if len(final_mean):
        outcome += f" (the final mean: {final_mean['success'].mean():.0%})"
    fig.suptitle(f"{title}: {outcome}", fontsize=9)
    fig.tight_layout()
    return fig


def best_paths_figure(
    best_paths: pd.DataFrame, hole: HoleConfig, title: str, goals: pd.DataFrame | None = None
) -> plt.Figure:
    """Best peg-tip (a) and robot (b) paths of every iteration, shaded by iteration, with the
    true hole and each iteration's goal (``goals``: the best rollouts' rows with iteration,
    target_x/y_m, the peg-tip target, and goal_x/y_m, the robot's DMP goal) (paper Fig. 8)."""
    fig, axes = plt.subplots(
        1, 2, figsize=(11, 3.4), sharex=True, sharey=True, layout="constrained"
    )
    iterations = sorted(best_paths["iteration"].unique())
    cmap = plt.get_cmap("viridis")
    norm = matplotlib.colors.Normalize(min(iterations, default=1), max(iterations, default=1))
    robot_drop_m = 0.0
    if len(best_paths):
        first = best_paths.iloc[0]
        robot_drop_m = first["robot_y_m"] - first["peg_bottom_y_m"]
    panels = (
        ("peg_bottom", "target", 0.0, "(a) best peg tip P2 paths and peg-tip targets"),
        (
            "robot",
            "goal",
            robot_drop_m,
            (
                f"(b) best robot frame R paths and DMP goals, {1e3 * robot_drop_m:g} mm lower\n"
                "(R is the spring's end, not the peg: it may cross a wall)"
            ),
        ),
    )
    for ax, (path, goal, drop, name) in zip(axes, panels):
        x, y = f"{path}_x_m", f"{path}_y_m"
        for wall in hole_outline(hole):
            ax.plot(1e3 * wall[:, 0], 1e3 * wall[:, 1], color="tab:brown", lw=1)
        for iteration in iterations:
            part = best_paths[best_paths["iteration"] == iteration]
            ax.plot(1e3 * part[x], 1e3 * (part[y] - drop), color=cmap(norm(iteration)), lw=0.8)
        if goals is not None and len(goals):
            ax.scatter(
                1e3 * goals[f"{goal}_x_m"],
                1e3 * (goals[f"{goal}_y_m"] - drop),
                c=goals["iteration"],
                cmap=cmap,
                norm=norm,
                marker="x",
                s=25,
                lw=1.0,
                zorder=3,
                label="goal per iteration",
            )
        ax.plot(1e3 * hole.x_m, 1e3 * hole.y_m, "r+", ms=11, mew=1.5, label="true hole H")
        ax.set_title(name, fontsize=8)
        ax.set_xlabel("x (mm)")
        ax.set_ylabel("y (mm)")
        ax.set_aspect("equal")
        ax.set_xlim(-45, 20)
        ax.set_ylim(-15, 15)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7, loc="lower left")
    fig.colorbar(
        matplotlib.cm.ScalarMappable(norm=norm, cmap=cmap),
        ax=axes,
        label="iteration",
        shrink=0.8,
        ticks=matplotlib.ticker.MaxNLocator(integer=True),
    )
    suptitle = fig.suptitle(f"Best paths per iteration (paper Fig. 8): {title}", fontsize=9)
    # Centred over the two panels, not over the panels and the colour bar.
    fig.draw_without_rendering()
    left, right = axes[0].get_position().x0, axes[1].get_position().x1
    suptitle.set_x((left + right) / 2)
    return fig
