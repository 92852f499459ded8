"""One planning run's outcome, read from its records: the best training rollouts, deployment
success and the training view (:func:`run_summary`), and the per-run rows every table across
runs (:mod:`pih.analysis.aggregate`) is made from (:func:`run_tables`, :func:`redeployment_summaries`).
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from pathlib import Path
from typing import Any

import pandas as pd

from pih.config import ConfigError, plain, recorded_config, to_mapping
from pih.planning.config import method_label, recorded_planner, upgraded
from pih.planning.run_record import Phase, phase_rows
from pih.records.outputs import read_metadata, read_provenance
from pih.scene.config import SceneConfig
from pih.scene.overrides import scene_with
from pih.study.points import GOAL_KEY, is_method_key, upgraded_point


def best_training_rows(rollouts: pd.DataFrame) -> pd.DataFrame:
    """Each training iteration's lowest-cost rollout, in iteration order."""
    train = phase_rows(rollouts, Phase.TRAIN)
    return train[train["is_best"]].sort_values("iteration")


def final_success_fraction(rollouts: pd.DataFrame, last: int = 10) -> float:
    """Fraction of the last ``last`` training iterations whose best rollout succeeded."""
    return float(best_training_rows(rollouts)["success"].tail(last).mean())


def variant(planner: Mapping[str, Any]) -> str:
    """A run's method as the study compares it (its recorded ``planner`` section, any age):
    ``one_level``, ``one_level/<stable goal>`` or ``bilevel/<outer rule>``."""
    return method_label(upgraded(planner)["goal"])


def run_title(point: Mapping[str, Any], planner: Mapping[str, Any]) -> str:
    """A run for a figure title: its method, then its other sweep levels (``start_x_m = -0.035``)."""
    levels = [
        f"{key.rsplit('.', 1)[-1]} = {plain(value)}"
        for key, value in point.items()
        if not is_method_key(key)
    ]
    return ", ".join([variant(planner), *levels])


def first_sensing_error(rollouts: pd.DataFrame, hole_xy_m: tuple[float, float]) -> dict[str, float]:
    """Where the run's first sensing of the hole (eq. 16b, its first training iteration's) landed
    relative to the real hole H: x and y offsets and their norm (m). In a simulator that knows
    only the sensed hole (``sensed_per_run``) this is the hole it trains on."""
    train = phase_rows(rollouts, Phase.TRAIN)
    if train.empty:
        return dict.fromkeys(FIRST_SENSING_COLUMNS, math.nan)
    first = train.sort_values(["iteration", "rollout"]).iloc[0]
    dx = float(first["sensed_hole_x_m"] - hole_xy_m[0])
    dy = float(first["sensed_hole_y_m"] - hole_xy_m[1])
    return {
        "first_sensing_dx_m": dx,
        "first_sensing_dy_m": dy,
        "first_sensing_error_m": math.hypot(dx, dy),
    }


FIRST_SENSING_COLUMNS: dict[str, tuple[str, str]] = {
    "first_sensing_dx_m": ("m", "x of the run's first sensed hole minus the real hole's"),
    "first_sensing_dy_m": ("m", "y of the run's first sensed hole minus the real hole's"),
    "first_sensing_error_m": ("m", "distance of the run's first sensed hole from the real hole"),
}


def run_summary(
    rollouts: pd.DataFrame, tolerance_m: float, time_step_s: float, deploy_policy: str
) -> dict[str, Any]:
    """One planning run's outcome: deployment success (the headline) and the training view."""
    train = phase_rows(rollouts, Phase.TRAIN)
    deploy = phase_rows(rollouts, Phase.DEPLOY)
    final_mean = (
        deploy if deploy_policy == "final_mean" else phase_rows(rollouts, Phase.DEPLOY_FINAL_MEAN)
    )
    means = phase_rows(rollouts, Phase.MEAN).sort_values("iteration")
    best = best_training_rows(rollouts)
    successes = best.loc[best["success"], "iteration"]
    goal_reached = best.loc[best["target_hole_error_m"] <= tolerance_m, "iteration"]
    return {
        "deploy_success_rate": float(deploy["success"].mean()) if len(deploy) else math.nan,
        "final_mean_deploy_success_rate": float(final_mean["success"].mean())
        if len(final_mean)
        else math.nan,
        "final_iteration_success": bool(best["success"].iloc[-1]),
        "final_success_fraction": final_success_fraction(rollouts),
        "mean_policy_last10_success": float(means["success"].tail(10).mean())
        if len(means)
        else math.nan,
        "first_success_iteration": int(successes.iloc[0]) if len(successes) else None,
        "goal_iteration": int(goal_reached.iloc[0]) if len(goal_reached) else None,
        "diverged_fraction": float((train["status"] != "ok").mean()),
        "retried_fraction": float((train["time_step_s"] != time_step_s).mean()),
        "deploy_diverged_fraction": float((deploy["status"] != "ok").mean())
        if len(deploy)
        else math.nan,
        "deploy_repeats_training": repeats_training(rollouts),
    }


def repeats_training(rollouts: pd.DataFrame) -> bool:
    """Whether every deployment trial only repeated a rollout of training: it ended at exactly
    the final pose of one of the per-iteration mean rollouts. That happens when the deployed
    target reads no fresh sensing and the start is training's (our rule, once it has found the
    hole): such trials cannot fail once the mean inserted, so they measure training, not
    deployment (the perturbed redeployment can fail)."""
    pose = ["final_bottom_x_m", "final_bottom_y_m", "final_bottom_theta_rad"]
    deploy = phase_rows(rollouts, Phase.DEPLOY)[pose]
    means = phase_rows(rollouts, Phase.MEAN)[pose]
    if deploy.empty or means.empty:
        return False
    seen = set(map(tuple, means.to_numpy()))
    return all(tuple(row) in seen for row in deploy.to_numpy())


BEST_COST_COLUMNS: dict[str, tuple[str, str]] = {
    "iteration": ("1", "iteration"),
    "cost": ("1", "best inner cost J_inn of the iteration (eq. 11)"),
    "method": ("", "planning method: one_level, one_level/<stable goal> or bilevel/<outer rule>"),
    "run": ("", "run directory (sweep point)"),
}


def run_tables(
    rollout_files: Iterable[str | Path],
    sweep_keys: list[str],
    tags: Mapping[Path, Mapping[str, Any]] | None = None,
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """From planning-run records: the best cost per iteration of every run (long table) and one
    summary row per run, each tagged with its method (:func:`variant`), run (its directory's
    name) and sweep levels (its sweep point's), or with ``tags[path]``'s run and levels."""
    bests, summaries = [], []
    for path in map(Path, rollout_files):
        record = read_provenance(path)
        planner = recorded_planner(record["config"])
        scene = recorded_config(SceneConfig, record["config"], "scene")
        rollouts = pd.read_parquet(path)
        if tags is None:
            point = upgraded_point(record["sweep_point"])
            own = {"run": path.parent.name, **{k: point[k] for k in split_keys(sweep_keys)}}
        else:
            own = tags[path]
        run_tags = {"method": variant(to_mapping(planner)), **own}
        run_tags |= {key: str(run_tags[key]) for key in split_keys(sweep_keys)}
        bests.append(best_training_rows(rollouts)[["iteration", "cost"]].assign(**run_tags))
        summaries.append(
            {
                **run_tags,
                "start_std_m": planner.deploy_start_std_m,
                "model_error": NO_MODEL_ERROR,
                "on_simulator": on_simulator(record["config"]),
                "run_seconds": run_seconds(path),
                **run_summary(
                    rollouts,
                    planner.success_tolerance_m,
                    scene.solver.time_step_s,
                    planner.deploy_policy,
                ),
                **first_sensing_error(rollouts, (scene.hole.x_m, scene.hole.y_m)),
            }
        )
    return pd.concat(bests, ignore_index=True), pd.DataFrame(summaries)


def run_seconds(path: Path) -> float:
    """A planning run's wall time (its plan job's, as ``rollouts.parquet`` records it; NaN for
    records without it)."""
    try:
        return float(read_metadata(path, "timing")["seconds"])
    except KeyError:
        return math.nan


NO_MODEL_ERROR = "none"
"""``model_error`` of a deployment on the scene the policy was trained on."""


def model_error_name(record: Mapping[str, Any]) -> str:
    """The model error a redeployment file's provenance ``record`` names, or "none"."""
    return (record.get("model_error") or {}).get("name", NO_MODEL_ERROR)


def model_error_settings(record: Mapping[str, Any]) -> dict[str, Any]:
    """The dotted scene settings of the model error a redeployment file's provenance
    ``record`` names (none: empty)."""
    return dict((record.get("model_error") or {}).get("settings") or {})


def on_simulator(
    config: Mapping[str, Any],
    model_error: Mapping[str, Any] | None = None,
    error_name: str = NO_MODEL_ERROR,
) -> bool:
    """Whether deployment trials on a run's real scene (its recorded ``config``'s), changed by
    a ``model_error``'s dotted scene settings, ran on the run's own training simulator, the hole
    aside: then they are what the simulator itself predicted (docs/contact_model.md). A named
    error whose settings were not recorded is no prediction."""
    if error_name != NO_MODEL_ERROR and not model_error:
        return False
    scene = recorded_config(SceneConfig, config, "scene")
    changes = recorded_planner(config).simulator.scene_changes
    training = scene.replace(**changes) if changes else scene
    if model_error:
        scene = scene_with(to_mapping(scene), model_error, "robustness.model_error")
    return scene == training


def redeployed_run(path: Path, record: Mapping[str, Any]) -> Path:
    """The ``rollouts.parquet`` a one-run redeployment file redeployed: its recorded input, found
    beside the file (where the workflow and ``pih publish`` keep it) or where it was recorded."""
    inputs = [Path(p) for p in record.get("inputs", {}) if Path(p).name == "rollouts.parquet"]
    for candidate in [path.with_name("rollouts.parquet"), *inputs]:
        if candidate.is_file():
            return candidate
    raise ConfigError(
        f"{path}: the run it redeployed ({inputs or 'rollouts.parquet'}) is not found"
    )


def redeployment_summaries(files: Iterable[str | Path], sweep_keys: list[str]) -> pd.DataFrame:
    """One row per redeployment of a run (``pih redeploy``, the ``redeploy`` and
    ``redeploy_model_error`` rules): its method, run and sweep levels as :func:`run_tables` tags
    them, the start std, the model error's name (``robustness.model_error``, or "none") and
    the fraction of the redeployed trials that inserted."""
    rows = []
    for path in map(Path, files):
        record = read_provenance(path)
        planner = record["config"]["planner"]
        deploy = phase_rows(pd.read_parquet(path, columns=["phase", "success"]), Phase.DEPLOY)
        point = upgraded_point(record["sweep_point"])
        # The record holds the scene deployed on; the run's own holds the one it trained beside.
        run_config = read_provenance(redeployed_run(path, record))["config"]
        rows.append(
            {
                "method": variant(planner),
                "run": path.parent.name,
                **{key: str(point[key]) for key in split_keys(sweep_keys)},
                "start_std_m": planner["deploy_start_std_m"],
                "model_error": model_error_name(record),
                "on_simulator": on_simulator(
                    run_config, model_error_settings(record), model_error_name(record)
                ),
                "deploy_success_rate": float(deploy["success"].mean()),
            }
        )
    return pd.DataFrame(rows)


def split_keys(sweep_keys: list[str]) -> list[str]:
    """The sweep dimensions tables are split by: all but those :func:`variant` labels name."""
    return [key for key in sweep_keys if key != GOAL_KEY]


SEED_KEY = "planner.seed"
REPLICATE_KEYS = ("planner.start_x_m", SEED_KEY)
"""Sweep dimensions that replicate a comparison rather than define one (the ablation table
pools over them)."""


def compared_keys(sweep_keys: list[str]) -> list[str]:
    """The sweep dimensions that define a comparison (e.g. ``variant``): not the method's, not
    the replicates (start, seed)."""
    return [key for key in split_keys(sweep_keys) if key not in REPLICATE_KEYS]


def level_columns(sweep_keys: list[str]) -> dict[str, tuple[str, str]]:
    """Unit specs of the per-run sweep-level columns of :func:`run_tables`' outputs."""
    return {key: ("", f"sweep level of {key}") for key in split_keys(sweep_keys)}
