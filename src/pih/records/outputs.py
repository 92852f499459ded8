"""Parquet tables with units and provenance, written atomically; rollout traces as tables.

Units and descriptions live in each field's metadata (``unit``, ``description``); the provenance
record lives in the schema metadata under ``pih.provenance`` (canonical JSON). Writes go to a
temporary file outside the output tree (:data:`TEMPORARY_DIR` in the working directory) and are
renamed into place, so an interrupted run never leaves a half-written file among the outputs,
whatever signal stops it (:func:`atomic_path`).
"""

from __future__ import annotations

import functools
import json
import math
import os
import re
import signal
import socket
import tempfile
import threading
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager, suppress
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq
from numpy.typing import NDArray

from pih.records.provenance import PROVENANCE_KEY, canonical_json, stable
from pih.scene.trace import Trace

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
    """Inverse of :func:`trace_frame`; a column the file does not keep reads as NaN (contact
    patches as -1, not logged)."""
    missing = [name for name in TRACE_COLUMNS if name not in frame.columns]
    frame = frame.assign(**{name: np.nan for name in missing})
    if "contact_patches" in missing:
        frame["contact_patches"] = -1
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


TEMPORARY_DIR = ".pih-tmp"
"""Directory in the working directory (the workflow's) where outputs below it are written before
they are renamed into place: outside ``results/``, so no signal leaves a file among the outputs.
A SIGTERM or SIGHUP during a write removes its temporary files; a file left by SIGKILL is
removed by the next write on the same host. Outputs outside the working directory, or on another
file system, get their temporary file beside them (hidden, cleaned up the same way)."""

_HOST = re.sub(r"[^A-Za-z0-9-]", "-", socket.gethostname()) or "host"
# .<target name>.<host>@<pid>.<random>.tmp (or another suffix: write_with's second file).
_OWNER = re.compile(r"\.(?P<host>[A-Za-z0-9-]+)@(?P<pid>[0-9]+)\.[A-Za-z0-9_]+(\.[^.]*)?$")


@contextmanager
def atomic_path(path: str | Path) -> Iterator[Path]:
    """Yield a temporary path (in :data:`TEMPORARY_DIR` when ``path`` is below the working
    directory); rename it over ``path`` only on success. A SIGTERM or SIGHUP meanwhile removes
    it before the process ends by that signal."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    folder = temporary_dir(path)
    _remove_stale(folder)
    fd, tmp = tempfile.mkstemp(
        prefix=f".{path.name}.{_HOST}@{os.getpid()}.", suffix=".tmp", dir=folder
    )
    os.close(fd)
    try:
        with removed_on_signal(Path(tmp)):
            yield Path(tmp)
            # mkstemp creates 0600; give the output the mode any file the user writes gets.
            os.chmod(tmp, 0o666 & ~_umask())
            os.replace(tmp, path)
    finally:
        if os.path.exists(tmp):
            os.unlink(tmp)


def temporary_dir(path: Path) -> Path:
    """Where :func:`atomic_path` writes ``path`` first: :data:`TEMPORARY_DIR` in the working
    directory if ``path`` is below it and on the same file system (``os.replace`` cannot cross
    file systems), else ``path``'s own directory."""
    parent, work = path.parent.resolve(), Path.cwd().resolve()
    if parent.is_relative_to(work):
        folder = work / TEMPORARY_DIR
        with suppress(OSError):
            folder.mkdir(exist_ok=True)
            if folder.stat().st_dev == parent.stat().st_dev:
                return folder
    return parent


def _remove_stale(folder: Path) -> None:
    """Remove the temporary files of writes killed on this host (their process is gone)."""
    with suppress(OSError):
        for entry in os.scandir(folder):
            owner = _OWNER.search(entry.name)
            if not entry.name.startswith(".") or owner is None or owner["host"] != _HOST:
                continue
            pid = int(owner["pid"])
            if pid == os.getpid():
                continue
            try:
                os.kill(pid, 0)
            except ProcessLookupError:
                with suppress(OSError):
                    os.unlink(entry.path)
            except OSError:
                pass  # alive (another user's) or unknown: leave it


_LIVE: dict[Path, None] = {}  # temporary files being written (an ordered set)
_SAVED_HANDLERS: dict[int, Any] = {}
_CLEANUP_SIGNALS = (signal.SIGTERM, signal.SIGHUP)


@contextmanager
def removed_on_signal(*paths: Path) -> Iterator[None]:
    """Within this block a SIGTERM or SIGHUP (SLURM's time limit and ``scancel`` send SIGTERM)
    removes ``paths`` and then ends the process by that signal as before. Only where the signal
    has its default action (not ignored, no other handler), and only in the main thread (Python
    runs handlers there): elsewhere the paths are still removed if the main thread is writing."""
    main = threading.current_thread() is threading.main_thread()
    installed = False
    if main and not _SAVED_HANDLERS:
        for number in _CLEANUP_SIGNALS:
            if signal.getsignal(number) is signal.SIG_DFL:
                _SAVED_HANDLERS[number] = signal.signal(number, _remove_live_and_die)
        installed = True
    for path in paths:
        _LIVE[path] = None
    try:
        yield
    finally:
        for path in paths:
            _LIVE.pop(path, None)
        if installed:
            for number, handler in _SAVED_HANDLERS.items():
                signal.signal(number, handler)
            _SAVED_HANDLERS.clear()


def _remove_live_and_die(number: int, frame: Any) -> None:
    for path in list(_LIVE):
        with suppress(OSError):
            os.unlink(path)
    signal.signal(number, signal.SIG_DFL)
    os.kill(os.getpid(), number)


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
    # Lossless, and a third smaller than Parquet's default on per-step traces: zstd, and the
    # floats' bytes split into streams (their exponents compress; docs/workflow.md, "Outputs").
    floats = [f.name for f in table.schema if pa.types.is_floating(f.type)]
    with atomic_path(path) as tmp:
        pq.write_table(
            table,
            tmp,
            compression="zstd",
            use_byte_stream_split=floats,
            use_dictionary=[name for name in table.column_names if name not in floats],
        )


def read_provenance(path: str | Path) -> dict[str, Any]:
    """The provenance record of a Parquet file, read from its schema without loading data; the
    schema is read once per version of the file (outputs are replaced whole, never edited in
    place), however often staleness checks, pooling and comparing ask."""
    stat = os.stat(path)
    record = _provenance_json(os.path.abspath(path), stat.st_ino, stat.st_mtime_ns, stat.st_size)
    if record is None:
        raise ValueError(
            f"{path}: no {PROVENANCE_KEY.decode()} record in the Parquet schema metadata"
        )
    return json.loads(record)


@functools.lru_cache(maxsize=4096)
def _provenance_json(path: str, inode: int, mtime_ns: int, size: int) -> bytes | None:
    return (pq.read_schema(path).metadata or {}).get(PROVENANCE_KEY)


def read_metadata(path: str | Path, key: str) -> Any:
    """A ``pih.<key>`` JSON entry of the schema metadata."""
    return json.loads((pq.read_schema(path).metadata or {})[f"pih.{key}".encode()])


def read_recording_provenance(path: str | Path) -> dict[str, Any]:
    """The provenance property of a recording written by :mod:`pih.records.recordings`."""
    from rerun.chunk import RrdReader

    for chunk in RrdReader(str(path)).store().stream():
        if chunk.entity_path == "/__properties/provenance":
            return json.loads(chunk.to_record_batch().column("record")[0][0].as_py())
    raise ValueError(f"{path}: no provenance property in the recording")


def read_output_provenance(path: str | Path) -> dict[str, Any]:
    """The provenance record an output carries: Parquet schema metadata, a recording's property,
    a PNG text chunk or a markdown file's closing comment (the last three without time or host)."""
    path = Path(path)
    if path.suffix == ".rrd":
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


def write_trace(
    trace: Trace,
    path: str | Path,
    provenance: Mapping[str, Any],
    rows: NDArray[np.intp] | None = None,
    columns: Sequence[str] = tuple(TRACE_COLUMNS),
) -> None:
    """One rollout trace to Parquet, its steps ``rows`` (default: all) and ``columns`` only; its
    status, reason, step and number of simulated steps go in ``pih.trace`` metadata."""
    frame = trace_frame(trace)[list(columns)]
    write_table(
        frame if rows is None else frame.iloc[rows].reset_index(drop=True),
        path,
        provenance,
        {name: TRACE_COLUMNS[name] for name in columns},
        extra_metadata={
            "trace": {
                "status": trace.status,
                "reason": trace.reason,
                "time_step_s": trace.time_step_s,
                "simulated_steps": len(trace),
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
            with removed_on_signal(target):
                writer(target)
            os.replace(target, tmp)
        finally:
            if target.exists():
                target.unlink()
