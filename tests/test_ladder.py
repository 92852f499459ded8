"""The deployment ladder: rungs of harder real scenes, each run's score over the rungs every run
has, pairs between methods and between a training model and its twin."""

import math

import pandas as pd
import pytest

from pih.analysis.ladder import ALL_RUNGS, ladder_pairs, ladder_runs, ladder_table, rung_label

KEYS = ["planner.goal", "planner.start_x_m", "planner.seed"]


def deployments(rates: dict[tuple[str, str], list[float]]) -> pd.DataFrame:
    """Deployments of two methods at three starts on the rungs given, keyed (rung, method)."""
    rungs = {
        "trained": (0.0, "none", 0.0),
        "starts 1 mm off": (0.001, "none", 0.0),
        "starts 1.25 mm off": (0.00125, "none", 0.0),
        "hole +1 mm": (0.001, "hole_right_1mm", 0.001),
        "friction": (0.001, "friction_0_5", math.nan),
    }
    rows = []
    for (rung, method), values in rates.items():
        std, error, shift = rungs[rung]
        for start, rate in zip(("-0.04", "-0.035", "-0.03"), values, strict=False):
            rows.append(
                {
                    "method": method,
                    "run": f"{method}@{start}",
                    "planner.start_x_m": start,
                    "planner.seed": "0",
                    "start_std_m": std,
                    "model_error": error,
                    "hole_shift_m": shift,
                    "deploy_success_rate": rate,
                }
            )
    return pd.DataFrame(rows)


def test_rungs_are_offset_starts_and_moved_holes_and_the_score_their_common_mean():
    frame = deployments(
        {
            ("trained", "a"): [1.0, 1.0, 1.0],
            ("starts 1 mm off", "a"): [1.0, 1.0, 0.9],
            ("starts 1.25 mm off", "a"): [1.0, 0.8, 0.7],
            ("hole +1 mm", "a"): [0.0, 0.2],  # the last run lacks this rung
            ("friction", "a"): [0.5, 0.5, 0.5],
            ("trained", "b"): [0.3, 0.3, 0.3],
            ("starts 1 mm off", "b"): [0.3, 0.2, 0.1],
            ("starts 1.25 mm off", "b"): [0.3, 0.2, 0.1],
            ("hole +1 mm", "b"): [0.0, 0.3, 0.4],
        }
    )
    runs = ladder_runs(frame, KEYS)
    # The training start and a model error that changes more than the hole are no rungs.
    assert set(runs["rung"]) == {
        "starts 1 mm off",
        "starts 1.25 mm off",
        "hole +1 mm",
        ALL_RUNGS,
    }
    score = runs[runs["rung"] == ALL_RUNGS].set_index("run")["deploy_success_rate"]
    # One run lacks "hole +1 mm": every score is over the two rungs all runs have.
    assert score["a@-0.035"] == pytest.approx((1.0 + 0.8) / 2)
    assert score["b@-0.04"] == pytest.approx((0.3 + 0.3) / 2)
    table = ladder_table(frame, KEYS)
    assert table["rung"].drop_duplicates().tolist() == [
        "starts 1 mm off",
        "starts 1.25 mm off",
        "hole +1 mm",
        ALL_RUNGS,
    ]
    moved = table[(table["rung"] == "hole +1 mm") & (table["method"] == "b")].iloc[0]
    assert (moved["runs"], moved["runs_none_inserted"]) == (3, 1)
    assert moved["deploy_success_rate"] == pytest.approx(0.7 / 3)
    assert moved["hole_shift_m"] == 0.001
    pairs = ladder_pairs(frame, KEYS).set_index("rung")
    hole = pairs.loc["hole +1 mm"]
    # Two pairs (a lacks one run): one tied at 0 of 10, one worse.
    assert (hole["pairs"], hole["better"], hole["worse"], hole["tied"]) == (2, 0, 1, 1)
    assert (hole["tied_at_floor"], hole["tied_at_ceiling"]) == (1, 0)
    assert pairs.loc["starts 1 mm off", "better"] == 3
    assert rung_label(0.00125, 0.0) == "starts 1.25 mm off"
    assert rung_label(0.001, -0.00075, moved_std_m=0.001) == "hole -0.75 mm"
    assert rung_label(0.00125, 0.001, moved_std_m=0.001) == "hole +1 mm, starts 1.25 mm off"


def test_a_training_model_is_paired_with_its_twin_on_every_rung():
    real = deployments(
        {("starts 1 mm off", "a"): [1.0, 1.0, 1.0], ("hole +1 mm", "a"): [1.0, 0.0, 0.5]}
    )
    point = deployments(
        {("starts 1 mm off", "a"): [1.0, 1.0, 1.0], ("hole +1 mm", "a"): [0.0, 0.0, 0.5]}
    )
    keys = [*KEYS, "planner.simulator.contact_model"]
    frame = pd.concat(
        [
            real.assign(**{"planner.simulator.contact_model": "None"}),
            point.assign(
                run=point["run"] + "@point", **{"planner.simulator.contact_model": "point"}
            ),
        ],
        ignore_index=True,
    )
    pairs = ladder_pairs(frame, keys)
    twins = pairs[pairs["versus"] == "a, trained the real scene's model"].set_index("rung")
    assert twins.loc["hole +1 mm", "method"] == "a, trained point"
    assert (twins.loc["hole +1 mm", ["better", "worse", "tied"]] == [0, 1, 2]).all()
    assert twins.loc["starts 1 mm off", "tied_at_ceiling"] == 3
