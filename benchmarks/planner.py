"""Benchmark: a planning run at the study's step against the 2 ms baseline.

Runs Algorithm 1 (paper Table 4's budget per iteration: 10 rollouts) for a few iterations twice,
each in a fresh process, on the same sweep point, and prints wall-clock figures and their ratio:

- baseline: the setting before the step-convergence work: 2 ms step (retry 1 ms), Drake's sampled
  output ports on, glibc's malloc;
- converged: the study's scene (``--configfile``, default config/config.yaml: its step and port
  setting) with the allocator the workflow preloads (tcmalloc or jemalloc when installed).

The default point (our rule, start −31 mm, seed 4) presses into the hole from iteration ≈ 5 on,
so the runs are contact-rich like a study's late iterations. The last line is machine-readable:
``converged_vs_2ms_baseline=R step_ms=S`` with R = baseline seconds ÷ converged seconds (goal
R ≥ 1: converged physics at no more than the old cost).

    python benchmarks/planner.py [--iterations 10] [--method bilevel] [--rule deepest_explored]
                                 [--start-x-m -0.031] [--seed 4] [--configfile config/config.yaml]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time

from pih.config import from_mapping, to_mapping
from pih.planning.config import OuterConfig, PlannerConfig, replace
from pih.planning.planner import Planner
from pih.scene.config import SceneConfig
from pih.study.config import load_config
from pih.workflow.jobs import preloaded_allocator


def one_run(spec: dict) -> None:
    """In a child process: the run, then one JSON line of its figures."""
    scene = from_mapping(SceneConfig, spec["scene"], "scene")
    config = replace(
        PlannerConfig(),
        iterations=spec["iterations"],
        method=spec["method"],
        seed=spec["seed"],
        start_x_m=spec["start_x_m"],
        outer=OuterConfig(rule=spec["rule"]),
    )
    started = time.perf_counter()
    record = Planner.from_configs(scene, config).run()
    rows = record.rollouts
    print(
        json.dumps(
            {
                "seconds": time.perf_counter() - started,
                "rollouts": len(rows),
                "diverged": int((rows["status"] != "ok").sum()),
                "retried": int((rows["time_step_s"] != scene.solver.time_step_s).sum()),
                "inserted": int(rows["success"].sum()),
            }
        )
    )


def timed(spec: dict, preload: str) -> dict:
    env = {**os.environ, "LD_PRELOAD": preload, "OMP_NUM_THREADS": "1"}
    out = subprocess.run(
        [sys.executable, __file__, "--child", json.dumps(spec)],
        env=env,
        capture_output=True,
        text=True,
        check=True,
    )
    return json.loads(out.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--iterations", type=int, default=10)
    parser.add_argument("--method", default="bilevel", choices=["one_level", "bilevel"])
    parser.add_argument(
        "--rule", default="deepest_explored", choices=["explored_argmin", "deepest_explored"]
    )
    parser.add_argument("--start-x-m", type=float, default=-0.031)
    parser.add_argument("--seed", type=int, default=4)
    parser.add_argument("--configfile", nargs="+", default=["config/config.yaml"])
    parser.add_argument("--child", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        one_run(json.loads(args.child))
        return

    scene = from_mapping(SceneConfig, load_config(args.configfile)["scene"], "scene")
    baseline = scene.replace(
        solver__time_step_s=2e-3, solver__retry_time_step_s=1e-3, solver__sampled_output_ports=True
    )
    run = {k: getattr(args, k) for k in ("iterations", "method", "rule", "start_x_m", "seed")}
    allocator = preloaded_allocator()
    results = {}
    for name, setting, preload in (
        ("baseline", baseline, ""),
        ("converged", scene, allocator),
    ):
        results[name] = figures = timed({**run, "scene": to_mapping(setting)}, preload)
        step_ms = 1e3 * setting.solver.time_step_s
        print(
            f"{name}: {step_ms:g} ms step, sampled ports {setting.solver.sampled_output_ports}, "
            f"malloc {os.path.basename(preload) or 'glibc'}: {figures['seconds']:.1f} s for "
            f"{args.iterations} iterations ({1e3 * figures['seconds'] / figures['rollouts']:.0f} "
            f"ms per rollout incl. DMP and costs); {figures['inserted']} of {figures['rollouts']} "
            f"rollouts inserted, {figures['diverged']} diverged, {figures['retried']} retried",
            flush=True,
        )
    ratio = results["baseline"]["seconds"] / results["converged"]["seconds"]
    print(f"converged_vs_2ms_baseline={ratio:.2f} step_ms={1e3 * scene.solver.time_step_s:g}")


if __name__ == "__main__":
    main()
