"""Benchmark: seconds per planning iteration and per full run.

Runs Algorithm 1 with the default configuration (paper Table 4: 50 iterations × 10 rollouts,
start x_P = −0.035 m) in one process and prints wall-clock figures.

    python benchmarks/planner.py [--iterations 50] [--method bilevel] [--rule explored_argmin]
                                 [--start-x-m -0.035] [--seed 0] [--workers 1]
"""

from __future__ import annotations

import argparse
import time

from pih.planner import OuterConfig, Planner, PlannerConfig, replace
from pih.scene_config import SceneConfig


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--iterations", type=int, default=PlannerConfig().iterations)
    parser.add_argument("--method", default="bilevel", choices=["one_level", "bilevel"])
    parser.add_argument(
        "--rule", default="explored_argmin", choices=["explored_argmin", "deepest_explored"]
    )
    parser.add_argument("--start-x-m", type=float, default=PlannerConfig().start_x_m)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--workers", type=int, default=1, help="processes for the rollouts")
    args = parser.parse_args()

    config = replace(
        PlannerConfig(),
        iterations=args.iterations,
        method=args.method,
        seed=args.seed,
        start_x_m=args.start_x_m,
        outer=OuterConfig(rule=args.rule),
    )
    started = time.perf_counter()
    planner = Planner.from_configs(SceneConfig(), config)
    setup = time.perf_counter() - started
    record = planner.run(workers=args.workers)
    rollouts = len(record.rollouts)
    config_step = SceneConfig().solver.time_step_s
    print(
        f"{args.method}, {args.iterations} iterations x {config.optimizer.population_size} rollouts, "
        f"{args.workers} worker(s): "
        f"{record.seconds:.1f} s per run ({record.seconds / args.iterations:.2f} s per iteration, "
        f"{1000 * record.rollout_seconds / rollouts:.0f} ms per rollout incl. DMP and costs; "
        f"setup {1000 * setup:.0f} ms); success iteration {record.success_iteration}; "
        f"{(record.rollouts['status'] != 'ok').sum()} of {rollouts} rollouts diverged, "
        f"{(record.rollouts['time_step_s'] != config_step).sum()} had an interval rerun at "
        "the retry step; "
        f"deployment success {record.deploy_success_rate:.0%}"
    )


if __name__ == "__main__":
    main()
