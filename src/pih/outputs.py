"""Parquet tables with units and provenance, written atomically; rollout traces as tables.

Units and descriptions live in each field's metadata (``unit``, ``description``); the provenance
record lives in the schema metadata under ``pih.provenance`` (canonical JSON). Writes go to a
temporary file in the target directory and are renamed into place, so an interrupted run never
leaves a half-written Parquet file.
"""

from __future__ import annotations

import json
import math
import os
import tempfile
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from pih.provenance import PROVENANCE_KEY, canonical_json, stable
from pih.scene import Trace

Column = tuple[str, str]  # (unit, description)

TRACE_COLUMNS: dict[str, Column] = {
    "time_s": ("s", "simulated time"),
    **{
        f"{frame}_{axis}": (unit, f"{label} {axis} (world; y up, θ counter-clockwise)")
        for frame, label in (
            ("robot", "robot frame R"),
            ("peg", "peg centre P"),
            ("peg_top", "peg top centre P1"),
            ("peg_bottom", "peg bottom centre P2"),
        )
        for axis, unit in (("x_m", "m"), ("y_m", "m"), ("theta_rad", "rad"))
    },
    "contact_fx_n": ("N", "contact force on the peg, x (world)"),
    "contact_fy_n": ("N", "contact force on the peg, y (world, up)"),
    "contact_moment_nm": ("N*m", "contact moment on the peg about its centre P, counter-clockwise"),
    "contact_patches": ("1", "contact patches carrying force (-1: not logged)"),
    "spring_fx_n": ("N", "spring force on the peg at P1, x (eq. 10)"),
    "spring_fy_n": ("N", "spring force on the peg at P1, y (eq. 10)"),
    "spring_moment_nm": ("N*m", "spring moment on the peg (eq. 10)"),
    "spring_energy_j": ("J", "spring energy E_RP (eq. 9)"),
    "insertion_depth_m": (
        "m",
        "depth of P2 below the hole entrance (bottom of chamfer), Whitney's l",
    ),
    "penetration_m": ("m", "deepest geometric overlap of peg and hole (solver transients)"),
}
_POSE_FIELDS = {
    "robot": "q_robot",
    "peg": "q_peg",
    "peg_top": "q_peg_top",
    "peg_bottom": "q_peg_bottom",
}
_TRIPLE_FIELDS = {
    "contact": ("contact_force", ("fx_n", "fy_n", "moment_nm")),
    "spring": ("spring_force", ("fx_n", "fy_n", "moment_nm")),
}


def trace_frame(trace: Trace) -> pd.DataFrame:
    """A rollout trace as a flat DataFrame with the columns of :data:`TRACE_COLUMNS`."""
    columns: dict[str, np.ndarray] = {"time_s": trace.time_s}
    for prefix, name in _POSE_FIELDS.items():
        values = getattr(trace, name)
        for i, axis in enumerate(("x_m", "y_m", "theta_rad")):
            columns[f"{prefix}_{axis}"] = values[:, i]
    for prefix, (name, suffixes) in _TRIPLE_FIELDS.items():
        values = getattr(trace, name)
        for i, suffix in enumerate(suffixes):
            columns[f"{prefix}_{suffix}"] = values[:, i]
    columns["contact_patches"] = trace.contact_patches
    columns["spring_energy_j"] = trace.spring_energy_j
    columns["insertion_depth_m"] = trace.insertion_depth_m
    columns["penetration_m"] = trace.penetration_m
    return pd.DataFrame(columns)[list(TRACE_COLUMNS)]


def frame_trace(frame: pd.DataFrame, status: str = "ok", reason: str = "") -> Trace:
    """Inverse of :func:`trace_frame`."""
    arrays: dict[str, Any] = {"time_s": frame["time_s"].to_numpy()}
    for prefix, name in _POSE_FIELDS.items():
        arrays[name] = frame[[f"{prefix}_{a}" for a in ("x_m", "y_m", "theta_rad")]].to_numpy()
    for prefix, (name, suffixes) in _TRIPLE_FIELDS.items():
        arrays[name] = frame[[f"{prefix}_{s}" for s in suffixes]].to_numpy()
    arrays["contact_patches"] = frame["contact_patches"].to_numpy()
    arrays["spring_energy_j"] = frame["spring_energy_j"].to_numpy()
    arrays["insertion_depth_m"] = frame["insertion_depth_m"].to_numpy()
    arrays["penetration_m"] = frame["penetration_m"].to_numpy()
    return Trace(**arrays, status=status, reason=reason)  # type: ignore[arg-type]


@contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path beside ``path``; rename it over ``path`` only on success."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    os.close(fd)
    try:
        yield Path(tmp)
        # mkstemp creates 0600; give the output the mode any file the user writes gets.
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def _umask() -> int:
    mask = os.umask(0)
    os.umask(mask)
    return mask


def write_table(
    frame: pd.DataFrame,
    path: str | Path,
    provenance: Mapping[str, Any],
    columns: Mapping[str, Column],
    extra_metadata: Mapping[str, Any] | None = None,
) -> None:
    """Write ``frame`` to Parquet atomically with units per column and the provenance record.

    Every column must be described in ``columns`` (unit, description): units are not optional.
    """
    missing = [c for c in frame.columns if c not in columns]
    if missing:
        raise ValueError(f"columns without unit/description: {missing}")
    table = pa.Table.from_pandas(frame, preserve_index=False)
    fields = [
        field.with_metadata({"unit": columns[field.name][0], "description": columns[field.name][1]})
        for field in table.schema
    ]
    metadata = {
        **(table.schema.metadata or {}),
        PROVENANCE_KEY: canonical_json(dict(provenance)).encode(),
    }
    for key, value in (extra_metadata or {}).items():
        metadata[f"pih.{key}".encode()] = canonical_json(value).encode()
    table = pa.Table.from_arrays(table.columns, schema=pa.schema(fields, metadata=metadata))
    with atomic_path(path) as tmp:
        pq.write_table(table, tmp)


def read_provenance(path: str | Path) -> dict[str, Any]:
    """The provenance record of a Parquet file, read from its schema without loading data."""
    metadata = pq.read_schema(path).metadata or {}
    if PROVENANCE_KEY not in metadata:
        raise ValueError(
            f"{path}: no {PROVENANCE_KEY.decode()} record in the Parquet schema metadata"
        )
    return json.loads(metadata[PROVENANCE_KEY])


def read_metadata(path: str | Path, key: str) -> Any:
    """A ``pih.<key>`` JSON entry of the schema metadata."""
    return json.loads((pq.read_schema(path).metadata or {})[f"pih.{key}".encode()])


def read_output_provenance(path: str | Path) -> dict[str, Any]:
    """The provenance record an output carries: Parquet schema metadata, a recording's property,
    a PNG text chunk or a markdown file's closing comment (the last three without time or host)."""
    path = Path(path)
    if path.suffix == ".rrd":
        from pih.recordings import read_recording_provenance

        return read_recording_provenance(path)
    if path.suffix == ".png":
        from PIL import Image

        with Image.open(path) as image:
            text = image.text.get(PROVENANCE_KEY.decode())
    elif path.suffix == ".md":
        last = path.read_text().rstrip().rsplit("\n", 1)[-1]
        text = (
            last[len(MARKDOWN_PROVENANCE) : -len(" -->")]
            if last.startswith(MARKDOWN_PROVENANCE)
            else None
        )
    else:
        return read_provenance(path)
    if text is None:
        raise ValueError(f"{path}: no {PROVENANCE_KEY.decode()} record")
    return json.loads(text)


def provenance_index(
    paths: list[str | Path], companions: Mapping[str, str] | None = None
) -> pd.DataFrame:
    """One row per output file: its run id, seeds, config and library hashes, code version and
    Drake version, and which file carries the record (itself, or for CSV and PDF files the
    Parquet file their job wrote with the same record, ``companions[file]``)."""
    companions = dict(companions or {})
    rows = []
    for path in paths:
        carrier = companions.get(str(path), str(path))
        record = read_output_provenance(carrier)
        rows.append(
            {
                "file": str(path),
                "record_in": "itself" if carrier == str(path) else carrier,
                "run_id": record["run_id"],
                "seeds": ", ".join(f"{k}={v}" for k, v in sorted(record["seeds"].items())),
                "config_sha256": record["config_sha256"][:12],
                "library_sha256": record["library_sha256"][:12],
                "code_version": record.get("code_version", ""),  # not in rerun-stable records
                "drake": record["packages"]["drake"],
            }
        )
    return pd.DataFrame(rows)


def read_units(path: str | Path) -> dict[str, str]:
    schema = pq.read_schema(path)
    return {f.name: (f.metadata or {}).get(b"unit", b"").decode() for f in schema}


def write_trace(trace: Trace, path: str | Path, provenance: Mapping[str, Any]) -> None:
    """One rollout trace to Parquet; its status, reason and step go in ``pih.trace`` metadata."""
    write_table(
        trace_frame(trace),
        path,
        provenance,
        TRACE_COLUMNS,
        extra_metadata={
            "trace": {
                "status": trace.status,
                "reason": trace.reason,
                "time_step_s": trace.time_step_s,
            }
        },
    )


def read_trace(path: str | Path) -> Trace:
    info = read_metadata(path, "trace")
    trace = frame_trace(pd.read_parquet(path), info["status"], info["reason"])
    trace.time_step_s = info.get("time_step_s", math.nan)
    return trace


def read_validation_traces(paths: list[str]) -> dict[tuple[str, float], Trace]:
    """Validation traces keyed by (variant, offset_m), from each file's sweep point."""
    traces = {}
    for path in paths:
        point = read_provenance(path)["sweep_point"]
        traces[(point["variant"], point["offset_m"])] = read_trace(path)
    return traces


def markdown_table(frame: pd.DataFrame, float_format: str = "{:.4g}") -> str:
    """A pipe table (no extra dependency)."""

    def cell(value: Any) -> str:
        if isinstance(value, (float, np.floating)):
            return "" if math.isnan(value) else float_format.format(value)
        return str(value)

    header = "| " + " | ".join(map(str, frame.columns)) + " |"
    rule = "|" + "|".join("---" for _ in frame.columns) + "|"
    body = ["| " + " | ".join(cell(v) for v in row) + " |" for row in frame.itertuples(index=False)]
    return "\n".join([header, rule, *body]) + "\n"


MARKDOWN_PROVENANCE = "<!-- pih.provenance "


def write_text(path: str | Path, text: str, provenance: Mapping[str, Any] | None = None) -> None:
    """Atomically write a text file (markdown/CSV tables). A markdown file given a provenance
    record ends with it (without time or host) in an HTML comment, invisible when rendered."""
    if provenance is not None:
        if Path(path).suffix != ".md":
            raise ValueError(f"{path}: only markdown files carry a provenance comment")
        text = f"{text.rstrip()}\n\n{MARKDOWN_PROVENANCE}{canonical_json(stable(provenance))} -->\n"
    with atomic_path(path) as tmp:
        tmp.write_text(text)


def write_with(path: str | Path, writer: Callable[[Path], None]) -> None:
    """Atomically produce ``path`` with ``writer(tmp_path)`` (figures, recordings)."""
    path = Path(path)
    with atomic_path(path) as tmp:
        # Keep the real suffix: matplotlib and rerun pick the format from it.
        target = tmp.with_suffix(path.suffix)
        try:
            writer(target)
            os.replace(target, tmp)
        finally:
            if target.exists():
                target.unlink()
