"""The equivalence record, ``published/equivalence.parquet``: which rollout codes were shown to
compute what an earlier one computed (``pih verify``, :mod:`pih.publishing.verification`).

A published planning run is current when its rollout hash is today's, or when rows of this
record lead from its hash to today's: rows chain, so a run at H1 is current at H3 once H1 → H2
and H2 → H3 are recorded, and each change verifies only from the hash current before it
(docs/reproducibility.md, "What current means").
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import pandas as pd

from pih.records.outputs import write_table
from pih.records.provenance import LIBRARY_ROOT, record, rollout_code_hash

REPOSITORY = LIBRARY_ROOT.parents[1]
"""The checkout that holds this library (``src/pih``), its ``published/`` and its history."""
RECORD = REPOSITORY / "published" / "equivalence.parquet"

COLUMNS: dict[str, tuple[str, str]] = {
    "from_rollout_code_sha256": ("", "the rollout code hash of published runs"),
    "to_rollout_code_sha256": ("", "the rollout code hash shown to compute the same on the suite"),
    "from_commit": ("", "the commit whose own code and hash function gave the from hash"),
    "to_commit": ("", "the code verified (git describe; -dirty: with uncommitted changes)"),
    "items": ("", "JSON list: each suite item, the run it ran and its outputs' sha256"),
    "cpu": ("", "the CPU both codes ran on"),
    "python": ("", "the Python both codes ran under"),
    "drake": ("", "the Drake both codes ran with"),
    "created_utc": ("", "when the verification ended (UTC, ISO 8601)"),
}


def read_record(path: Path = RECORD) -> pd.DataFrame:
    """The record's rows (none when the file does not exist); one line naming the file when it
    is not a readable record (truncated, or other columns)."""
    if not Path(path).exists():
        return pd.DataFrame({name: pd.Series(dtype=str) for name in COLUMNS})
    try:
        rows = pd.read_parquet(path)
    except Exception as error:  # noqa: BLE001 - pyarrow's errors for a damaged file vary
        raise ValueError(f"{path}: not a readable equivalence record ({error})") from None
    missing = sorted(set(COLUMNS) - set(rows.columns))
    if missing:
        raise ValueError(f"{path}: not an equivalence record (no column {', '.join(missing)})")
    return rows


def current_hashes(today: str | None = None, path: Path = RECORD) -> frozenset[str]:
    """``today``'s rollout hash (default: this code's) and every hash a chain of the record's
    rows leads from to it; a row between two other hashes counts for nothing."""
    today = today or rollout_code_hash()
    rows = read_record(path)
    reached, grew = {today}, True
    while grew:
        sources = set(
            rows.loc[rows["to_rollout_code_sha256"].isin(reached), "from_rollout_code_sha256"]
        )
        grew = not sources <= reached
        reached |= sources
    return frozenset(reached)


def chained(made_at: str, path: Path = RECORD) -> str:
    """The hash the record's rows lead to from ``made_at`` (itself when none leaves it), following
    the latest row at each step."""
    rows = read_record(path)
    seen, at = {made_at}, made_at
    while True:
        onward = rows.loc[rows["from_rollout_code_sha256"] == at, "to_rollout_code_sha256"]
        if onward.empty or onward.iloc[-1] in seen:
            return at
        at = onward.iloc[-1]
        seen.add(at)


def add_row(row: Mapping[str, Any], path: Path = RECORD) -> None:
    """Append one verification to the record, written whole or not at all."""
    rows = read_record(path)
    new = pd.DataFrame([{name: str(row[name]) for name in COLUMNS}])
    rows = pd.concat([rows, new], ignore_index=True) if len(rows) else new
    write_table(rows, path, record("verify"), COLUMNS)
