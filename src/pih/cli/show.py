"""``pih show FILE`` and ``pih provenance FILE...``: what an output holds, and its provenance."""

from __future__ import annotations

import json
import sys
from pathlib import Path

from pih.cli.common import first_line
from pih.records.outputs import read_output_provenance, read_provenance

SHOWN_SUFFIXES = (".parquet", ".csv", ".md", ".html", ".png", ".pdf", ".rrd")


SHOWN_TYPES = ", ".join(SHOWN_SUFFIXES)


def show(path: Path) -> int:
    """What an output holds and where it came from, by type: a Parquet or CSV table's columns
    (with units) and rows, a Markdown file's first lines, a figure's size, a recording's
    entities and timelines; then its provenance (its own record; a CSV's is in its companion
    Parquet, a PDF's in its companion PNG). A missing path suggests the closest existing one."""
    if not path.exists():
        print(f"pih show: no such file: {path}{did_you_mean(path)}", file=sys.stderr)
        return 1
    if path.is_dir():
        inside = next((p for p in sorted(path.rglob("*")) if p.suffix in SHOWN_SUFFIXES), None)
        hint = f"; e.g. pih show {inside}" if inside else ""
        print(f"pih show: {path} is a directory, not a file{hint}", file=sys.stderr)
        return 1
    kinds = {
        ".parquet": ("Parquet", _show_parquet),
        ".csv": ("CSV", _show_csv),
        ".md": ("Markdown", _show_markdown),
        ".html": ("HTML", _show_html),
        ".png": ("PNG", _show_png),
        ".pdf": ("PDF", _show_pdf),
        ".rrd": ("Rerun recording", _show_rrd),
    }
    if path.suffix.lower() not in kinds:
        print(f"pih show: {path}: not a type pih writes ({SHOWN_TYPES})", file=sys.stderr)
        return 1
    kind, describe = kinds[path.suffix.lower()]
    try:
        lines, record, carrier = describe(path)
    except Exception as error:  # noqa: BLE001 - any unreadable file: one clear line
        print(f"pih show: {path}: not a pih {kind} output ({first_line(error)})", file=sys.stderr)
        return 1
    print("\n".join(lines))
    if record is None:
        print("provenance: none in the file (not written by pih?)")
        return 0
    if carrier is not None:
        print(f"provenance (in {carrier}):")
    seeds = ", ".join(f"{k}={v}" for k, v in sorted(record.get("seeds", {}).items()))
    print(f"step {record.get('step', '?')}; run id {record.get('run_id', '?')}")
    print(f"seeds: {seeds or '-'}; config sha256 {str(record.get('config_sha256', '?'))[:12]}")
    details = [
        f"code {record['code_version']}" if "code_version" in record else "",
        f"library {str(record.get('library_sha256', '?'))[:12]}",
        f"drake {record.get('packages', {}).get('drake', '?')}",
        f"created {record['created_utc']}" if "created_utc" in record else "",
    ]
    print(", ".join(d for d in details if d))
    if "machine" in record:
        blas = "; ".join(
            f"{b['internal_api']} {b['version']} ({b['architecture']} kernel)"
            for b in record["machine"]["blas"]
        )
        print(f"cpu {record['machine']['cpu']}; blas {blas or '-'}")
    return 0


def did_you_mean(path: Path) -> str:
    """``"; did you mean P?"`` for the existing path closest to ``path``, name by name from its
    deepest existing ancestor (difflib), or ``""``."""
    import difflib

    base, missing = path, []
    while not base.exists() and base != base.parent:
        missing.insert(0, base.name)
        base = base.parent
    guess = base
    for name in missing:
        if (guess / name).exists():
            guess = guess / name
            continue
        try:
            names = [p.name for p in guess.iterdir()] if guess.is_dir() else []
        except OSError:
            return ""
        match = difflib.get_close_matches(name, names, n=1, cutoff=0.6)
        if not match:
            return ""
        guess = guess / match[0]
    return f"; did you mean {guess}?" if guess.exists() and guess != path else ""


_ShowResult = tuple[list[str], dict | None, Path | None]  # lines, record, the file it is in


def _columns(schema) -> list[str]:  # a pyarrow schema, or a list of its fields
    width = max((len(field.name) for field in schema), default=0)
    lines = []
    for field in schema:
        info = {k.decode(): v.decode() for k, v in (field.metadata or {}).items()}
        unit = info.get("unit") or "-"
        lines.append(f"  {field.name:<{width}}  [{unit}]  {info.get('description', '')}")
    return lines


def _show_parquet(path: Path) -> _ShowResult:
    import pyarrow.parquet as pq

    meta = pq.ParquetFile(path).metadata
    schema = pq.read_schema(path)
    record = read_provenance(path)
    return [f"{path}: {meta.num_rows} rows, {len(schema)} columns", *_columns(schema)], record, None


def _show_csv(path: Path) -> _ShowResult:
    import pandas as pd
    import pyarrow.parquet as pq

    table = pd.read_csv(path)
    head = f"{path}: CSV, {len(table)} rows, {len(table.columns)} columns"
    companion = path.with_suffix(".parquet")  # e.g. success.csv beside success.parquet
    try:
        schema = pq.read_schema(companion)
        record = read_provenance(companion)
    except Exception:  # noqa: BLE001 - no companion: the columns without units
        return [head, *(f"  {name}" for name in table.columns)], None, None
    fields = [schema.field(name) for name in table.columns if name in schema.names]
    others = [f"  {name}  [-]" for name in table.columns if name not in schema.names]
    return [head, *_columns(fields), *others], record, companion


def _show_markdown(path: Path) -> _ShowResult:
    from pih.records.outputs import MARKDOWN_PROVENANCE

    text = [line for line in path.read_text().splitlines() if line.strip()]
    shown = [line for line in text if not line.startswith(MARKDOWN_PROVENANCE)]
    first = [f"  {line if len(line) <= 120 else line[:119] + '…'}" for line in shown[:8]]
    more = [f"  … ({len(shown) - 8} more lines)"] if len(shown) > 8 else []
    try:
        record = read_output_provenance(path)
    except ValueError:  # no closing provenance comment
        record = None
    return [f"{path}: Markdown, {len(shown)} lines; first lines:", *first, *more], record, None


def _show_html(path: Path) -> _ShowResult:
    """A report page (results/report/): its title and tables; its record is the closing comment
    it copies from the markdown it shows."""
    import re

    from pih.records.outputs import MARKDOWN_PROVENANCE

    text = path.read_text()
    title = re.search(r"<title>(.*?)</title>", text, re.DOTALL)
    tables = len(re.findall(r"<table\b", text))
    head = f"{path}: HTML page {title[1].strip()!r}, " if title else f"{path}: HTML page, "
    head += f"{tables} table{'s' * (tables != 1)}, {len(text.encode()) / 1024:.0f} kB"
    last = text.rstrip().rsplit("\n", 1)[-1]
    record = None
    if last.startswith(MARKDOWN_PROVENANCE) and last.endswith(" -->"):
        record = json.loads(last[len(MARKDOWN_PROVENANCE) : -len(" -->")])
    return [head], record, None


def _show_png(path: Path) -> _ShowResult:
    from PIL import Image

    with Image.open(path) as image:
        width, height = image.size
        image.verify()
    kb = path.stat().st_size / 1024
    head = f"{path}: PNG figure, {width} × {height} px, {kb:.0f} kB"
    try:
        record = read_output_provenance(path)
    except ValueError:  # no pih.provenance text chunk
        record = None
    return [head], record, None


def _show_pdf(path: Path) -> _ShowResult:
    import re

    data = path.read_bytes()
    if not data.startswith(b"%PDF"):
        raise ValueError("no %PDF header")
    pages = len(re.findall(rb"/Type\s*/Page\b", data))
    head = f"{path}: PDF figure, {pages} page{'s' * (pages != 1)}, {len(data) / 1024:.0f} kB"
    companion = path.with_suffix(".png")  # the figure's PNG carries the full record
    try:
        return [head], read_output_provenance(companion), companion
    except Exception:  # noqa: BLE001 - no companion: the run id and hashes the PDF carries
        subject = re.search(rb"/Subject \((.*?)\)", data)
        words = re.search(rb"/Keywords \((.*?)\)", data)
        if subject is None:
            return [head], None, None
        record = dict(w.split("=", 1) for w in (words[1].decode() if words else "").split())
        return [head], {"run_id": subject[1].decode(), **record}, None


def _show_rrd(path: Path) -> _ShowResult:
    from rerun.chunk import RrdReader

    reader = RrdReader(str(path))
    (recording, *_) = reader.recordings()
    entities, timelines = set(), set()
    for chunk in reader.store().stream():
        if not chunk.entity_path.startswith("/__"):
            entities.add(chunk.entity_path)
            timelines.update(chunk.timeline_names)
    kb = path.stat().st_size / 1024
    lines = [
        f"{path}: Rerun recording {recording.recording_id!r}, {kb:.0f} kB (rerun {path})",
        f"  timelines: {', '.join(sorted(timelines - {'log_time'})) or '-'}",
        f"  {len(entities)} entities: {', '.join(sorted(entities))}",
    ]
    return lines, read_output_provenance(path), None


def provenance(files: list[Path], key: str | None) -> int:
    """Each file's full provenance record (or its ``key``), as JSON; every file is tried."""
    status = 0
    for path in files:
        try:
            record = read_output_provenance(path)
        except Exception as error:  # noqa: BLE001 - any unreadable file: say which, go on
            print(
                f"{path}: not a pih output with provenance ({first_line(error)})", file=sys.stderr
            )
            status = 1
            continue
        if key is not None and key not in record:
            print(f"{path}: no key {key!r}; keys are {sorted(record)}", file=sys.stderr)
            status = 1
            continue
        print(f"# {path}")
        print(json.dumps(record if key is None else record[key], indent=2, sort_keys=True))
    return status
