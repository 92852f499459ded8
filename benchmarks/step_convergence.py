"""The step check: does a simulator setting decide insertion outcomes as a fine-step reference does?

Every number the study reports is an insertion outcome decided at the chamfer, where a tilted
peg either slides in or jams, and a step that is too coarse decides some of those differently.
Jam-or-slide settles only below 0.125 ms and not monotonically (docs/simulation.md), so a setting
is judged against a **fine-step reference**, not against its own half step.

The reference (committed; regenerate it whenever the physics it stands for changes: Drake, the
scene, the rollout code):

- ``step_reference_set.parquet`` (``--make-reference``): the step set (below) replayed at
  0.0625 ms, and at 0.5, 0.25 and 0.125 ms; every rollout whose outcome differs among those four
  steps is replayed once more at 0.03125 ms, and ``confirmed`` says whether it ends there as at
  0.0625 ms.
- the deployment trials the headline counts: every run of the published paper-scale study, its
  deployed policy from the training start and from starts 1 mm off (660 trials), replayed at
  0.0625 ms beside the run (``replay_time_step_s~6.25e-05.parquet``, made by
  ``pih publish --study paper --replay-step``).

A setting (the config's scene with ``--set scene.KEY=VALUE`` overrides) PASSES when at least
97 % of the set's insertion outcomes agree with the reference **and** the deployment trials,
replayed at the setting, give every point's paired sign (each rule against one-level, per start
source) that the reference gives. The last line is machine-readable:
``flips=F of N vs_reference_ms=0.0625 median_dp2_um=D verdict=PASS|FAIL``; every rollout's
outcome and final P2 at the setting, beside the reference's, goes to ``--output`` (default
``step_check.parquet``) with the verdict, the setting, the code and the CPU in its provenance,
so a verdict can be examined afterwards.
``--half-step`` prints the former check (h against h/2, 97 %) as a diagnostic instead.
``--replay FILE`` writes the set's replay at a setting (with the CPU and BLAS kernel in its
provenance) and ``--against FILE`` replays the set here and compares it with such a file: how far
outcomes and P2 move when only the machine does (docs/reproducibility.md).

The step runs: the published paper-scale study's 12 runs at starts −40, −38, −34 and −30 mm
(seed 0; the default study until 2026-12-05), :func:`step_runs`. The set
(``step_convergence_set.parquet``, committed) and its recipe: from every given run's
training rollouts (``phase == 'train'``) in the later half of its iterations (contact-rich: by
then most rollouts reach the chamfer or the hole), an equal number per method (one-level, the
paper's rule, ours), drawn without replacement by ``numpy.random.default_rng(0)`` after sorting
by (run, iteration, rollout); 240 in all (80 per method). ``--draw-from RUN ...`` redraws it.

    python benchmarks/step_convergence.py [--set scene.solver.time_step_s=0.00025] [--workers 2]
                                          [--output step_check.parquet] [--rollouts N]
    python benchmarks/step_convergence.py --half-step [--set ...]
    python benchmarks/step_convergence.py --make-reference [--workers 2]
    python benchmarks/step_convergence.py --replay default.parquet
    OPENBLAS_CORETYPE=Sandybridge python benchmarks/step_convergence.py --against default.parquet
    python benchmarks/step_convergence.py --draw-from \
        published/paper/planning/start_x_m~-0.0{4,38,34,3}_goal~*_seed~0/rollouts.parquet
"""

from __future__ import annotations

import argparse
import json
import shlex
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pyarrow as pa
import pyarrow.parquet as pq

from pih.config import ConfigError, from_mapping, to_mapping
from pih.planning.config import ONE_LEVEL, PlannerConfig, recorded_planner
from pih.planning.run_record import RecordedRun
from pih.publishing.equivalence import current_hashes
from pih.publishing.published import PUBLISHED_STUDIES
from pih.publishing.reference_step import REFERENCE_STEP_S
from pih.records.outputs import read_provenance, write_table
from pih.records.provenance import package_versions, record
from pih.scene.config import SceneConfig
from pih.scene.overrides import scene_settings, scene_with
from pih.study.config import load_config
from pih.study.replay import at_step, replay_rows
from pih.study.replay_record import KEYS, deployment_trials, replay_name

HERE = Path(__file__).parent
SET_PATH = HERE / "step_convergence_set.parquet"
REFERENCE_PATHS = {"set": HERE / "step_reference_set.parquet"}
PAPER_DIR = PUBLISHED_STUDIES["paper"].directory
STEP_STARTS = ("-0.04", "-0.038", "-0.034", "-0.03")
SET_SIZE = 240
AGREEMENT = 0.97
CONFIRM_STEP_S = 3.125e-5
COARSER_STEPS_S = (5.0e-4, 2.5e-4, 1.25e-4)
POSES = ("start", "target", "sensed_hole")
COLUMNS = [
    "run",
    "method",
    "iteration",
    "rollout",
    *(f"{p}_{c}" for p in POSES for c in ("x_m", "y_m", "theta_rad")),
    "weights",
]
UNITS = {
    "run": ("1", "the planning run (its results directory) the rollout was recorded in"),
    "method": ("1", "the run's planner.goal (one_level: the sensed hole)"),
    "point": ("1", "the run's sweep point without its method: the runs paired at one point"),
    "source": ("1", "deployment trials: from the training start or from offset starts"),
    "iteration": ("1", "the iteration that recorded the rollout"),
    "rollout": ("1", "the rollout's index in its iteration"),
    **{
        f"{p}_{c}": (
            unit,
            f"the recorded {p.replace('_', ' ')}, {c[0] if c != 'theta_rad' else 'θ'}",
        )
        for p in POSES
        for c, unit in (("x_m", "m"), ("y_m", "m"), ("theta_rad", "rad"))
    },
    "weights": ("1", "the rollout's DMP weights W"),
    "inserted": ("1", "insertion outcome at the reference step (|P2 − H| ≤ tolerance, ok)"),
    "p2_x_m": ("m", "final P2 x at the reference step"),
    "p2_y_m": ("m", "final P2 y at the reference step"),
    "varies": ("1", "the outcome differs among the coarser steps and the reference"),
    "confirmed": ("1", "varying rollouts: the outcome at 0.03125 ms equals the reference's"),
}


def step_runs(root: Path = Path()) -> list[Path]:
    """The runs the step check stands on (module docstring): each run's ``rollouts.parquet``."""
    planning = root / PAPER_DIR / "planning"
    return sorted(
        path
        for start in STEP_STARTS
        for path in planning.glob(f"start_x_m~{start}_goal~*_seed~0/rollouts.parquet")
    )


def coarse_column(step_s: float) -> tuple[str, tuple[str, str]]:
    """The reference set's column of the outcomes at a coarser step, with its unit."""
    return f"inserted_at_{1e6 * step_s:g}us", ("1", f"insertion outcome at {1e3 * step_s:g} ms")


def method_of(run: RecordedRun) -> str:
    goal = run.planner.goal
    return "one_level" if goal == ONE_LEVEL else goal


def point_of(run: RecordedRun) -> str:
    point = {k: v for k, v in run.record["sweep_point"].items() if k != "planner.goal"}
    return ",".join(f"{k}={point[k]}" for k in sorted(point))


def draw_set(paths: list[Path], size: int = SET_SIZE) -> pd.DataFrame:
    """The recipe of the module docstring: late training rollouts, an equal share per method."""
    pools: dict[str, list[pd.DataFrame]] = {}
    planner_config: PlannerConfig | None = None
    for path in sorted(paths):
        run = RecordedRun.read(path)
        if run.planner.simulator.scene_changes or run.planner.simulated_hole != "true_hole":
            # The set replays training rows on the real scene, where these did not run.
            raise SystemExit(f"{path}: trained in a simulator other than the real scene")
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


def deployment_reference(root: Path = Path()) -> pd.DataFrame:
    """The deployment trials the headline counts: each published paper-scale run's deployed
    policy from the training start and from its offset starts, ``source`` naming which and
    ``point`` the runs paired with it, beside their outcome and final P2 at the reference step
    from the run's replay file (``pih publish --study paper --replay-step``). Refused (one line)
    when a run has none, or another Drake replayed it: it then stands for other physics."""
    planning = root / PAPER_DIR / "planning"
    runs = sorted(planning.glob("*/rollouts.parquet"))
    name = replay_name(REFERENCE_STEP_S)
    missing = [path.parent.name for path in runs if not (path.parent / name).is_file()]
    if missing or not runs:
        raise SystemExit(
            f"{planning}: {len(missing)} of {len(runs)} runs have no {name} (e.g. "
            f"{(missing or ['no run'])[0]}); pih publish --study paper --replay-step"
        )
    drake, trials = package_versions()["drake"], []
    for path in runs:
        replay = path.parent / name
        made = read_provenance(replay)
        if made["packages"]["drake"] != drake:
            raise SystemExit(
                f"{replay}: replayed by Drake {made['packages']['drake']}, not {drake}; "
                "pih publish --study paper --replay-step"
            )
        if made["rollout_code_sha256"] not in current_hashes():
            print(f"{replay}: replayed by other rollout code ({made['code_version']})")
        run = RecordedRun.read(path)
        replayed = pd.read_parquet(replay)
        # The sources the replay holds: a redeployment added after it (the ladder's wider
        # starts) is not the headline's.
        rows = deployment_trials(path.parent, run.rollouts)
        rows = rows[rows["source"].isin(set(replayed["source"]))].reset_index(drop=True)
        if not rows[KEYS].equals(replayed[KEYS]):
            raise SystemExit(f"{replay}: not the deployment trials {path.parent.name} holds")
        deployed = (rows["phase"] == "deploy").to_numpy()
        outcome = replayed.loc[deployed, ["inserted", "p2_x_m", "p2_y_m"]].reset_index(drop=True)
        rows = rows[deployed].reset_index(drop=True)
        trials.append(
            pd.concat(
                [
                    rows.assign(run=path.parent.name, method=method_of(run), point=point_of(run))[
                        [*COLUMNS, "point", "source"]
                    ],
                    outcome,
                ],
                axis=1,
            )
        )
    return pd.concat(trials, ignore_index=True)


def write_set(drawn: pd.DataFrame, path: Path) -> None:
    table = pa.Table.from_pandas(drawn, preserve_index=False)
    meta = {**(table.schema.metadata or {}), b"planner": json.dumps(drawn.attrs["planner"])}
    pq.write_table(table.replace_schema_metadata(meta), path)


def read_set(path: Path) -> tuple[pd.DataFrame, PlannerConfig]:
    meta = pq.read_schema(path).metadata
    # Read as a run's record is: keys the set predates at their defaults.
    planner = recorded_planner({"planner": json.loads(meta[b"planner"])})
    return pd.read_parquet(path), planner


def paired_signs(rows: pd.DataFrame, inserted: np.ndarray) -> pd.Series:
    """sign(rule − one-level) of the deployment success rate, per (point, source, rule)."""
    rates = (
        rows.assign(inserted=inserted)
        .groupby(["point", "source", "method"])["inserted"]
        .mean()
        .unstack("method")
    )
    rules = [m for m in rates.columns if m != "one_level"]
    if "one_level" not in rates or rates.isna().any(axis=None):
        raise SystemExit("the deployment trials do not hold every method at every point")
    return np.sign(rates[rules].sub(rates["one_level"], axis=0)).stack().astype(int)


def make_reference(scene: SceneConfig, workers: int, command: str) -> None:
    """Replay the set at the reference step and at the coarser steps, and write it."""
    rows, planner = read_set(SET_PATH)
    started = time.perf_counter()
    reference = replay_rows(rows, at_step(scene, REFERENCE_STEP_S), planner, workers)
    frame = rows.assign(
        inserted=reference[:, 0] > 0, p2_x_m=reference[:, 1], p2_y_m=reference[:, 2]
    )
    outcomes = [frame["inserted"].to_numpy()]
    for step in COARSER_STEPS_S:
        coarse = replay_rows(rows, at_step(scene, step), planner, workers)[:, 0] > 0
        frame[coarse_column(step)[0]] = coarse
        outcomes.append(coarse)
    varies = np.any(np.array(outcomes) != outcomes[0], axis=0)
    confirmed = np.ones(len(rows), dtype=bool)
    if varies.any():
        fine = replay_rows(rows[varies], at_step(scene, CONFIRM_STEP_S), planner, workers)
        confirmed[varies] = (fine[:, 0] > 0) == frame["inserted"].to_numpy()[varies]
    frame = frame.assign(varies=varies, confirmed=confirmed)
    provenance = record(
        "step_reference_set",
        config={
            "scene": to_mapping(at_step(scene, REFERENCE_STEP_S)),
            "planner": to_mapping(planner),
        },
        inputs=[SET_PATH],
        simulator={
            "time_step_s": REFERENCE_STEP_S,
            "retry_time_step_s": REFERENCE_STEP_S / 2,
            "confirm_time_step_s": CONFIRM_STEP_S,
        },
        extra={"command": command, "seconds": round(time.perf_counter() - started)},
    )
    units = {**UNITS, **dict(coarse_column(step) for step in COARSER_STEPS_S)}
    path = REFERENCE_PATHS["set"]
    write_table(frame, path, provenance, units)
    print(f"{path}: {len(frame)} rollouts, {int(frame['inserted'].sum())} insert")
    print(
        f"  {int(varies.sum())} vary among the steps, {int(confirmed[varies].sum())} of them "
        f"end at {1e3 * CONFIRM_STEP_S:g} ms as at {1e3 * REFERENCE_STEP_S:g} ms"
    )


def read_reference() -> tuple[pd.DataFrame, PlannerConfig]:
    """A committed reference and its planner config; refused (one line) when another Drake made
    it, since it then stands for other physics. Rollout code neither today's nor verified
    equivalent to it (:mod:`pih.publishing.equivalence`) is said, not refused: a lever under test
    changes the code, and the reference is what it is judged against."""
    path = REFERENCE_PATHS["set"]
    if not path.is_file():
        raise SystemExit(f"{path}: missing; make it with --make-reference")
    provenance = read_provenance(path)
    drake, made_by = package_versions()["drake"], provenance["packages"]["drake"]
    if made_by != drake:
        raise SystemExit(f"{path}: made by Drake {made_by}, not {drake}; --make-reference")
    if provenance["rollout_code_sha256"] not in current_hashes():
        print(f"{path}: made by other rollout code ({provenance['code_version']})")
    planner = recorded_planner(provenance["config"])
    return pd.read_parquet(path), planner


def overridden(scene: SceneConfig, settings: list[str]) -> SceneConfig:
    """The scene with ``--set scene.KEY=VALUE`` overrides (the retry step follows the step)."""
    return scene_with(to_mapping(scene), scene_settings(settings), "--set scene")


def per_method(rows: pd.DataFrame, flips: np.ndarray, inserted: dict[str, np.ndarray]) -> None:
    for name, group in rows.groupby([c for c in ("method", "source") if c in rows]):
        idx = group.index.to_numpy()
        counts = ", ".join(f"{inserted[k][idx].sum()} at {k}" for k in inserted)
        print(f"  {', '.join(name)}: {flips[idx].sum()} of {len(idx)} flip; inserted {counts}")


def scene_differences(
    setting: dict[str, Any], reference: dict[str, Any], prefix: str = ""
) -> list[str]:
    """``key=value (reference value)`` for every scene key the checked setting changes."""
    differences = []
    for key, value in setting.items():
        was = reference.get(key)
        if isinstance(value, dict):
            differences += scene_differences(value, was or {}, f"{prefix}{key}.")
        elif value != was:
            differences.append(f"{prefix}{key}={value} (reference {was})")
    return differences


def compare_set(replayed: np.ndarray, reference: pd.DataFrame, label: str) -> tuple[int, float]:
    """Print how the set's outcomes at a setting (``replay_rows``'s rows) compare with
    ``reference`` (``inserted``, ``p2_x_m``, ``p2_y_m`` per row); (flips, median |ΔP2| in µm)."""
    inserted, expected = replayed[:, 0] > 0, reference["inserted"].to_numpy()
    flips = inserted != expected
    dp2_um = 1e6 * np.hypot(*(replayed[:, 1:] - reference[["p2_x_m", "p2_y_m"]].to_numpy()).T)
    per_method(reference, flips, {label: inserted, "reference": expected})
    quantiles = np.quantile(dp2_um, [0.5, 0.9, 0.99, 1.0])
    print(
        "  |ΔP2| against the reference (µm): median {:.3g}, 90 % {:.3g}, 99 % {:.3g}, "
        "max {:.3g}; {} of {} bit-identical".format(
            *quantiles, int((dp2_um == 0).sum()), len(dp2_um)
        )
    )
    print(f"  set agreement {1 - flips.mean():.1%}")
    return int(flips.sum()), float(quantiles[0])


def check_against_reference(
    scene: SceneConfig, workers: int, output: Path, command: str, rollouts: int | None = None
) -> str:
    """Replay the set and the deployment trials at ``scene``; the verdict line, and every
    rollout's outcome at the setting beside the reference's written to ``output``
    (:data:`CHECK_COLUMNS`, with the verdict, the setting, the code and the CPU in its
    provenance). ``rollouts``: a quick look at the set's first rollouts and that many deployment
    trials per (point, source, method), whose verdict is PARTIAL, never PASS."""
    reference, planner = read_reference()
    deployments = deployment_reference()
    if rollouts is not None:
        reference = reference.head(rollouts)
        keys = ["point", "source", "method"]
        deployments = deployments.groupby(keys).head(rollouts).reset_index(drop=True)
    made_at = read_provenance(REFERENCE_PATHS["set"])["config"]["scene"]
    print(
        "the setting differs from the reference's scene in: "
        + "; ".join(scene_differences(to_mapping(scene), made_at) or ["nothing"])
    )
    step_ms = 1e3 * scene.solver.time_step_s
    started = time.perf_counter()
    replayed = replay_rows(reference, scene, planner, workers)
    seconds = time.perf_counter() - started
    print(f"{len(reference)} set rollouts at {step_ms:g} ms ({seconds:.0f} s, {workers} workers)")
    flips, median_dp2_um = compare_set(replayed, reference, f"{step_ms:g} ms")
    unsure = reference["varies"] & ~reference["confirmed"]
    print(
        f"  the reference: {int(reference['varies'].sum())} rollouts vary among the coarser "
        f"steps, {int(unsure.sum())} of them end otherwise at {1e3 * CONFIRM_STEP_S:g} ms"
    )

    expected = deployments["inserted"].to_numpy()
    deployed_at = replay_rows(deployments, scene, planner, workers)
    deployed = deployed_at[:, 0] > 0
    reference_signs = paired_signs(deployments, expected)
    signs = paired_signs(deployments, deployed)
    changed = signs[signs != reference_signs]
    print(f"{len(deployments)} deployment trials: {int((deployed != expected).sum())} flip")
    per_method(
        deployments, deployed != expected, {f"{step_ms:g} ms": deployed, "reference": expected}
    )
    for (point, source, rule), sign in changed.items():
        print(
            f"  paired sign changed: {rule} vs one-level at {point}, {source}: "
            f"{reference_signs[point, source, rule]:+d} -> {sign:+d}"
        )
    print(f"  paired signs kept: {len(signs) - len(changed)} of {len(signs)}")
    agree = 1 - flips / len(reference)
    verdict = "PASS" if agree >= AGREEMENT and changed.empty else "FAIL"
    if rollouts is not None:
        verdict = "PARTIAL"
    line = (
        f"flips={flips} of {len(reference)} vs_reference_ms={1e3 * REFERENCE_STEP_S:g} "
        f"median_dp2_um={median_dp2_um:.3g} verdict={verdict}"
    )
    frame = pd.concat(
        [
            check_rows("set", reference, replayed),
            check_rows("deployments", deployments, deployed_at),
        ],
        ignore_index=True,
    )
    provenance = record(
        "step_check",
        config={"scene": to_mapping(scene), "planner": to_mapping(planner)},
        inputs=[
            *REFERENCE_PATHS.values(),
            *sorted((HERE.parent / PAPER_DIR).glob(f"planning/*/{replay_name(REFERENCE_STEP_S)}")),
        ],
        simulator={"reference_time_step_s": REFERENCE_STEP_S},
        extra={
            "command": command,
            "verdict": line,
            "set_agreement": agree,
            "paired_signs_kept": [len(signs) - len(changed), len(signs)],
            "seconds": round(time.perf_counter() - started),
        },
    )
    write_table(frame, output, provenance, CHECK_COLUMNS)
    print(f"{output}: {len(frame)} rollouts at the setting beside the reference")
    return line


CHECK_COLUMNS = {
    "part": ("1", "the rollout's part of the check: set (late training) or deployments"),
    **{k: UNITS[k] for k in ("run", "method", "point", "source", "iteration", "rollout")},
    "reference_inserted": ("1", "insertion outcome at the reference step"),
    "reference_p2_x_m": ("m", "final P2 x at the reference step"),
    "reference_p2_y_m": ("m", "final P2 y at the reference step"),
    "inserted": ("1", "insertion outcome at the checked setting"),
    "p2_x_m": ("m", "final P2 x at the checked setting"),
    "p2_y_m": ("m", "final P2 y at the checked setting"),
    "flipped": ("1", "the outcome at the setting differs from the reference's"),
    "dp2_m": ("m", "|ΔP2|: distance between the final P2 at the setting and at the reference"),
}
"""The columns of a check's table: every replayed rollout beside the reference."""


def check_rows(part: str, reference: pd.DataFrame, replayed: np.ndarray) -> pd.DataFrame:
    """One part's rows of a check's table (:data:`CHECK_COLUMNS`): ``replayed`` is
    :func:`pih.study.replay.replay_rows`' array of the ``reference`` rows at the setting."""
    inserted = replayed[:, 0] > 0
    frame = pd.DataFrame(
        {
            "part": part,
            **{
                k: reference.get(k, pd.Series("", index=reference.index))
                for k in ("run", "method", "point", "source")
            },
            "iteration": reference["iteration"],
            "rollout": reference["rollout"],
            "reference_inserted": reference["inserted"].astype(bool),
            "reference_p2_x_m": reference["p2_x_m"],
            "reference_p2_y_m": reference["p2_y_m"],
            "inserted": inserted,
            "p2_x_m": replayed[:, 1],
            "p2_y_m": replayed[:, 2],
        }
    )
    frame["flipped"] = frame["inserted"] != frame["reference_inserted"]
    frame["dp2_m"] = np.hypot(
        frame["p2_x_m"] - frame["reference_p2_x_m"], frame["p2_y_m"] - frame["reference_p2_y_m"]
    )
    return frame.reset_index(drop=True)


def replay_set(scene: SceneConfig, workers: int, output: Path, command: str) -> None:
    """The set replayed at ``scene``, written with its provenance (the CPU and BLAS kernel
    among it), to compare with a replay elsewhere (``--against``)."""
    rows, planner = read_set(SET_PATH)
    replayed = replay_rows(rows, scene, planner, workers)
    frame = rows.assign(inserted=replayed[:, 0] > 0, p2_x_m=replayed[:, 1], p2_y_m=replayed[:, 2])
    provenance = record(
        "step_set_replay",
        config={"scene": to_mapping(scene), "planner": to_mapping(planner)},
        inputs=[SET_PATH],
        extra={"command": command},
    )
    write_table(frame, output, provenance, UNITS)
    print(f"{output}: {len(frame)} rollouts, {int(frame['inserted'].sum())} insert")


def check_against_replay(scene: SceneConfig, workers: int, against: Path) -> str:
    """The set at ``scene`` here against a replay of it made elsewhere (another CPU, BLAS
    kernel or allocator): how far the physics moves when only the machine does."""
    reference = pd.read_parquet(against)
    made = read_provenance(against)
    _, planner = read_set(SET_PATH)
    print(f"against {against}: made on {made['machine']}, allocator {made['allocator']}")
    differences = scene_differences(to_mapping(scene), made["config"]["scene"])
    if differences:
        raise SystemExit(f"{against} was replayed at another setting: {'; '.join(differences)}")
    replayed = replay_rows(reference, scene, planner, workers)
    flips, median_dp2_um = compare_set(replayed, reference, "this machine")
    return f"flips={flips} of {len(reference)} vs={against} median_dp2_um={median_dp2_um:.3g}"


def check_against_half_step(scene: SceneConfig, workers: int) -> str:
    """The former check, a diagnostic: the set at h and at h/2."""
    rows, planner = read_set(SET_PATH)
    step = scene.solver.time_step_s
    outcomes = {
        name: replay_rows(rows, at_step(scene, h), planner, workers)
        for name, h in (("h", step), ("h/2", step / 2))
    }
    inserted = {name: o[:, 0] > 0 for name, o in outcomes.items()}
    flips = inserted["h"] != inserted["h/2"]
    dp2_um = 1e6 * np.hypot(*(outcomes["h"][:, 1:] - outcomes["h/2"][:, 1:]).T)
    print(f"{len(rows)} set rollouts at h = {1e3 * step:g} ms and h/2")
    per_method(rows, flips, inserted)
    verdict = "PASS" if 1 - flips.mean() >= AGREEMENT else "FAIL"
    return (
        f"flips={int(flips.sum())} of {len(rows)} vs_half_step "
        f"median_dp2_um={np.median(dp2_um):.3g} verdict={verdict}"
    )


def main() -> int:
    parser = argparse.ArgumentParser(
        description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter
    )
    parser.add_argument("--configfile", nargs="+", default=["config/config.yaml"])
    parser.add_argument("--set", action="append", default=[], metavar="scene.KEY=VALUE")
    parser.add_argument("--workers", type=int, default=2)
    mode = parser.add_mutually_exclusive_group()
    mode.add_argument("--half-step", action="store_true", help="the former check: h against h/2")
    mode.add_argument(
        "--make-reference", action="store_true", help="replay the set at the reference step"
    )
    mode.add_argument("--draw-from", nargs="+", type=Path, metavar="ROLLOUTS")
    mode.add_argument("--replay", type=Path, metavar="FILE", help="write the set's replay here")
    mode.add_argument("--against", type=Path, metavar="FILE", help="compare with such a replay")
    parser.add_argument(
        "--output",
        type=Path,
        default=Path("step_check.parquet"),
        help="the check's table: every rollout at the setting beside the reference "
        "(default step_check.parquet)",
    )
    parser.add_argument(
        "--rollouts",
        type=int,
        metavar="N",
        help="a quick look: the set's first N rollouts and N deployment trials per point, source "
        "and method (verdict=PARTIAL)",
    )
    args = parser.parse_args()
    if args.rollouts is not None and (
        args.rollouts < 1
        or any((args.half_step, args.make_reference, args.draw_from, args.replay, args.against))
    ):
        parser.error("--rollouts N: N >= 1, with the check against the reference only")

    if args.draw_from:
        drawn = draw_set(args.draw_from)
        write_set(drawn, SET_PATH)
        print(f"{SET_PATH}: {len(drawn)} rollouts ({drawn['method'].value_counts().to_dict()})")
        return 0
    try:
        config = load_config(args.configfile)
        scene = overridden(from_mapping(SceneConfig, config["scene"], "scene"), args.set)
    except ConfigError as error:
        print(f"step_convergence: {error}", file=sys.stderr)
        return 1
    if args.make_reference:
        if args.set:
            print("step_convergence: --make-reference takes the config's scene, no --set")
            return 1
        command = shlex.join(["python", *sys.argv])
        make_reference(scene, args.workers, command)
        return 0
    if args.replay:
        replay_set(scene, args.workers, args.replay, shlex.join(["python", *sys.argv]))
    elif args.against:
        print(check_against_replay(scene, args.workers, args.against))
    elif args.half_step:
        print(check_against_half_step(scene, args.workers))
    else:
        command = shlex.join(["python", *sys.argv])
        print(check_against_reference(scene, args.workers, args.output, command, args.rollouts))
    return 0


if __name__ == "__main__":
    sys.exit(main())
