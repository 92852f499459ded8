"""pih replay's row query: parsed comparisons, never evaluated code."""

import pandas as pd
import pytest

from pih.cli.row_query import QueryError, select_rows

FRAME = pd.DataFrame(
    {
        "phase": ["train", "train", "mean", "deploy", "deploy"],
        "iteration": [1, 1, 1, 2, 2],
        "rollout": [0, 1, 0, 0, 1],
        "cost": [3.5, 1.0e5, 2.0, 0.5, float("nan")],
        "success": [False, True, False, True, False],
    }
)


@pytest.mark.parametrize(
    ("query", "rows"),
    [
        ("phase == 'deploy'", [3, 4]),
        ('phase == "deploy" and rollout == 1', [4]),
        ("phase == 'mean' or rollout == 1", [1, 2, 4]),
        ("phase == 'train' or phase == 'mean' and rollout == 0", [0, 1, 2]),
        ("(phase == 'train' or phase == 'mean') and rollout == 0", [0, 2]),
        ("cost >= 2", [0, 1, 2]),
        ("cost < 1e3 and cost > 0.75", [0, 2]),
        ("cost != 0.5", [0, 1, 2, 4]),
        ("success == True", [1, 3]),
        ("iteration <= -1", []),
    ],
)
def test_queries_select_the_rows_pandas_would(query, rows):
    assert select_rows(FRAME, query).index.tolist() == rows


@pytest.mark.parametrize(
    ("query", "message"),
    [
        ("", "empty"),
        ("rolout == 3", "no column 'rolout'; the columns are phase, iteration, rollout"),
        ("phase = 'deploy'", "cannot read"),
        ("phase == deploy", "expected a number, a quoted string"),
        ("phase ==", "ends too early"),
        ("(phase == 'deploy'", "ends too early"),
        ("phase == 'deploy')", "unexpected ')'"),
        ("phase == 'deploy' rollout == 1", "unexpected 'rollout'"),
        ("and phase == 'deploy'", "expected a column name"),
        ("@Path.home.__globals__['os'].system('id') == 0", "cannot read"),
        ("__import__('os').system('id') == 0", 'cannot read the query from ".system'),
        ("phase.upper() == 'DEPLOY'", "cannot read"),
        ("cost < 'a'", "cost < 'a'"),
    ],
)
def test_bad_queries_are_one_clear_error(query, message):
    with pytest.raises(QueryError, match=None) as raised:
        select_rows(FRAME, query)
    assert message in str(raised.value)
    assert "\n" not in str(raised.value)
