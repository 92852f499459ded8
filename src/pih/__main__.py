"""Command line (``python -m pih`` or the ``pih`` console script):

- ``pih show FILE``: a Parquet output's columns with units, row count and provenance summary;
- ``pih provenance FILE... [--key K]``: the full provenance record (Parquet or recording);
- ``pih plot RUN_DIR [--output F]``: one planning run's cost curve and best paths, as
  ``RUN_DIR/run.png`` or ``F``;
- ``pih replay RUN_DIR QUERY [--output F]``: simulate again the first rollout of the run
  matching a pandas query (e.g. ``"phase == 'deploy' and rollout == 3"``), check it ends where
  the record says, and write it as a Rerun recording
  ``RUN_DIR/replay_<phase>_<iteration>_<rollout>.rrd`` (or ``F``);
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
- ``pih schema``: the JSON schema of the study's config;
- ``pih job TARGET [--configfile F ...]``: run the workflow script that makes ``TARGET`` in this
  process, outside Snakemake, for debugging (``python -m pdb -m pih job TARGET``).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

from pih.outputs import read_output_provenance, read_provenance


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="pih", description=__doc__)
    commands = parser.add_subparsers(dest="command", required=True)
    show = commands.add_parser("provenance", help="print the provenance record of output files")
    show.add_argument("files", nargs="+", type=Path, help="Parquet outputs (or .rrd recordings)")
    show.add_argument("--key", help="print only this top-level key")
    commands.add_parser("schema", help="print the JSON schema of config/config.yaml")
    look = commands.add_parser("show", help="columns, units, rows and provenance of a Parquet file")
    look.add_argument("file", type=Path)
    plot = commands.add_parser("plot", help="cost curve and best paths of one planning run")
    plot.add_argument("run", type=Path, help="a results/planning/<sweep point>/ directory")
    plot.add_argument("--output", type=Path, help="the PNG to write (default RUN_DIR/run.png)")
    replay = commands.add_parser("replay", help="simulate one recorded rollout again, to Rerun")
    replay.add_argument("run", type=Path, help="a results/planning/<sweep point>/ directory")
    replay.add_argument(
        "query", help="pandas query on rollouts.parquet, e.g. \"phase == 'deploy'\""
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
    job = commands.add_parser("job", help="run the workflow script that makes TARGET, here")
    job.add_argument(
        "target", help="an output path, e.g. results/validation/point/offset_m~0.001.parquet"
    )
    job.add_argument("--configfile", nargs="+", help="config files (default config/config.yaml)")
    args = parser.parse_args(argv)
    if args.command == "job":
        return _job(args.target, args.configfile)
    if args.command == "show":
        return _show(args.file)
    if args.command == "plot":
        return _plot(args.run, args.output)
    if args.command == "replay":
        return _replay(args.run, args.query, args.output)
    if args.command == "redeploy":
        return _redeploy(args.runs, args.start_std_m, args.output, args.workers)
    if args.command == "aggregate":
        return _aggregate(args.paths, args.output_dir, args.reference_variant)
    if args.command == "schema":
        from pih.study_config import config_schema

        print(json.dumps(config_schema(), indent=2))
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


def _show(path: Path) -> int:
    import pyarrow.parquet as pq

    try:
        meta = pq.ParquetFile(path).metadata
        schema = pq.read_schema(path)
        record = read_provenance(path)
    except Exception as error:  # noqa: BLE001 - any unreadable file: one clear line
        first = _first_line(error)
        print(f"{path}: not a pih Parquet output ({first})", file=sys.stderr)
        return 1
    print(f"{path}: {meta.num_rows} rows, {len(schema)} columns")
    width = max(len(field.name) for field in schema)
    for field in schema:
        info = {k.decode(): v.decode() for k, v in (field.metadata or {}).items()}
        unit = info.get("unit") or "-"
        print(f"  {field.name:<{width}}  [{unit}]  {info.get('description', '')}")
    seeds = ", ".join(f"{k}={v}" for k, v in sorted(record.get("seeds", {}).items()))
    print(f"step {record['step']}; run id {record['run_id']}")
    print(f"seeds: {seeds or '-'}; config sha256 {record['config_sha256'][:12]}")
    print(
        f"code {record['code_version']}, library {record['library_sha256'][:12]}, "
        f"drake {record['packages']['drake']}, created {record['created_utc']}"
    )
    return 0


def _plot(run: Path, output: Path | None) -> int:
    import pandas as pd

    from pih import plots
    from pih.planner import RecordedRun

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


def _replay(run: Path, query: str, output: Path | None) -> int:
    import numpy as np

    from pih.planner import Planner, RecordedRun, recorded_pose, recorded_rollout
    from pih.provenance import record as provenance_record
    from pih.recordings import record_insertion

    try:
        recorded = RecordedRun.read(run / "rollouts.parquet")
        rollouts, config = recorded.rollouts, recorded.record["config"]
        rows = rollouts.query(query)
    except Exception as error:  # noqa: BLE001 - a bad run or query: one clear line
        first = _first_line(error)
        print(f"pih replay {run}: {first}", file=sys.stderr)
        return 1
    if "weights" not in rollouts or rows.empty:
        why = "it predates recorded weights" if "weights" not in rollouts else "no row matches"
        print(f"pih replay {run}: nothing to replay ({why}: {query!r})", file=sys.stderr)
        return 1
    row = rows.iloc[0]
    scene = recorded.scene
    planner = Planner.from_configs(scene, recorded.planner)
    start, target, weights, sensed = recorded_rollout(row)
    trace, _ = planner.evaluate(planner.dmp(start, target), weights, sensed)
    name = f"replay_{row['phase']}_{row['iteration']}_{row['rollout']}"
    same = np.array_equal(trace.q_peg_bottom[-1], recorded_pose(row, "final_bottom"))
    provenance = provenance_record(
        "replay", config=config, inputs=[run / "rollouts.parquet"], extra={"query": query}
    )
    target = output or run / f"{name}.rrd"
    record_insertion(target, trace, scene, name, provenance)
    print(
        f"{target}: {row['phase']} iteration {row['iteration']} rollout {row['rollout']}, "
        f"{trace.status}; P2 at the end ({', '.join(f'{v:.6g}' for v in trace.q_peg_bottom[-1])})"
        f" {'= the record' if same else 'DIFFERS from the record'}"
    )
    return 0 if same else 1


def _redeploy(runs: list[Path], start_std_m: float, output: Path | None, workers: int) -> int:
    import pandas as pd

    from pih.aggregate import wilson_interval
    from pih.config import ConfigError
    from pih.outputs import write_table
    from pih.planner import ROLLOUT_COLUMNS, RecordedRun
    from pih.provenance import record as provenance_record

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
            table = record.redeploy(start_std_m, workers)
        except ValueError as error:  # the record and its seeds disagree
            print(f"pih redeploy {run}: {_first_line(error)}", file=sys.stderr)
            return 1
        before = record.rollouts[record.rollouts["phase"] == "deploy"]["success"].mean()
        rate = table[table["phase"] == "deploy"]["success"].mean()
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
            config={"deploy_start_std_m": start_std_m},
            inputs=[run / "rollouts.parquet" for run in runs],
        )
        columns = {**ROLLOUT_COLUMNS, "run": ("", "the planning run's directory name")}
        write_table(pd.concat(tables, ignore_index=True), output, provenance, columns)
        print(output)
    return 0


def _aggregate(paths: list[Path], output_dir: Path, reference_variant: str | None) -> int:
    import pandas as pd

    from pih import plots
    from pih.aggregate import (
        BAND_COLUMNS,
        BEST_COST_COLUMNS,
        PAIRED_COLUMNS,
        SEED_KEY,
        SUCCESS_COLUMNS,
        figure_bands,
        level_columns,
        planning_tables,
        robustness_columns,
    )
    from pih.config import ConfigError
    from pih.outputs import markdown_table, write_table, write_text
    from pih.pooling import SOURCE_COLUMNS, find_outputs, pool
    from pih.provenance import record as provenance_record

    try:
        pooled = pool(*find_outputs(paths))
    except ConfigError as error:
        print(f"pih aggregate: {_first_line(error)}", file=sys.stderr)
        return 1
    keys = pooled.sweep_keys
    tables = planning_tables(
        pooled.runs, pooled.summaries, pooled.deployments, keys, reference_variant
    )
    provenance = provenance_record(
        "aggregate", config={"sweep_keys": keys}, inputs=sorted(set(pooled.sources["file"]))
    )
    outputs = {
        "runs": (pooled.runs, {**BEST_COST_COLUMNS, **level_columns(keys)}),
        "cost_bands": (tables.bands, BAND_COLUMNS),
        "success": (tables.success, SUCCESS_COLUMNS),
        "paired": (tables.paired, PAIRED_COLUMNS),
        "robustness": (tables.robustness, robustness_columns(keys)),
        "sources": (pooled.sources, SOURCE_COLUMNS),
    }
    for name, (frame, columns) in outputs.items():
        write_table(frame, output_dir / f"{name}.parquet", provenance, columns)
    for name in ("success", "paired", "robustness"):
        write_text(output_dir / f"{name}.md", markdown_table(outputs[name][0]), provenance)
    plots.save(
        plots.cost_band_figure(figure_bands(tables.bands)),
        output_dir / "fig9_cost_bands.png",
        output_dir / "fig9_cost_bands.pdf",
        provenance=provenance,
    )
    # Per start and per compared dimension; seeds only replicate, and a dimension with one level
    # repeats "all".
    success = tables.success
    levels = success.groupby("dimension")["level"].nunique()
    shown = [d for d, n in levels.items() if d == "all" or (n > 1 and d != SEED_KEY)]
    compared = success[success["dimension"].isin(shown)]
    plots.save(
        plots.deploy_success_figure(compared),
        output_dir / "fig_deploy_success.png",
        provenance=provenance,
    )
    overall = success[success["dimension"] == "all"]
    with pd.option_context("display.width", 200, "display.max_columns", 12):
        print(f"{len(pooled.summaries)} trainings, sweep keys {keys}")
        print(overall[["method", "runs", "deploy_success_rate", "deploy_ci_low", "deploy_ci_high"]])
        print(tables.paired[tables.paired["dimension"].isin(["all", "start_std_m", "variant"])])
        print(tables.robustness)
    print(output_dir)
    return 0


def _job(target: str, configfiles: list[str] | None) -> int:
    """Run the rule's script with the ``snakemake`` object Snakemake would give it."""
    import runpy

    from pih.workflow import mock_snakemake

    try:
        smk, script = mock_snakemake(target, configfiles)
    except ValueError as error:
        print(f"pih job: {error}", file=sys.stderr)
        return 1
    print(f"pih job: {script.name} for {target} (log: {smk.log[0] if smk.log else 'none'})")
    runpy.run_path(str(script), init_globals={"snakemake": smk}, run_name="__main__")
    return 0


if __name__ == "__main__":
    sys.exit(main())
