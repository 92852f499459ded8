"""Benchmark: milliseconds per planning-scale rollout.

The rollout: the peg starts 35 mm beside the hole with its tip 5 mm above the top surface, moves
across for 2 s and down into the hole, 3.5 s simulated in all. Timed over several runs in one
process with one reused diagram (the planner's path) at the study's step, at the former 2 ms
step, and through a naive path (a fresh diagram per rollout, same step, no retry) for comparison. The
last two lines are machine-readable: the planner's path (reused diagram, no per-step patch
count) against the naive one, and the study's step against the former 2 ms (both in this
process, so with the same allocator: `LD_PRELOAD` as the workflow sets it, or not).

    python benchmarks/rollout.py [--runs 15] [--naive-runs 3]
"""

from __future__ import annotations

import argparse
import statistics
import time

import numpy as np

from pih.records.provenance import allocator
from pih.scene.config import SceneConfig
from pih.scene.simulation import PegInHoleScene
from pih.scene.trace import RobotTrajectory


def planning_rollout(scene: PegInHoleScene, duration_s: float = 3.5) -> RobotTrajectory:
    t = np.arange(0.0, duration_s + 1e-9, scene.config.solver.time_step_s)
    hole = scene.config.hole
    start = scene.peg_top_from_bottom([hole.x_m - 0.035, hole.top_y_m + 0.005, 0.0])
    goal = scene.peg_top_from_bottom([hole.x_m, hole.y_m + 0.001, 0.0])
    across = np.clip(t / 2.0, 0, 1)
    down = np.clip((t - 1.8) / 1.5, 0, 1)
    smooth = lambda s: 3 * s**2 - 2 * s**3
    poses = np.column_stack(
        [
            start[0] + (goal[0] - start[0]) * smooth(across),
            start[1] + (goal[1] - start[1]) * smooth(down),
            np.zeros_like(t),
        ]
    )
    return RobotTrajectory(t, poses)


def time_rollouts(make_scene, runs: int) -> tuple[list[float], str]:
    times, status = [], ""
    for _ in range(runs):
        start = time.perf_counter()
        scene = make_scene()
        trace = scene.rollout(planning_rollout(scene))
        times.append(1000.0 * (time.perf_counter() - start))
        status = f"{trace.status}, final depth {1000 * trace.insertion_depth_m[-1]:.2f} mm"
    return times, status


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--runs", type=int, default=15)
    parser.add_argument("--naive-runs", type=int, default=3)
    args = parser.parse_args()

    config = SceneConfig()
    scene = PegInHoleScene(config)
    scene.rollout(planning_rollout(scene))  # warm-up
    reused, status = time_rollouts(lambda: scene, args.runs)
    print(
        f"reused diagram, {config.solver.time_step_s * 1e3:g} ms step: median {statistics.median(reused):.0f} ms "
        f"per rollout (min {min(reused):.0f}, max {max(reused):.0f}, n = {args.runs}); {status}"
    )
    no_patches = PegInHoleScene(config.replace(solver__log_contact_patches=False))
    lean, _ = time_rollouts(lambda: no_patches, args.runs)
    print(f"  without the per-step contact-patch count: median {statistics.median(lean):.0f} ms")
    naive_config = config.replace(solver__retry_time_step_s=0.0)
    naive, status = time_rollouts(lambda: PegInHoleScene(naive_config), args.naive_runs)
    ratio = statistics.median(naive) / statistics.median(reused)
    print(
        f"naive (fresh diagram per rollout, same step): median {statistics.median(naive):.0f} ms "
        f"per rollout; {ratio:.1f}x slower; {status}"
    )
    lean_ratio = statistics.median(naive) / statistics.median(lean)
    print(f"speedup_vs_naive={lean_ratio:.1f} median_ms={statistics.median(lean):.0f}")
    two_ms = PegInHoleScene(
        config.replace(
            solver__time_step_s=2e-3,
            solver__retry_time_step_s=1e-3,
            solver__log_contact_patches=False,
        )
    )
    baseline, _ = time_rollouts(lambda: two_ms, args.runs)
    ratio = statistics.median(baseline) / statistics.median(lean)
    print(
        f"converged_vs_2ms_baseline={ratio:.2f} step_ms={config.solver.time_step_s * 1e3:g} "
        f"(allocator {allocator()})"
    )


if __name__ == "__main__":
    main()
