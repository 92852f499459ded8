"""Benchmark: scene settings (solver, modulus, margin, fillet, step) on the planner's rollouts.

Records the robot trajectories of short planning runs of the config's planner on its scene
(bilevel with our outer rule, so later iterations reach the hole: the trajectories cover free
flight, landing on the top surface and the chamfer, and pressing into the hole), then replays every trajectory
under each scene variant in one process and prints, per variant: ms per rollout, the fraction
with an interval rerun at the retry step, the fraction that still diverged (and why), and how
the outcome compares with the first variant's: the median distance between the two P2 at the
end and how many rollouts end on the other side of the insertion test (|P2 − H| ≤ 1 mm).

The config files are read as the workflow reads them (``--configfile``: the default config, then
yours). The variants are the named dotted-path scene settings of ``validation.variants`` (the
validation's by default; a file of your own with that section replaces them), applied to the
study's planner scene (not the validation's deeper hole).

    python benchmarks/solvers.py [--iterations 10] [--start-x-m -0.031 -0.037] [--seed 4 1]
                                 [--configfile config/config.yaml my_variants.yaml]
                                 [--variants hydroelastic similar sap ...]
"""

from __future__ import annotations

import argparse
import time
from collections import Counter

import numpy as np

from pih.config import ConfigError
from pih.planning.config import PlannerConfig, replace
from pih.planning.planner import Planner
from pih.scene.config import SceneConfig
from pih.scene.overrides import scene_with
from pih.scene.simulation import PegInHoleScene
from pih.scene.trace import RobotTrajectory, Trace
from pih.study.config import load_config, resolve


def study_configs(
    configfiles: list[str],
) -> tuple[SceneConfig, PlannerConfig, dict[str, SceneConfig]]:
    """The study's scene and planner, and each named variant's scene, from the config files as
    the workflow reads them (a later file's fields override an earlier one's; its
    ``validation.variants`` replace the earlier ones whole)."""
    config = load_config(configfiles)
    scene, planner = resolve(config)
    variants = config["validation"]["variants"]
    return (
        scene,
        planner,
        {
            name: scene_with(config["scene"], overrides, f"validation.variants.{name}")
            for name, overrides in variants.items()
        },
    )


def planning_trajectories(
    scene: SceneConfig,
    planner_config: PlannerConfig,
    iterations: int,
    starts: list[float],
    seeds: list[int],
) -> list[RobotTrajectory]:
    """Every robot trajectory (training, mean and deployment) of short planning runs of the
    config's planner with our outer rule."""
    captured: list[RobotTrajectory] = []
    for start_x_m, seed in zip(starts, seeds, strict=True):
        config = replace(
            planner_config,
            iterations=iterations,
            goal="deepest_explored",
            seed=seed,
            start_x_m=start_x_m,
        )
        planner = Planner.from_configs(scene, config)
        rollout = planner.scene.rollout

        def capturing(robot: RobotTrajectory, rollout=rollout) -> Trace:
            captured.append(robot)
            return rollout(robot)

        planner.scene.rollout = capturing
        planner.run()
    return captured


def replay(scene: PegInHoleScene, robots: list[RobotTrajectory]) -> tuple[list[Trace], float]:
    started = time.perf_counter()
    traces = [scene.rollout(robot) for robot in robots]
    return traces, (time.perf_counter() - started) / len(robots)


def final_tip(trace: Trace) -> np.ndarray:
    """P2 (x, y) at the end; NaN if the rollout diverged."""
    return trace.q_peg_bottom[-1, :2] if trace.ok else np.full(2, np.nan)


def main() -> None:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--iterations", type=int, default=10)
    parser.add_argument("--start-x-m", type=float, nargs="+", default=[-0.031, -0.037])
    parser.add_argument("--seed", type=int, nargs="+", default=[4, 1])
    parser.add_argument("--configfile", nargs="+", default=["config/config.yaml"])
    parser.add_argument("--variants", nargs="+", help="names under validation.variants (all)")
    args = parser.parse_args()
    try:
        study_scene, planner_config, variants = study_configs(args.configfile)
    except ConfigError as error:
        parser.error(str(error))
    names = args.variants or list(variants)
    unknown = [name for name in names if name not in variants]
    if unknown:
        parser.error(
            f"--variants: {unknown} are not under validation.variants ({sorted(variants)})"
        )

    robots = planning_trajectories(
        study_scene, planner_config, args.iterations, args.start_x_m, args.seed
    )
    print(f"{len(robots)} planning trajectories ({args.iterations} iterations per run)")
    tolerance = planner_config.success_tolerance_m
    reference: np.ndarray | None = None
    for name in names:
        config = variants[name].replace(solver__log_contact_patches=False)
        scene = PegInHoleScene(config)
        traces, seconds = replay(scene, robots)
        tips = np.array([final_tip(t) for t in traces])
        if reference is None:
            reference = tips
        both = np.isfinite(tips[:, 0]) & np.isfinite(reference[:, 0])
        errors = np.hypot(*(tips - scene.hole_pose[:2]).T)
        ref_errors = np.hypot(*(reference - scene.hole_pose[:2]).T)
        rerun = sum(t.time_step_s != config.solver.time_step_s for t in traces)
        diverged = [t.reason.split(" at t")[0][:60] for t in traces if not t.ok]
        flipped = int(np.sum((errors[both] <= tolerance) != (ref_errors[both] <= tolerance)))
        moved = np.hypot(*(tips[both] - reference[both]).T)
        print(
            f"{name}: {1000 * seconds:.0f} ms per rollout; rerun {rerun}/{len(traces)}; "
            f"diverged {len(diverged)}/{len(traces)} {dict(Counter(diverged).most_common(3))}; "
            f"inserted {int(np.sum(errors <= tolerance))}; vs {names[0]}: median |ΔP2| "
            f"{1000 * np.median(moved):.3f} mm (90th percentile {1000 * np.percentile(moved, 90):.2f}), "
            f"{flipped} of {int(both.sum())} on the other side of the 1 mm test",
            flush=True,
        )


if __name__ == "__main__":
    main()
