"""Step convergence: do insertion outcomes agree at the study's time step and at half of it?

Every number the study reports is an insertion outcome decided at the chamfer, where a tilted
peg either slides in or wedges; a step that is too coarse decides some of those differently.
This check replays a fixed set of recorded planning rollouts (the same robot motion: start, P2
target and DMP weights) at the configured step h and at h/2 (the retry step halved too) and
counts the outcomes that flip.

The set (``benchmarks/step_convergence_set.parquet``, committed) and its recipe: from every
given run's training rollouts (``phase == 'train'``) in the later half of its iterations
(contact-rich: by then most rollouts reach the chamfer or the hole), an equal number per method
(one-level, the paper's rule, ours), drawn without replacement by ``numpy.random.default_rng(0)``
after sorting by (run, iteration, rollout); 240 in all (80 per method). Redraw it with
``--draw-from results/planning/*/rollouts.parquet``.

    python benchmarks/step_convergence.py [--configfile config/config.yaml] [--workers 2]
                                          [--time-step-s H] [--draw-from RUN ...]

``--deployments RUN ...`` (``results/planning/*/rollouts.parquet``) replays instead the
deployment trials a study reports (each run's ``phase == 'deploy'`` trials from the training
start and from its redeployed offset starts beside it), so one sees whether the step changes the
headline and not only training rollouts at the edge.

The last line is machine-readable: ``flips=F of N median_dp2_um=D verdict=PASS|FAIL``, PASS when
at least 97 % of the outcomes agree. A step that fails is still allowed in a config (a user's
choice); docs/simulation.md records what the study's step gives.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from pih.config import from_mapping, to_mapping
from pih.planning.config import ONE_LEVEL, PlannerConfig
from pih.planning.planner import Planner, RolloutWorkers
from pih.planning.run_record import RecordedRun, recorded_rollout, succeeded
from pih.scene.config import SceneConfig
from pih.study.config import load_config
from pih.study.pooling import REDEPLOY_PATTERNS

SET_PATH = Path(__file__).with_name("step_convergence_set.parquet")
SET_SIZE = 240
AGREEMENT = 0.97
COLUMNS = [
    "run",
    "method",
    "iteration",
    "rollout",
    *(f"{p}_{c}" for p in ("start", "target", "sensed_hole") for c in ("x_m", "y_m", "theta_rad")),
    "weights",
]


def method_of(run: RecordedRun) -> str:
    goal = run.planner.goal
    return "one_level" if goal == ONE_LEVEL else goal


def draw_set(paths: list[Path], size: int = SET_SIZE) -> pd.DataFrame:
    """The recipe of the module docstring: late training rollouts, an equal share per method."""
    pools: dict[str, list[pd.DataFrame]] = {}
    planner_config: PlannerConfig | None = None
    for path in sorted(paths):
        run = RecordedRun.read(path)
        rows = run.rollouts[run.rollouts["phase"] == "train"]
        late = rows[rows["iteration"] > rows["iteration"].max() / 2].copy()
        late["run"] = path.parent.name
        late["method"] = method_of(run)
        pools.setdefault(late["method"].iloc[0], []).append(late)
        planner_config = planner_config or run.planner
    rng = np.random.default_rng(0)
    share = -(-size // len(pools))
    picked = []
    for method in sorted(pools):
        pool = pd.concat(pools[method]).sort_values(["run", "iteration", "rollout"])
        chosen = np.sort(rng.choice(len(pool), size=min(share, len(pool)), replace=False))
        picked.append(pool.iloc[chosen][COLUMNS])
    drawn = pd.concat(picked, ignore_index=True)
    assert planner_config is not None
    drawn.attrs["planner"] = to_mapping(planner_config)
    return drawn


def deployment_trials(paths: list[Path]) -> tuple[pd.DataFrame, PlannerConfig]:
    """Each run's deployment trials: from the training start (``rollouts.parquet``) and from its
    redeployed offset starts (``redeploy_start_std_m~*.parquet``), ``source`` naming which."""
    trials = []
    planner_config: PlannerConfig | None = None
    for path in sorted(paths):
        run, run_dir = RecordedRun.read(path), path.parent
        sources = [("training start", run.rollouts)]
        for redeployed in sorted(run_dir.glob(REDEPLOY_PATTERNS[0])):
            sources.append((redeployed.stem.removeprefix("redeploy_"), pd.read_parquet(redeployed)))
        for source, rows in sources:
            deployed = rows[rows["phase"] == "deploy"]
            trials.append(
                deployed.assign(run=run_dir.name, method=method_of(run), source=source)[
                    [*COLUMNS, "source"]
                ]
            )
        planner_config = planner_config or run.planner
    assert planner_config is not None
    return pd.concat(trials, ignore_index=True), planner_config


def write_set(drawn: pd.DataFrame, path: Path) -> None:
    table = pa.Table.from_pandas(drawn, preserve_index=False)
    meta = {**(table.schema.metadata or {}), b"planner": json.dumps(drawn.attrs["planner"])}
    pq.write_table(table.replace_schema_metadata(meta), path)


def read_set(path: Path) -> tuple[pd.DataFrame, PlannerConfig]:
    meta = pq.read_schema(path).metadata
    planner = from_mapping(PlannerConfig, json.loads(meta[b"planner"]), "planner")
    return pd.read_parquet(path), planner


def replay_all(
    rows: pd.DataFrame, scene: SceneConfig, planner_config: PlannerConfig, workers: int
) -> np.ndarray:
    """Per row: (inserted as the ``success`` column defines it, final P2 x, final P2 y)."""
    planner = Planner.from_configs(scene, planner_config)
    rollouts = [recorded_rollout(row) for _, row in rows.iterrows()]
    with RolloutWorkers(planner, workers) as pool:
        traces = [trace for trace, _ in pool.evaluate(rollouts)]
    tolerance = planner_config.success_tolerance_m
    holes = [
        planner.scene.hole_pose if r.simulated_hole is None else r.simulated_hole for r in rollouts
    ]
    return np.array(
        [
            (succeeded(t, hole, tolerance), *t.q_peg_bottom[-1][:2])
            for t, hole in zip(traces, holes, strict=True)
        ],
        dtype=float,
    )


def main() -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--configfile", nargs="+", default=["config/config.yaml"])
    parser.add_argument("--time-step-s", type=float, help="the step h to check (default: config's)")
    parser.add_argument("--workers", type=int, default=2)
    group = parser.add_mutually_exclusive_group()
    group.add_argument("--draw-from", nargs="+", type=Path, metavar="ROLLOUTS")
    group.add_argument(
        "--deployments", nargs="+", type=Path, metavar="ROLLOUTS", help="replay these instead"
    )
    parser.add_argument(
        "--output", type=Path, help="Parquet of every rollout's outcome at h and h/2"
    )
    args = parser.parse_args()

    if args.draw_from:
        drawn = draw_set(args.draw_from)
        write_set(drawn, SET_PATH)
        print(f"{SET_PATH}: {len(drawn)} rollouts ({drawn['method'].value_counts().to_dict()})")
    rows, planner = deployment_trials(args.deployments) if args.deployments else read_set(SET_PATH)
    config = load_config(args.configfile)
    scene = from_mapping(SceneConfig, config["scene"], "scene")
    step = args.time_step_s or scene.solver.time_step_s
    coarse = scene.replace(solver__time_step_s=step, solver__retry_time_step_s=step / 2)
    fine = scene.replace(solver__time_step_s=step / 2, solver__retry_time_step_s=step / 4)
    seconds = {}
    outcomes = {}
    for name, setting in (("h", coarse), ("h/2", fine)):
        started = time.perf_counter()
        outcomes[name] = replay_all(rows, setting, planner, args.workers)
        seconds[name] = time.perf_counter() - started
    inserted_h, inserted_half = outcomes["h"][:, 0] > 0, outcomes["h/2"][:, 0] > 0
    flips = inserted_h != inserted_half
    dp2_um = 1e6 * np.hypot(*(outcomes["h"][:, 1:] - outcomes["h/2"][:, 1:]).T)
    n = len(rows)
    print(
        f"{n} recorded rollouts at h = {1e3 * step:g} ms and h/2 ({seconds['h']:.0f} s and "
        f"{seconds['h/2']:.0f} s with {args.workers} workers)"
    )
    for name, group in rows.groupby([c for c in ("method", "source") if c in rows]):
        idx = group.index.to_numpy()
        print(
            f"  {', '.join(name)}: {flips[idx].sum()} of {len(idx)} flip; inserted "
            f"{inserted_h[idx].sum()} at h, {inserted_half[idx].sum()} at h/2"
        )
    if args.output:
        keys = [c for c in ("run", "method", "source", "iteration", "rollout") if c in rows]
        per_rollout = rows[keys].assign(
            inserted_h=inserted_h,
            inserted_half=inserted_half,
            **{
                f"p2_{c}_m_{n}": outcomes[k][:, i + 1]
                for i, c in enumerate("xy")
                for k, n in (("h", "h"), ("h/2", "half"))
            },
        )
        per_rollout.to_parquet(args.output)
    toward = int((flips & inserted_h).sum())
    print(f"  of the flips, {toward} insert at h only and {int(flips.sum()) - toward} at h/2 only")
    verdict = "PASS" if 1 - flips.mean() >= AGREEMENT else "FAIL"
    print(
        f"flips={int(flips.sum())} of {n} median_dp2_um={np.median(dp2_um):.3g} verdict={verdict}"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
