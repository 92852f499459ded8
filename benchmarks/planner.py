"""Benchmark: a planning run at a candidate setting against today's 0.5 ms lagged SAP setting.

Runs Algorithm 1 (paper Table 4's budget per iteration: 10 rollouts) for a few iterations at two
settings, each run in a fresh process, on the same sweep point, alternating A B A B for
``--repeats`` rounds, and prints wall-clock figures and their ratio:

- baseline: the study's setting before the speed work: Drake's discrete `lagged` SAP at a 0.5 ms
  step (retry 0.25 ms), sampled output ports, the scene of ``--configfile`` otherwise;
- candidate: the scene of ``--configfile`` (default config/config.yaml) with ``--set
  scene.KEY=VALUE`` overrides, i.e. a lever to measure; or with ``--set
  planner.simulator.KEY=VALUE`` the planner's own simulator, which changes only the training
  rollouts (e.g. ``planner.simulator.contact_model=point``: trained in point contact, deployed on
  the scene).

Both run with the allocator the workflow preloads (tcmalloc or jemalloc when installed) and the
same Drake. The default point (our rule, start −31 mm, seed 4) presses into the hole from
iteration ≈ 5 on, so the runs are contact-rich like a study's late iterations. The last line is
machine-readable: ``speedup_vs_sap_0p5ms=R verdict=PASS|FAIL``, R = baseline seconds ÷
candidate seconds (summed over the rounds), PASS when R ≥ 2 (issue 44's goal). A setting that is
faster must also pass the step check (benchmarks/step_convergence.py) to become the study's.

    python benchmarks/planner.py [--set scene.solver.time_step_s=0.001] [--iterations 10]
                                 [--set planner.simulator.contact_model=point]
                                 [--goal deepest_explored] [--start-x-m -0.031] [--seed 4]
                                 [--repeats 1] [--configfile config/config.yaml]
"""

from __future__ import annotations

import argparse
import copy
import json
import os
import subprocess
import sys
import time

import yaml

from pih.config import ConfigError, from_mapping, set_paths, to_mapping
from pih.planning.config import PlannerConfig, replace
from pih.planning.planner import Planner
from pih.scene.config import SceneConfig
from pih.scene.overrides import scene_settings, scene_with
from pih.study.config import load_config
from pih.workflow.jobs import preloaded_allocator

GOAL_SPEEDUP = 2.0


def one_run(spec: dict) -> None:
    """In a child process: the run, then one JSON line of its figures."""
    scene = from_mapping(SceneConfig, spec["scene"], "scene")
    config = replace(
        from_mapping(PlannerConfig, spec["planner"], "planner"),
        iterations=spec["iterations"],
        goal=spec["goal"],
        seed=spec["seed"],
        start_x_m=spec["start_x_m"],
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
                "deployed": record.deploy_success_rate,
            }
        )
    )


def planner_with(planner: dict, settings: list[str]) -> dict:
    """The planner section with ``planner.simulator.KEY=VALUE`` settings (values read as YAML,
    never evaluated), validated."""
    changed = copy.deepcopy(planner)
    for setting in settings:
        key, sep, value = setting.partition("=")
        if not sep:
            raise ConfigError(f"--set {setting!r}: expected planner.simulator.<key>=<value>")
        set_paths(changed, {key.removeprefix("planner."): yaml.safe_load(value)}, "--set planner.")
    from_mapping(PlannerConfig, changed, "--set planner")
    return changed


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


def main() -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument(
        "--set", action="append", default=[], metavar="scene.KEY=VALUE|planner.simulator.KEY=VALUE"
    )
    parser.add_argument("--iterations", type=int, default=10)
    parser.add_argument(
        "--goal",
        default="deepest_explored",
        choices=["sensed_hole", "explored_argmin", "deepest_explored"],
    )
    parser.add_argument("--start-x-m", type=float, default=-0.031)
    parser.add_argument("--seed", type=int, default=4)
    parser.add_argument("--repeats", type=int, default=1)
    parser.add_argument("--configfile", nargs="+", default=["config/config.yaml"])
    parser.add_argument("--child", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        one_run(json.loads(args.child))
        return 0

    simulator = [s for s in args.set if s.startswith("planner.simulator.")]
    try:
        config = load_config(args.configfile)
        scene = config["scene"]
        scene_sets = [s for s in args.set if s not in simulator]
        candidate = scene_with(scene, scene_settings(scene_sets), "--set scene")
        candidate_planner = planner_with(config["planner"], simulator)
        baseline = scene_with(
            scene,
            {
                "solver.time_step_s": 5e-4,
                "solver.retry_time_step_s": 2.5e-4,
                "solver.discrete_contact_approximation": "lagged",
                "solver.sampled_output_ports": True,
            },
            "baseline",
        )
    except ConfigError as error:
        print(f"benchmarks/planner.py: {error}", file=sys.stderr)
        return 1
    run = {k: getattr(args, k) for k in ("iterations", "goal", "start_x_m", "seed")}
    planners = {"baseline": config["planner"], "candidate": candidate_planner}
    allocator = preloaded_allocator()
    seconds = {"baseline": 0.0, "candidate": 0.0}
    for _ in range(args.repeats):
        for name, setting in (("baseline", baseline), ("candidate", candidate)):
            spec = {**run, "scene": to_mapping(setting), "planner": planners[name]}
            figures = timed(spec, allocator)
            seconds[name] += figures["seconds"]
            solver = setting.solver
            overrides = f" with {' '.join(args.set)}" if name == "candidate" and args.set else ""
            print(
                f"{name}: {solver.discrete_contact_approximation} {1e3 * solver.time_step_s:g} ms"
                f"{overrides}, "
                f"malloc {os.path.basename(allocator) or 'glibc'}: {figures['seconds']:.1f} s for "
                f"{args.iterations} iterations ({1e3 * figures['seconds'] / figures['rollouts']:.0f}"
                f" ms per rollout incl. DMP and costs); {figures['inserted']} of "
                f"{figures['rollouts']} rollouts inserted, {figures['diverged']} diverged, "
                f"{figures['retried']} retried; deployed {figures['deployed']:.0%} on the scene",
                flush=True,
            )
    ratio = seconds["baseline"] / seconds["candidate"]
    verdict = "PASS" if ratio >= GOAL_SPEEDUP else "FAIL"
    print(f"speedup_vs_sap_0p5ms={ratio:.2f} verdict={verdict}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
