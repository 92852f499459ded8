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
  likely cause from the provenance: another CPU, Drake or code); an OLD that holds NEW's runs
  and more (``pih compare published/sim_to_real results``) is read at NEW's sweep points, two
  trees that each hold runs the other lacks (``published/paper``) at the points they share;
- ``pih publish [RESULTS] [--study default|sim_to_real|paper]``: copy a finished run of a
  published study (data, tables, figures, provenance; not the recordings) into
  ``published/<study>``, the files README's numbers come from, and regenerate README's results
  for it; refused when RESULTS is not that study's run at this code. The paper-scale and
  sim-to-real studies are published in parts: each call adds the runs RESULTS holds, and the
  tables are made once all (33, 48) are in. ``--redeploy [--limit N] [--workers N]``: make the
  redeployments the study's config asks for that its published runs lack (a model error added
  after them), beside them, at most N in one call; the tables are re-made once all are in.
  ``--replay-step [STEP_S] [--limit N] [--workers N]``: every deployment trial of the study's
  published runs replayed at STEP_S (default 6.25e-05 s, the step check's reference), one file
  per run beside it, at most N runs in one call;
- ``pih verify [STUDY_DIR ...]``: whether today's code computes exactly what the code that made
  the published runs computed: both run one suite (each published configuration at one recorded
  run, a few iterations) through their own workflow on this machine, every output column compared
  bit for bit; when all agree, ``published/equivalence.parquet`` gets a row that keeps the runs
  current (docs/reproducibility.md);
- ``pih status [DIR] [--configfile F ...]``: a study's progress, from the files in its working
  directory ``DIR`` (default ``.``): planning and validation runs done, running (with their
  iteration) and pending, and the time left (:mod:`pih.workflow.status`);
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

from pih.cli import job
from pih.cli.common import first_line
from pih.cli.show import SHOWN_TYPES
from pih.publishing.compare import R_TOLERANCE
from pih.publishing.published import PUBLISHED_STUDIES
from pih.publishing.reference_step import REFERENCE_STEP_S


def _one_line_errors(command: Callable[[list[str] | None], int]) -> Callable[..., int]:
    """Any error of a command as one line (``pih COMMAND: what``) and exit status 1."""

    @functools.wraps(command)
    def run(argv: list[str] | None = None) -> int:
        try:
            return command(argv)
        except BrokenPipeError:
            # The reader stopped early (pih show F | head): end quietly, its output is complete
            # for it. stdout now points at nothing, so that the exit's flush cannot fail again.
            os.dup2(os.open(os.devnull, os.O_WRONLY), sys.stdout.fileno())
            return 0
        except Exception as error:
            if job.running_script or os.environ.get("PIH_TRACEBACK", "") not in ("", "0"):
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
    return f"{first_line(error)} ({type(error).__name__})"


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
    drawn = commands.add_parser(
        "scene", help="draw a study's scene: peg, hole, spring and robot frame (README's picture)"
    )
    drawn.add_argument(
        "--configfile",
        type=Path,
        nargs="+",
        default=[Path("config/config.yaml")],
        help="the study's config files, as given to Snakemake (default config/config.yaml)",
    )
    drawn.add_argument("--output", type=Path, default=Path("scene.png"), help="the PNG to write")
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
        "publish", help="copy a finished study into published/STUDY (its page's source)"
    )
    publish.add_argument(
        "results",
        type=Path,
        nargs="?",
        default=Path("results"),
        help="the results tree of a finished run of the study (default: results)",
    )
    publish.add_argument(
        "--study",
        choices=list(PUBLISHED_STUDIES),
        default="default",
        help="which published study RESULTS is a run of (default: default)",
    )
    instead = publish.add_mutually_exclusive_group()
    instead.add_argument(
        "--redeploy",
        action="store_true",
        help="instead: redeploy the study's published runs where a redeployment its config asks "
        "for is missing (e.g. a model error), writing beside them",
    )
    instead.add_argument(
        "--replay-step",
        type=float,
        nargs="?",
        const=REFERENCE_STEP_S,
        metavar="STEP_S",
        help="instead: replay every deployment trial of the study's published runs at STEP_S "
        "(default 6.25e-05, the step check's reference), a file beside each run",
    )
    publish.add_argument(
        "--limit", type=int, help="--redeploy, --replay-step: at most this many in this call"
    )
    publish.add_argument(
        "--workers", type=int, default=1, help="--redeploy, --replay-step: rollout processes"
    )
    equivalent = commands.add_parser(
        "verify",
        help="does today's code compute what made the published runs (run both on one suite)",
    )
    equivalent.add_argument(
        "studies",
        type=Path,
        nargs="*",
        help="published study directories (default: every one, e.g. published/paper)",
    )
    equivalent.add_argument(
        "--stop-at-difference",
        action="store_true",
        help="run no item after the first whose outputs differ (the answer is then no)",
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
        "target", help="an output path, e.g. results/validation/point_1e7/offset_m~0.001.parquet"
    )
    job.add_argument("--configfile", nargs="+", help="config files (default config/config.yaml)")
    # `pih COMMAND --help` opens with what the command does, as `pih --help` lists it.
    for listed in commands._choices_actions:
        command = commands.choices[listed.dest]
        command.description = command.description or listed.help
    args = parser.parse_args(argv)
    return _run(args)


def _run(args: argparse.Namespace) -> int:
    """The subcommand ``args`` names, each imported only when it runs (``pih aggregate`` and
    ``pih compare`` load no Drake)."""
    if args.command == "job":
        return job.job(args.target, args.configfile)
    if args.command == "status":
        from pih.cli.status import status

        return status(args.study, args.configfile, args.jobs)
    if args.command == "show":
        from pih.cli.show import show

        return show(args.file)
    if args.command == "provenance":
        from pih.cli.show import provenance

        return provenance(args.files, args.key)
    if args.command == "plot":
        from pih.cli.plot import plot

        return plot(args.run, args.output)
    if args.command == "scene":
        from pih.cli.scene import scene

        return scene(args.configfile, args.output)
    if args.command == "replay":
        from pih.cli.replay import replay

        return replay(args.run, args.query, args.output, args.set)
    if args.command == "redeploy":
        from pih.cli.redeploy import redeploy

        return redeploy(args.runs, args.start_std_m, args.output, args.workers)
    if args.command == "aggregate":
        from pih.cli.aggregate import aggregate

        return aggregate(args.paths, args.output_dir, args.reference_variant)
    if args.command == "publish":
        from pih.cli.publish import publish, redeploy_published, replay_published

        if args.redeploy:
            return redeploy_published(args.study, args.limit, args.workers)
        if args.replay_step is not None:
            return replay_published(args.study, args.replay_step, args.limit, args.workers)
        return publish(args.results, args.study)
    if args.command == "compare":
        from pih.cli.compare import compare

        return compare(args.old, args.new, args.rtol, args.r_tolerance)
    if args.command == "verify":
        from pih.cli.verify import verify

        return verify(args.studies, args.stop_at_difference)
    from pih.study.schema import config_markdown, config_schema

    schema_json = json.dumps(config_schema(), indent=2) + "\n"
    print(config_markdown() if args.markdown else schema_json, end="")
    return 0


if __name__ == "__main__":
    sys.exit(main())
