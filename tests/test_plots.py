"""Figures: deterministic bytes with provenance inside, and aggregates that survive failures."""

import hashlib

import numpy as np
import pandas as pd
from PIL import Image

from pih.records.provenance import record
from pih.reporting import plots


def _saved(tmp_path, name):
    fig = plots.cost_band_figure(
        pd.DataFrame(
            {"method": "a", "iteration": [1, 2], "mean": [2.0, 1.0], "std": 0.1, "count": 3}
        )
    )
    png, pdf = tmp_path / f"{name}.png", tmp_path / f"{name}.pdf"
    plots.save(fig, png, pdf, provenance=record("fig", point={"k": 1}))
    return png, pdf


def test_figures_carry_stable_provenance_and_rerun_byte_identical(tmp_path):
    first, second = _saved(tmp_path, "a"), _saved(tmp_path, "b")
    for a, b in zip(first, second):
        assert hashlib.sha256(a.read_bytes()).digest() == hashlib.sha256(b.read_bytes()).digest()
    text = Image.open(first[0]).text["pih.provenance"]
    assert '"run_id":"fig/k=1"' in text and "created_utc" not in text
    assert b"fig/k=1" in first[1].read_bytes()


def test_cost_bands_of_runs_where_everything_diverged_still_plot(tmp_path):
    bands = pd.DataFrame(
        {"method": "a", "iteration": [1, 2], "mean": np.nan, "std": np.nan, "count": 0}
    )
    plots.save(plots.cost_band_figure(bands), tmp_path / "all_diverged.png")
    assert (tmp_path / "all_diverged.png").stat().st_size > 1000


def _validation_inputs(offsets=(0.0005, 0.001, 0.0015, 0.002)):
    """Theory and simulated curves with phase markers a fraction of a millimetre apart."""
    depth = np.linspace(-0.001, 0.045, 200)
    theory = {
        o: pd.DataFrame({"depth_m": depth, "f_x_n": -1 + np.exp(-300 * depth.clip(0))})
        for o in offsets
    }
    simulated = {
        (variant, o): pd.DataFrame({"depth_m": depth, "f_x_n": frame["f_x_n"] * 1.05})
        for variant in ("hydroelastic", "point")
        for o, frame in theory.items()
    }
    markers = {o: {"CFC": -0.001, "1PC": -0.0007, "S2PC": 0.0002, "E2PC": 0.04} for o in offsets}
    return simulated, theory, markers


def _boxes(fig, texts):
    renderer = fig.canvas.get_renderer()
    return [t.get_window_extent(renderer) for t in texts]


def test_phase_labels_sit_above_the_curves_without_overlapping_and_the_legend_below():
    fig = plots.validation_curves(*_validation_inputs(), "f_x_n")
    fig.draw_without_rendering()
    renderer = fig.canvas.get_renderer()
    for ax in fig.axes:
        names = [t for t in ax.texts if t.get_text() in {"CFC", "1PC", "S2PC", "E2PC"}]
        assert len(names) == 4
        boxes = _boxes(fig, names)
        top = ax.get_window_extent(renderer).y1
        assert all(box.y0 >= top for box in boxes)  # above the panel: never on a curve
        for i, a in enumerate(boxes):
            assert not any(a.overlaps(b) for b in boxes[i + 1 :])
        title = ax.title.get_window_extent(renderer)
        assert not any(title.overlaps(box) for box in boxes)
    # One legend, for the whole figure, below every panel (never on Fig. 4's -1 N asymptote).
    assert all(ax.get_legend() is None for ax in fig.axes)
    (legend,) = fig.legends
    bottom = min(ax.get_window_extent(renderer).y0 for ax in fig.axes)
    assert legend.get_window_extent(renderer).y1 <= bottom


def test_force_scatter_names_the_diagonal_in_both_panels():
    depth = np.linspace(0, 0.01, 20)
    aligned = {
        (v, 0.001): pd.DataFrame(
            {
                f"{kind}_{q}": np.linspace(0, 1, 20)
                for kind in ("theory", "sim")
                for q in ("f_x_n", "f_z_n")
            }
        ).assign(depth_m=depth)
        for v in ("hydroelastic", "point")
    }
    fig = plots.force_scatter(aligned)
    for ax in fig.axes:
        labels = [t.get_text() for t in ax.get_legend().get_texts()]
        assert any("y = x" in label for label in labels), labels
        assert "(N)" in ax.get_xlabel() and "(N)" in ax.get_ylabel()


def test_a_dense_force_scatter_is_a_pdf_of_a_person_s_size(tmp_path):
    """Fig. 5 draws every aligned sample (≈ 3.6e5 an offset in the validation): its points are
    rasterized in the PDF, its axes and text stay vector, so the file stays ≤ 2 MB (issue 71)."""
    rng = np.random.default_rng(0)
    n = 200_000
    aligned = {
        ("hydroelastic", offset): pd.DataFrame(
            {
                f"{kind}_{q}": rng.normal(size=n)
                for kind in ("theory", "sim")
                for q in ("f_x_n", "f_z_n")
            }
        )
        for offset in (0.001, 0.002)
    }
    fig = plots.force_scatter(aligned)
    assert all(line.get_rasterized() for ax in fig.axes for line in ax.lines[:-1])
    assert not any(ax.xaxis.label.get_rasterized() for ax in fig.axes)
    plots.save(fig, tmp_path / "fig5.png", tmp_path / "fig5.pdf")
    assert (tmp_path / "fig5.pdf").stat().st_size <= 2_000_000


def test_cost_bands_differ_by_more_than_colour():
    bands = pd.DataFrame(
        {
            "method": np.repeat(["a", "b", "c"], 3),
            "iteration": np.tile([1, 2, 3], 3),
            "mean": 1.0,
            "std": 0.5,
            "count": 2,
        }
    )
    ax = plots.cost_band_figure(bands).axes[0]
    hatches = {c.get_hatch() for c in ax.collections if c.get_hatch()}
    assert len(hatches) == 3  # overlapping bands stay apart
    assert all(c.get_alpha() is None or c.get_alpha() <= 0.5 for c in ax.collections)
    styles = {(line.get_linestyle(), line.get_marker()) for line in ax.get_legend().get_lines()}
    assert len(styles) == 3


def _success_rows():
    rows = []
    for dimension, level in [("all", "all"), ("planner.outer.goal_tilt", "explored")]:
        for method, rate in [("one_level", 0.2), ("bilevel/explored_argmin", 0.6)]:
            rows.append(
                {
                    "method": method,
                    "dimension": dimension,
                    "level": level,
                    "runs": 2,
                    "deploy_success_rate": rate,
                    "deploy_ci_low": rate / 2,
                    "deploy_ci_high": (1 + rate) / 2,
                    "final_mean_deploy_success_rate": rate,
                    "final_mean_deploy_ci_low": rate / 2,
                    "final_mean_deploy_ci_high": (1 + rate) / 2,
                }
            )
    return pd.DataFrame(rows)


def _robustness_rows():
    """Deployments from starts 1 mm off per method and goal_tilt level, on the training scene
    and under one model error (which the figure leaves out)."""
    rows = []
    for error, rate in (("none", 0.9), ("friction_0_5", 0.0)):
        for level in ("explored", "sensed"):
            rows.append(
                {
                    "method": "bilevel/explored_argmin",
                    "planner.outer.goal_tilt": level,
                    "start_std_m": 0.001,
                    "model_error": error,
                    "runs": 2,
                    "deploy_success_rate": rate,
                    "deploy_ci_low": rate / 2,
                    "deploy_ci_high": 1.0,
                }
            )
    return pd.DataFrame(rows)


def test_deploy_success_without_a_compared_dimension_draws_no_empty_heading():
    """With no dimension compared, the rows are all runs: no heading row above them."""
    success = _success_rows()
    fig = plots.deploy_success_figure(success[success["dimension"] == "all"], _robustness_rows())
    labels = [t.get_text() for t in fig.axes[0].get_yticklabels()]
    assert labels == ["bilevel/explored_argmin (n = 2 runs)", "one_level (n = 2 runs)"]


def test_deploy_success_rows_name_their_method_and_methods_differ_by_marker():
    fig = plots.deploy_success_figure(_success_rows(), _robustness_rows())
    ax = fig.axes[0]
    labels = [t.get_text() for t in ax.get_yticklabels()]
    # A compared dimension's levels do not pool: no "all runs" group beside them.
    assert labels == [
        "goal_tilt = explored",
        "bilevel/explored_argmin (n = 2 runs)",
        "one_level (n = 2 runs)",
    ]
    handles, names = ax.get_legend_handles_labels()
    assert sorted(names) == [
        "bilevel/explored_argmin, from starts 1 mm off",
        "bilevel/explored_argmin, from the training start",
        "one_level, from the training start",  # one-level was not redeployed here
    ]
    markers = {name: h.lines[0].get_marker() for h, name in zip(handles, names, strict=True)}
    assert (
        markers["one_level, from the training start"]
        != markers["bilevel/explored_argmin, from the training start"]
    )
    # The headline is filled, at the rate of the training scene (not the model error's).
    offset = handles[names.index("bilevel/explored_argmin, from starts 1 mm off")].lines[0]
    assert offset.get_markerfacecolor() != "white" and offset.get_xdata()[0] == 0.9
    legend = ax.get_legend()
    # The legend sits beside the axes, at its top, not below the figure.
    fig.draw_without_rendering()
    renderer = fig.canvas.get_renderer()
    box, axes_box = legend.get_window_extent(renderer), ax.get_window_extent(renderer)
    assert box.x0 >= axes_box.x1 and box.y1 >= axes_box.y1 - 1


def test_best_paths_title_is_centred_over_the_panels():
    from pih.scene.config import HoleConfig

    paths = pd.DataFrame(
        {
            "iteration": [1, 1, 2, 2],
            "time_s": [0.0, 1.0, 0.0, 1.0],
            "peg_bottom_x_m": [-0.03, 0.0, -0.03, 0.0],
            "peg_bottom_y_m": [0.005, -0.005, 0.005, -0.005],
            "robot_x_m": [-0.03, 0.0, -0.03, 0.0],
            "robot_y_m": [0.05, 0.04, 0.05, 0.04],
        }
    )
    fig = plots.best_paths_figure(paths, HoleConfig(), "run")
    panels = [ax for ax in fig.axes if ax.get_label() != "<colorbar>"]
    centre = (panels[0].get_position().x0 + panels[-1].get_position().x1) / 2
    assert abs(fig._suptitle.get_position()[0] - centre) < 1e-6
