"""What a per-level (marginal) row pools: only the cells every level of its dimension ran, and
the row says which (issue 79)."""

import itertools
from pathlib import Path

import pandas as pd
import pytest

from pih.analysis.aggregate import (
    ALL_RUNS,
    balanced_cells,
    compared_keys,
    cost_bands,
    crossed_keys,
    success_table,
)
from pih.publishing.published import PUBLISHED_STUDIES

ROOT = Path(__file__).resolve().parents[1]
CONTACT, STIFFNESS = "planner.simulator.contact_model", "planner.simulator.point_stiffness_n_per_m"
HOLE, SEED = "planner.simulated_hole", "planner.seed"


def summaries(cells: list[dict[str, str]], rates: list[float], methods=("a",)) -> pd.DataFrame:
    """Per-run rows of :func:`success_table`: each cell run at seeds 0 and 1 by each method,
    deploying at its rate."""
    rows = [
        {"method": method, **cell, SEED: seed, "deploy_success_rate": rate}
        for method, (cell, rate), seed in itertools.product(methods, zip(cells, rates), "01")
    ]
    return pd.DataFrame(rows).assign(
        final_mean_deploy_success_rate=lambda f: f["deploy_success_rate"],
        final_iteration_success=True,
        first_success_iteration=1,
        goal_iteration=1,
        final_success_fraction=1.0,
        mean_policy_last10_success=1.0,
        diverged_fraction=0.0,
        retried_fraction=0.0,
        deploy_diverged_fraction=0.0,
        deploy_repeats_training=False,
    )


def rows(table: pd.DataFrame, method: str, key: str) -> pd.DataFrame:
    return table[(table["method"] == method) & (table["dimension"] == key)].set_index("level")


def test_a_crossed_unbalanced_dimension_pools_the_cells_every_level_ran_and_says_so():
    # The contact-model study pooled with the sim-to-real one: the real scene's model (None)
    # trained on the true and the sensed hole, point contact on the true hole only.
    real = {CONTACT: "None", STIFFNESS: "None"}
    cells = [
        {**real, HOLE: "true_hole"},
        {**real, HOLE: "sensed_per_run"},
        {CONTACT: "point", STIFFNESS: "1e6", HOLE: "true_hole"},
        {CONTACT: "point", STIFFNESS: "1e7", HOLE: "true_hole"},
    ]
    frame = summaries(cells, [1.0, 0.0, 1.0, 0.5], methods=("a", "b"))
    # Method b trained on the true hole only: its levels are balanced.
    frame = frame[(frame["method"] == "a") | (frame[HOLE] == "true_hole")]
    keys = ["planner.goal", SEED, CONTACT, STIFFNESS, HOLE]
    table = success_table(frame, keys)
    true_hole = "only planner.simulated_hole = true_hole"
    contact = rows(table, "a", CONTACT)
    assert contact.loc["None", ["runs", "deploy_success_rate", "pooled"]].tolist() == [
        2,
        1.0,  # not 0.5: the sensed-hole runs are left out
        true_hole,
    ]
    assert contact.loc["point", ["runs", "pooled"]].tolist() == [4, true_hole]
    assert rows(table, "a", STIFFNESS).loc["None", ["runs", "pooled"]].tolist() == [2, true_hole]
    hole = rows(table, "a", HOLE)
    assert hole["runs"].to_dict() == {"sensed_per_run": 2, "true_hole": 2}
    assert set(hole["pooled"]) == {f"only {CONTACT} = None, {STIFFNESS} = None"}
    assert set(rows(table, "b", CONTACT)["pooled"]) == {ALL_RUNS}
    assert set(table[table["dimension"].isin(["all", SEED])]["pooled"]) == {ALL_RUNS}
    assert rows(table, "a", "all")["runs"].tolist() == [8]
    # The cost bands' rows pool the same runs.
    bands = cost_bands(frame.assign(iteration=1, cost=frame["deploy_success_rate"]), keys)
    assert rows(bands, "a", CONTACT).loc["None", ["count", "mean", "pooled"]].tolist() == [
        2,
        1.0,
        true_hole,
    ]


def test_a_balanced_design_pools_every_run_and_a_nested_dimension_is_no_imbalance():
    crossed = [{CONTACT: c, HOLE: h} for c in ("None", "point") for h in ("true_hole", "sensed")]
    frame = summaries(crossed, [1.0, 0.0, 0.5, 0.25])
    table = success_table(frame, ["planner.goal", SEED, CONTACT, HOLE])
    assert set(table["pooled"]) == {ALL_RUNS}
    for key in (CONTACT, HOLE):
        means = frame.groupby(key)["deploy_success_rate"].agg(["size", "mean"])
        level = rows(table, "a", key)
        assert level["runs"].to_dict() == means["size"].to_dict()
        assert level["deploy_success_rate"].to_dict() == means["mean"].to_dict()
    # The stiffness exists only in point contact: part of the contact model's levels, not a
    # design they differ in.
    nested = [
        {CONTACT: "None", STIFFNESS: "None"},
        {CONTACT: "point", STIFFNESS: "1e6"},
        {CONTACT: "point", STIFFNESS: "1e7"},
    ]
    frame = summaries(nested, [1.0, 0.5, 0.0])
    keys = ["planner.goal", SEED, CONTACT, STIFFNESS]
    assert crossed_keys(frame, CONTACT, keys) == crossed_keys(frame, STIFFNESS, keys) == []
    table = success_table(frame, keys)
    assert set(table["pooled"]) == {ALL_RUNS}
    assert rows(table, "a", CONTACT)["runs"].to_dict() == {"None": 2, "point": 4}


def test_cells_that_are_not_all_combinations_are_named_one_by_one():
    keys = ["k", "o", "p"]
    runs = pd.DataFrame(
        [("1", "a", "x"), ("1", "b", "y"), ("1", "a", "y"), ("2", "a", "x"), ("2", "b", "y")]
        + [("2", "b", "x")],
        columns=keys,
    )
    kept, label = balanced_cells(runs, "k", keys)
    assert label == "only (o = a, p = x) or (o = b, p = y)" and len(kept) == 4
    # No cell at every level: every run, and the row says its levels differ in design.
    swapped = pd.DataFrame(
        [("1", "a", "x"), ("1", "b", "y"), ("2", "a", "y"), ("2", "b", "x")], columns=keys
    )
    kept, label = balanced_cells(swapped, "k", keys)
    assert len(kept) == 4 and label == f"{ALL_RUNS}: no cell of o, p ran at every level"


@pytest.mark.parametrize("study", sorted(PUBLISHED_STUDIES))
def test_no_published_marginal_row_pools_unbalanced_cells_without_saying_so(study):
    summary = ROOT / PUBLISHED_STUDIES[study].directory / "planning" / "summary"
    if not (summary / "success.parquet").is_file():
        pytest.skip(f"{study}: no tables published")
    per_run = pd.read_parquet(summary / "per_run.parquet")
    keys = list(per_run.columns[1 : per_run.columns.get_loc("run")])  # the level columns
    success = pd.read_parquet(summary / "success.parquet")
    for row in success[success["dimension"] != "all"].itertuples():
        kept, label = balanced_cells(per_run[per_run["method"] == row.method], row.dimension, keys)
        assert getattr(row, "pooled", ALL_RUNS) == label, (study, row)
        assert row.runs == (kept[row.dimension] == row.level).sum(), (study, row)
    # Every robustness row is one cell: a level of every compared dimension.
    robustness = pd.read_parquet(summary / "robustness.parquet")
    assert set(compared_keys(keys)) <= set(robustness.columns)
