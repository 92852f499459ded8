"""Command line (``python -m pih`` or the ``pih`` console script):

- ``pih show FILE``: a Parquet output's columns with units, row count and provenance summary;
- ``pih provenance FILE... [--key K]``: the full provenance record (Parquet or recording);
- ``pih plot RUN_DIR [--output F]``: one planning run's cost curve and best paths, as
  ``RUN_DIR/run.png`` or ``F``;
- ``pih replay RUN_DIR QUERY [--set KEY=VALUE ...] [--output F]``: simulate again the rollouts
  of the run that the query selects (``column op value`` terms joined by and/or, e.g.
  ``"phase == 'deploy' and rollout == 3"``; parsed, never evaluated), one machine-readable line
  each: recorded and replayed end pose of P2 and whether each inserted; the first as a Rerun
  recording ``RUN_DIR/replay_<phase>_<iteration>_<rollout>.rrd`` (or ``F``). ``--set
  scene.solver.time_step_s=0.0005`` replays under other physics;
- ``pih redeploy RUN... --start-std-m S``: deploy each run's learned policy again (a run is its
  directory or its ``rollouts.parquet``), as it would have deployed with
  ``planner.deploy_start_std_m = S`` (same sensed holes and targets, starts from its deployment
  stream), and print the success rates with a 95 % Wilson interval
  over the runs; ``--output F`` writes the rollouts as Parquet with provenance;
- ``pih aggregate PATH... --output-dir DIR``: pool the planning runs and redeployments under
  the PATHs (several studies' results directories, run directories, redeployment files) into
  the success, paired, robustness and cost-band tables and their figures, each training
  counted once; runs must differ only in their sweep levels (docs/planner.md, "Pooling
  studies");
  ``--reference-variant V`` also compares each variant of an ablation with ``V``;
- ``pih compare OLD NEW [--rtol R] [--r-tolerance T]``: did NEW reproduce OLD, e.g.
  ``pih compare published/default results`` after a fresh ``snakemake -j2``: its conclusions
  (deployment success inside OLD's intervals, paired signs, validation r; exit 0 when they hold)
  and its data (headline numbers and planning runs' data, each that differs named, with the
  likely cause from the provenance: another CPU, Drake or code);
- ``pih publish [RESULTS] [--study default|sim_to_real]``: copy a finished run of a published
  study (data, tables, figures, provenance; not the recordings) into ``published/<study>``, the
  files README's numbers come from, and regenerate README's results for it; refused when
  RESULTS is not that study's run at this code;
- ``pih status [DIR] [--configfile F ...]``: a study's progress, from the files in its working
  directory ``DIR`` (default ``.``): planning and validation runs done, running (with their
  iteration) and pending, and the time left (:mod:`pih.status`);
- ``pih schema [--markdown]``: the JSON schema of the study's config (or
  docs/configuration.md, every key's type, default and description);
- ``pih job TARGET [--configfile F ...]``: run the workflow script that makes ``TARGET`` in this
  process, outside Snakemake, for debugging (``python -m pdb -m pih job TARGET``).

Every error is one line on stderr and exit status 1 (``PIH_TRACEBACK=1`` shows the traceback);
an error in the script ``pih job`` runs keeps its traceback.
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import sys
from collections.abc import Callable
from pathlib import Path

from pih.compare import R_TOLERANCE
from pih.outputs import read_output_provenance, read_provenance

_RUNNING_SCRIPT = False  # set while `pih job` runs a workflow script: its errors keep tracebacks


def _one_line_errors(command: Callable[[list[str] | None], int]) -> Callable[..., int]:
    """Any error of a command as one line (``pih COMMAND: what``) and exit status 1."""

    @functools.wraps(command)
    def run(argv: list[str] | None = None) -> int:
        try:
            return command(argv)
        except Exception as error:
            if _RUNNING_SCRIPT or os.environ.get("PIH_TRACEBACK", "") not in ("", "0"):
                raise
            words = sys.argv[1:] if argv is None else argv
            name = " ".join(["pih", *[w for w in words if not w.startswith("-")][:1]])
            print(f"{name}: {_describe(error)}", file=sys.stderr)
            return 1

    return run


def _describe(error: Exception) -> str:
    if isinstance(error, KeyError):
        return f"missing key {error.args[0]!r} (KeyError)" if error.args else "KeyError"
    if isinstance(error, OSError) and error.strerror:
        return f"{error.filename}: {error.strerror}" if error.filename else error.strerror
    return f"{_first_line(error)} ({type(error).__name__})"


@_one_line_errors
def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="pih",
        description="Look at, replay, compare and pool the outputs of a pih study "
        "(docs/workflow.md). `pih COMMAND --help` describes each command.",
    )
    commands = parser.add_subparsers(dest="command", required=True)
    show = commands.add_parser("provenance", help="print the provenance record of output files")
    show.add_argument("files", nargs="+", type=Path, help="Parquet outputs (or .rrd recordings)")
    show.add_argument("--key", help="print only this top-level key")
    schema = commands.add_parser("schema", help="print the JSON schema of config/config.yaml")
    schema.add_argument(
        "--markdown",
        action="store_true",
        help="print docs/configuration.md instead: every key's type, default and description",
    )
    look = commands.add_parser(
        "show",
        help="what an output holds (columns and rows, first lines, figure size, recording "
        "entities) and its provenance",
    )
    look.add_argument("file", type=Path, help=f"an output file ({SHOWN_TYPES})")
    plot = commands.add_parser("plot", help="cost curve and best paths of one planning run")
    plot.add_argument("run", type=Path, help="a results/planning/<sweep point>/ directory")
    plot.add_argument("--output", type=Path, help="the PNG to write (default RUN_DIR/run.png)")
    replay = commands.add_parser(
        "replay", help="simulate recorded rollouts again (one line each; the first to Rerun)"
    )
    replay.add_argument("run", type=Path, help="a results/planning/<sweep point>/ directory")
    replay.add_argument(
        "query",
        help="rows of rollouts.parquet: column op value terms joined by and/or, e.g. "
        "\"phase == 'deploy' and rollout == 3\" (parsed, never evaluated as code)",
    )
    replay.add_argument(
        "--set",
        action="append",
        default=[],
        metavar="KEY=VALUE",
        help="replay under other physics, e.g. --set scene.solver.time_step_s=0.00025 (repeatable)",
    )
    replay.add_argument(
        "--output",
        type=Path,
        help="the .rrd to write (default RUN_DIR/replay_<phase>_<it>_<n>.rrd)",
    )
    redeploy = commands.add_parser(
        "redeploy", help="deploy runs' learned policies again from offset starts"
    )
    redeploy.add_argument(
        "runs",
        nargs="+",
        type=Path,
        help="results/planning/<point>/ dirs or their rollouts.parquet files",
    )
    redeploy.add_argument(
        "--start-std-m", type=float, required=True, help="start offset std in x and y, m"
    )
    redeploy.add_argument("--output", type=Path, help="Parquet file of the redeployed rollouts")
    redeploy.add_argument("--workers", type=int, default=1, help="rollout processes per run")
    pooled = commands.add_parser(
        "aggregate",
        help="pool planning runs of several studies into the summary tables and figures",
    )
    pooled.add_argument("paths", nargs="+", type=Path, help="results dirs, run dirs or files")
    pooled.add_argument(
        "--output-dir", type=Path, required=True, help="where the tables and figures go"
    )
    pooled.add_argument(
        "--reference-variant", help="compare each variant of an ablation against this one"
    )
    check = commands.add_parser(
        "compare", help="did NEW reproduce OLD: its conclusions, and its data number by number"
    )
    check.add_argument("old", type=Path, help="a results tree, e.g. published/default")
    check.add_argument("new", type=Path, help="another, e.g. results")
    check.add_argument(
        "--rtol", type=float, default=1e-9, help="relative tolerance for numbers (default 1e-9)"
    )
    check.add_argument(
        "--r-tolerance",
        type=float,
        default=R_TOLERANCE,
        help=f"how far a validation r may move (default {R_TOLERANCE:g})",
    )
    publish = commands.add_parser(
        "publish", help="copy a finished study into published/STUDY (README's source)"
    )
    publish.add_argument("results", type=Path, nargs="?", default=Path("results"))
    publish.add_argument(
        "--study",
        choices=["default", "sim_to_real"],
        default="default",
        help="which published study RESULTS is a run of (default: default)",
    )
    watch = commands.add_parser(
        "status", help="a study's progress: runs done, running and pending, and the time left"
    )
    watch.add_argument(
        "study", type=Path, nargs="?", default=Path("."), help="its working directory (default .)"
    )
    watch.add_argument(
        "--configfile", nargs="+", default=[], help="the study's config files, as for snakemake"
    )
    watch.add_argument("--jobs", type=int, help="jobs in parallel (default: as many as run, ≥ 2)")
    job = commands.add_parser("job", help="run the workflow script that makes TARGET, here")
    job.add_argument(
        "target", help="an output path, e.g. results/validation/point/offset_m~0.001.parquet"
    )
    job.add_argument("--configfile", nargs="+", help="config files (default config/config.yaml)")
    args = parser.parse_args(argv)
    if args.command == "job":
        return _job(args.target, args.configfile)
    if args.command == "status":
        return _status(args.study, args.configfile, args.jobs)
    if args.command == "show":
        return _show(args.file)
    if args.command == "plot":
        return _plot(args.run, args.output)
    if args.command == "replay":
        return _replay(args.run, args.query, args.output, args.set)
    if args.command == "redeploy":
        return _redeploy(args.runs, args.start_std_m, args.output, args.workers)
    if args.command == "aggregate":
        return _aggregate(args.paths, args.output_dir, args.reference_variant)
    if args.command == "publish":
        return _publish(args.results, args.study)
    if args.command == "compare":
        return _compare(args.old, args.new, args.rtol, args.r_tolerance)
    if args.command == "schema":
        from pih.study_config import config_markdown, config_schema

        schema_json = json.dumps(config_schema(), indent=2) + "\n"
        print(config_markdown() if args.markdown else schema_json, end="")
        return 0

    status = 0
    for path in args.files:
        try:
            record = read_output_provenance(path)
        except Exception as error:  # noqa: BLE001 - any unreadable file: say which, go on
            first = _first_line(error)
            print(f"{path}: not a pih output with provenance ({first})", file=sys.stderr)
            status = 1
            continue
        if args.key is not None and args.key not in record:
            print(f"{path}: no key {args.key!r}; keys are {sorted(record)}", file=sys.stderr)
            status = 1
            continue
        value = record if args.key is None else record[args.key]
        print(f"# {path}")
        print(json.dumps(value, indent=2, sort_keys=True))
    return status


def _first_line(error: Exception) -> str:
    return str(error).splitlines()[0] if str(error) else type(error).__name__


SHOWN_SUFFIXES = (".parquet", ".csv", ".md", ".html", ".png", ".pdf", ".rrd")
SHOWN_TYPES = ", ".join(SHOWN_SUFFIXES)


def _show(path: Path) -> int:
    """What an output holds and where it came from, by type: a Parquet or CSV table's columns
    (with units) and rows, a Markdown file's first lines, a figure's size, a recording's
    entities and timelines; then its provenance (its own record; a CSV's is in its companion
    Parquet, a PDF's in its companion PNG). A missing path suggests the closest existing one."""
    if not path.exists():
        print(f"pih show: no such file: {path}{_did_you_mean(path)}", file=sys.stderr)
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
        print(f"pih show: {path}: not a pih {kind} output ({_first_line(error)})", file=sys.stderr)
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


def _did_you_mean(path: Path) -> str:
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
    from pih.outputs import MARKDOWN_PROVENANCE

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

    from pih.outputs import MARKDOWN_PROVENANCE

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


def _plot(run: Path, output: Path | None) -> int:
    import pandas as pd

    from pih import plots
    from pih.run_record import RecordedRun

    if _missing_parent("plot", "--output", output):
        return 1
    try:
        recorded = RecordedRun.read(run / "rollouts.parquet")
        paths = pd.read_parquet(run / "best_paths.parquet")
    except Exception as error:  # noqa: BLE001 - any unreadable run: one clear line
        first = _first_line(error)
        print(f"{run}: not a planning run directory ({first})", file=sys.stderr)
        return 1
    target = output or run / "run.png"
    figure = plots.run_figure(recorded.rollouts, paths, recorded.scene.hole, run.name)
    plots.save(figure, target, provenance=recorded.record)
    print(target)
    return 0


def _replay(run: Path, query: str, output: Path | None, settings: list[str]) -> int:
    import numpy as np
    import yaml

    from pih.config import ConfigError, to_mapping
    from pih.planner import Planner
    from pih.provenance import record as provenance_record
    from pih.recordings import record_insertion
    from pih.row_query import select_rows
    from pih.run_record import RecordedRun, recorded_pose, recorded_rollout, succeeded
    from pih.study_config import scene_with

    try:
        recorded = RecordedRun.read(run / "rollouts.parquet")
        rollouts, config = recorded.rollouts, recorded.record["config"]
        rows = select_rows(rollouts, query)
        overrides = {}
        for setting in settings:
            key, sep, value = setting.partition("=")
            if not sep or not key.startswith("scene."):
                raise ConfigError(f"--set {setting!r}: expected scene.<section>.<key>=<value>")
            overrides[key.removeprefix("scene.")] = yaml.safe_load(value)
        if "solver.time_step_s" in overrides and "solver.retry_time_step_s" not in overrides:
            overrides["solver.retry_time_step_s"] = overrides["solver.time_step_s"] / 2
        scene = scene_with(to_mapping(recorded.scene), overrides, "--set")
    except Exception as error:  # noqa: BLE001 - a bad run, query or setting: one clear line
        print(f"pih replay {run}: {_first_line(error)}", file=sys.stderr)
        return 1
    if "weights" not in rollouts or rows.empty:
        if "weights" not in rollouts:
            why = "it predates recorded weights"
        else:
            why = (
                f"no row matches {query!r}; "
                + ", ".join(
                    f"{c} {rollouts[c].min()}–{rollouts[c].max()}" for c in ("iteration", "rollout")
                )
                + f", phases {', '.join(sorted(rollouts['phase'].unique()))}"
            )
        print(f"pih replay {run}: nothing to replay ({why})", file=sys.stderr)
        return 1
    planner = Planner.from_configs(scene, recorded.planner)
    hole, tolerance = planner.scene.hole_pose, recorded.planner.success_tolerance_m
    differs = 0
    for index, (_, row) in enumerate(rows.iterrows()):
        rollout = recorded_rollout(row)
        trace, _ = planner.evaluate_rollout(rollout)
        replayed = trace.q_peg_bottom[-1]
        simulated = hole if rollout.simulated_hole is None else rollout.simulated_hole
        inserted = succeeded(trace, simulated, tolerance)
        same = np.array_equal(replayed, recorded_pose(row, "final_bottom"))
        differs += not same
        if index == 0:
            name = f"replay_{row['phase']}_{row['iteration']}_{row['rollout']}"
            extra = {"query": query, "set": overrides}
            provenance = provenance_record(
                "replay", config=config, inputs=[run / "rollouts.parquet"], extra=extra
            )
            target_file = output or run / f"{name}.rrd"
            record_insertion(target_file, trace, scene, name, provenance)
            print(f"# {target_file}: the first row's replay, as a Rerun recording")
        pose = ",".join(f"{v:.9g}" for v in recorded_pose(row, "final_bottom"))
        print(
            f"phase={row['phase']} iteration={row['iteration']} rollout={row['rollout']} "
            f"recorded_p2={pose} replayed_p2={','.join(f'{v:.9g}' for v in replayed)} "
            f"recorded_inserted={int(bool(row['success']))} replayed_inserted={int(inserted)} "
            f"status={trace.status} same={int(same)}"
        )
    # Without --set a replay must end where the record says (exit 1 if not); with it, it may not.
    return 0 if settings or not differs else 1


def _publish(results: Path, name: str) -> int:
    from pih.published import PUBLISHED_STUDIES, publish, readme_with_results, results_block

    study, readme = PUBLISHED_STUDIES[name], Path("README.md")
    if not readme.is_file():
        print("pih publish: run it from the repository's root (no README.md here)", file=sys.stderr)
        return 1
    if study.markers[0] not in readme.read_text():
        print(f"pih publish: README.md has no {study.markers[0]} line", file=sys.stderr)
        return 1
    try:
        copied = publish(results, study)
    except (OSError, ValueError) as error:
        print(f"pih publish: {_first_line(error)}", file=sys.stderr)
        return 1
    block = results_block(study.directory, study)
    readme.write_text(readme_with_results(readme.read_text(), block, study))
    print(f"{study.directory}: {copied} files from {results}; README.md's results for it")
    return 0


def _compare(old: Path, new: Path, rtol: float, r_tolerance: float) -> int:
    from pih.compare import compare

    try:
        result = compare(old, new, rtol, r_tolerance)
    except (OSError, ValueError) as error:
        print(f"pih compare: {_first_line(error)}", file=sys.stderr)
        return 1
    for difference in result.differences:
        print(difference)
    within = "bit-identical" if rtol == 0 else f"within --rtol {rtol:g}"
    data = "the same" if result.data_identical else "NOT the same"
    print(f"data: {result.differing_items()} of {result.items} items differ: {data} ({within})")
    if result.causes:
        print(f"data: likely causes, from the provenance: {'; '.join(result.causes)}")
    failed = [check for check in result.checks if not check.holds]
    for check in failed:
        print(check)
    verdict = "reproduced" if result.conclusions_hold else "NOT reproduced"
    print(
        f"conclusions: {len(result.checks) - len(failed)} of {len(result.checks)} hold "
        f"(deployment success inside the 95 % intervals, paired signs, validation r within "
        f"{r_tolerance:g}): {new} {verdict} {old}"
    )
    return 0 if result.conclusions_hold else 1


def _redeploy(runs: list[Path], start_std_m: float, output: Path | None, workers: int) -> int:
    import pandas as pd

    from pih.aggregate import wilson_interval
    from pih.config import ConfigError
    from pih.outputs import write_table
    from pih.provenance import record as provenance_record
    from pih.redeployment import redeploy
    from pih.run_record import ROLLOUT_COLUMNS, Phase, RecordedRun, phase_rows

    if _missing_parent("redeploy", "--output", output):
        return 1
    # A run's rollouts.parquet names its run (results/planning/*/rollouts.parquet skips summary/).
    runs = [run.parent if run.name == "rollouts.parquet" else run for run in runs]
    recorded = []
    for run in runs:  # every run is read and checked before any is simulated
        try:
            recorded.append(RecordedRun.read(run / "rollouts.parquet"))
        except Exception as error:  # noqa: BLE001 - an unreadable run: one clear line
            print(f"pih redeploy {run}: cannot redeploy ({_first_line(error)})", file=sys.stderr)
            return 1
        try:
            recorded[-1].redeployment_config(start_std_m)
        except ConfigError as error:
            print(f"pih redeploy: --start-std-m: {_first_line(error)}", file=sys.stderr)
            return 1
        except ValueError as error:  # e.g. a run older than recorded weights
            print(f"pih redeploy {run}: cannot redeploy ({_first_line(error)})", file=sys.stderr)
            return 1
    tables, rates = [], []
    for run, record in zip(runs, recorded, strict=True):
        try:
            table = redeploy(record, start_std_m, workers)
        except ValueError as error:  # the record and its seeds disagree
            print(f"pih redeploy {run}: {_first_line(error)}", file=sys.stderr)
            return 1
        before = phase_rows(record.rollouts, Phase.DEPLOY)["success"].mean()
        rate = phase_rows(table, Phase.DEPLOY)["success"].mean()
        rates.append(rate)
        print(
            f"{run.name}: deployed {rate:.0%} from starts offset by N(0, ({start_std_m:g} m)²) "
            f"(recorded {before:.0%} at {record.planner.deploy_start_std_m:g} m)"
        )
        tables.append(table.assign(run=run.name))
    low, high = wilson_interval(sum(rates), len(rates))
    print(
        f"{len(rates)} runs: deployment success {sum(rates) / len(rates):.3g} (95 % Wilson "
        f"interval over runs {low:.2f}-{high:.2f})"
    )
    if output is not None:
        provenance = provenance_record(
            "redeploy",
            config={"planner": {"deploy_start_std_m": start_std_m}},  # as the rule's files
            inputs=[run / "rollouts.parquet" for run in runs],
        )
        columns = {**ROLLOUT_COLUMNS, "run": ("", "the planning run's directory name")}
        write_table(pd.concat(tables, ignore_index=True), output, provenance, columns)
        print(output)
    return 0


def _aggregate(paths: list[Path], output_dir: Path, reference_variant: str | None) -> int:
    import pandas as pd

    from pih.aggregate import planning_tables
    from pih.config import ConfigError
    from pih.outputs import write_table
    from pih.planning_summary import write_planning_summary
    from pih.pooling import SOURCE_COLUMNS, find_outputs, pool
    from pih.provenance import record as provenance_record

    if output_dir.exists() and not output_dir.is_dir():
        print(f"pih aggregate: --output-dir {output_dir}: not a directory", file=sys.stderr)
        return 1
    try:
        pooled = pool(*find_outputs(paths))
    except ConfigError as error:
        print(f"pih aggregate: {_first_line(error)}", file=sys.stderr)
        return 1
    keys = pooled.sweep_keys
    if reference_variant is not None:
        known = (
            sorted(map(str, pooled.summaries["variant"].dropna().unique()))
            if "variant" in keys and "variant" in pooled.summaries
            else []
        )
        if reference_variant not in known:
            print(
                f"pih aggregate: --reference-variant {reference_variant!r} is not a variant of "
                f"these runs ({known or 'they sweep no variant'})",
                file=sys.stderr,
            )
            return 1
    tables = planning_tables(
        pooled.runs, pooled.summaries, pooled.deployments, keys, reference_variant
    )
    provenance = provenance_record(
        "aggregate", config={"sweep_keys": keys}, inputs=sorted(set(pooled.sources["file"]))
    )
    write_planning_summary(output_dir, pooled.runs, tables, keys, provenance)
    write_table(pooled.sources, output_dir / "sources.parquet", provenance, SOURCE_COLUMNS)
    success = tables.success
    overall = success[success["dimension"] == "all"]
    with pd.option_context("display.width", 200, "display.max_columns", 12):
        print(f"{len(pooled.summaries)} trainings, sweep keys {keys}")
        print(overall[["method", "runs", "deploy_success_rate", "deploy_ci_low", "deploy_ci_high"]])
        print(tables.paired[tables.paired["dimension"].isin(["all", "start_std_m", "variant"])])
        print(tables.robustness)
    print(output_dir)
    return 0


def _status(study: Path, configfiles: list[str], jobs: int | None) -> int:
    """One progress line per kind of run of the study in ``study`` (:mod:`pih.status`). Its
    config: ``config/config.yaml`` (here, else in ``study``, else in pih's checkout) with
    ``configfiles`` merged on; without ``configfiles``, those of the latest Snakemake run in
    ``study`` (its log in ``.snakemake/log/``), else the default config alone."""
    from pih.status import logged_configfiles, study_status

    if not study.is_dir():
        print(f"pih status: no such directory: {study}{_did_you_mean(study)}", file=sys.stderr)
        return 1
    # Without --configfile: the config files of the latest Snakemake run there. A study run in
    # its own directory (snakemake -s REPO/Snakefile) has the default config in pih's checkout.
    files = None if configfiles else logged_configfiles(study)
    if files is None:
        checkout = Path(__file__).resolve().parents[2]
        places = [Path("config"), study / "config", checkout / "config"]
        default = next((p / "config.yaml" for p in places if (p / "config.yaml").is_file()), None)
        if default is None:
            raise FileNotFoundError(
                "no config/config.yaml here, in the study directory or in pih's checkout; run "
                "pih status in the workflow's directory (pih status STUDY_DIR --configfile ...)"
            )
        files = [str(default), *configfiles]
    for line in study_status(study, files, jobs):
        print(line)
    return 0


def _job(target: str, configfiles: list[str] | None) -> int:
    """Run the rule's script with the ``snakemake`` object Snakemake would give it."""
    import runpy

    from pih.study_config import load_config_file
    from pih.workflow import mock_snakemake

    global _RUNNING_SCRIPT
    try:
        if not Path("Snakefile").is_file():
            raise ValueError(f"no Snakefile in {Path.cwd()}; run it in the workflow's directory")
        for path in configfiles or []:
            load_config_file(path)  # one line naming a missing, empty or malformed file
        smk, script = mock_snakemake(target, configfiles)
    except ValueError as error:  # a ConfigError too
        print(f"pih job: {_first_line(error)}", file=sys.stderr)
        return 1
    except Exception as error:  # noqa: BLE001 - Snakemake's errors: one line
        print(f"pih job: {_first_line(error)} ({type(error).__name__})", file=sys.stderr)
        return 1
    missing = [str(path) for path in smk.input if not Path(path).exists()]
    if missing:
        more = f" and {len(missing) - 3} more" if len(missing) > 3 else ""
        print(
            f"pih job: {target}: {len(missing)} input(s) missing ({', '.join(missing[:3])}{more});"
            f" make them first with snakemake (pih job runs one script, not its upstream jobs)",
            file=sys.stderr,
        )
        return 1
    print(f"pih job: {script.name} for {target} (log: {smk.log[0] if smk.log else 'none'})")
    _RUNNING_SCRIPT = True
    try:
        runpy.run_path(str(script), init_globals={"snakemake": smk}, run_name="__main__")
    finally:
        _RUNNING_SCRIPT = False
    return 0


def _missing_parent(command: str, option: str, output: Path | None) -> bool:
    """Whether ``output``'s directory is missing (said on stderr): a CLI writes only into an
    existing directory."""
    if output is None or output.parent.is_dir():
        return False
    print(f"pih {command}: {option} {output}: no directory {output.parent}", file=sys.stderr)
    return True


if __name__ == "__main__":
    sys.exit(main())
