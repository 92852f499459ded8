"""Row selection from a command line without evaluating code: ``pih replay``'s query.

A query is comparisons ``column op value`` (op one of ``== != < <= > >=``; value a number, a
quoted string, ``True`` or ``False``) joined by ``and`` / ``or`` (``and`` binds tighter), with
optional parentheses, e.g. ``phase == 'deploy' and rollout == 3``. It is parsed here and applied
with pandas comparisons: nothing in it is ever evaluated as Python (``DataFrame.query`` would
evaluate ``@name`` and attribute access, which runs code).
"""

from __future__ import annotations

import operator
import re
from collections.abc import Callable

import pandas as pd

_TOKEN = re.compile(
    r"""\s*(?:
        (?P<number>[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?)
      | (?P<string>'[^']*'|"[^"]*")
      | (?P<op>==|!=|<=|>=|<|>)
      | (?P<paren>[()])
      | (?P<name>[A-Za-z_][A-Za-z0-9_]*)
    )""",
    re.VERBOSE,
)
_COMPARE: dict[str, Callable[[pd.Series, object], pd.Series]] = {
    "==": operator.eq,
    "!=": operator.ne,
    "<": operator.lt,
    "<=": operator.le,
    ">": operator.gt,
    ">=": operator.ge,
}
_LITERALS = {"True": True, "False": False}


class QueryError(ValueError):
    """A query that does not parse, or names a column the table lacks."""


def _tokens(query: str) -> list[tuple[str, str]]:
    tokens, position = [], 0
    while position < len(query.rstrip()):
        match = _TOKEN.match(query, position)
        if match is None or match.end() == position:
            raise QueryError(f"cannot read the query from {query[position:].strip()!r} on")
        kind = match.lastgroup
        assert kind is not None
        tokens.append((kind, match.group(kind)))
        position = match.end()
    return tokens


def select_rows(frame: pd.DataFrame, query: str) -> pd.DataFrame:
    """The rows of ``frame`` that ``query`` (module docstring) selects."""
    tokens = _tokens(query)
    if not tokens:
        raise QueryError("the query is empty")
    position = 0

    def peek() -> tuple[str, str] | None:
        return tokens[position] if position < len(tokens) else None

    def take() -> tuple[str, str]:
        nonlocal position
        if position >= len(tokens):
            raise QueryError(f"the query ends too early: {query!r}")
        position += 1
        return tokens[position - 1]

    def either() -> pd.Series:
        mask = both()
        while peek() == ("name", "or"):
            take()
            mask = mask | both()
        return mask

    def both() -> pd.Series:
        mask = comparison()
        while peek() == ("name", "and"):
            take()
            mask = mask & comparison()
        return mask

    def comparison() -> pd.Series:
        kind, text = take()
        if (kind, text) == ("paren", "("):
            mask = either()
            if take() != ("paren", ")"):
                raise QueryError(f"a '(' is not closed in {query!r}")
            return mask
        if kind != "name" or text in ("and", "or"):
            raise QueryError(f"expected a column name, got {text!r}")
        if text not in frame.columns:
            raise QueryError(f"no column {text!r}; the columns are {', '.join(frame.columns)}")
        op_kind, op = take()
        if op_kind != "op":
            raise QueryError(f"expected one of {' '.join(_COMPARE)} after {text!r}, got {op!r}")
        value_kind, value = take()
        if value_kind == "number":
            literal: object = float(value) if any(c in value for c in ".eE") else int(value)
        elif value_kind == "string":
            literal = value[1:-1]
        elif value in _LITERALS:
            literal = _LITERALS[value]
        else:
            raise QueryError(
                f"expected a number, a quoted string, True or False after {text} {op}, got "
                f"{value!r}"
            )
        try:
            return _COMPARE[op](frame[text], literal).fillna(False).astype(bool)
        except TypeError as error:
            raise QueryError(f"{text} {op} {value}: {error}") from None

    mask = either()
    if position != len(tokens):
        raise QueryError(f"unexpected {tokens[position][1]!r} in {query!r}")
    return frame[mask]
