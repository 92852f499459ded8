"""The planner's own simulator against reality (docs/contact_model.md): per training simulator
(``planner.simulator``) and method, deployment success on the real scene from offset starts,
what the simulator itself predicted (the same trials on its own scene), and each run against its
twin trained on the real scene's model: the run at the same levels of every other sweep
dimension (method, start, seed), which has its seed key and so its draws (the simulator keys are
training keys, outside the seed key)."""

from __future__ import annotations

import math

import pandas as pd

from pih.analysis.run_summary import NO_MODEL_ERROR, split_keys
from pih.analysis.statistics import TEST_COLUMNS, TIE_COLUMNS, pair_counts, rate_over_runs
from pih.study.points import SIMULATOR_PREFIX

SIMULATED_HOLE_KEY = "planner.simulated_hole"
REAL_SCENE = "the real scene's"
"""The training model of runs whose simulator is the real scene (the hole aside)."""

TRAINING_MODEL_COLUMNS: dict[str, tuple[str, str]] = {
    "method": ("", "planning method: one_level, one_level/<stable goal> or bilevel/<outer rule>"),
    "training_model": (
        "",
        (
            f"the planner's simulator (planner.simulator): {REAL_SCENE} model, or its contact model "
            "and stiffness"
        ),
    ),
    "start_std_m": ("m", "std of the deployment trials' start offset in x and y"),
    "runs": ("1", "independent planning runs"),
    "deploy_success_rate": (
        "1",
        "mean over runs of the fraction of trials that inserted on the real scene",
    ),
    "deploy_ci_low": ("1", "95 % Wilson interval over runs (each run one observation), low"),
    "deploy_ci_high": ("1", "95 % Wilson interval over runs, high"),
    "predicted_success_rate": (
        "1",
        (
            "the same trials on the simulator's own scene (the model error equal to it): what the "
            "simulator predicted (NaN: not redeployed there)"
        ),
    ),
    "predicted_ci_low": ("1", "95 % Wilson interval over runs, low"),
    "predicted_ci_high": ("1", "95 % Wilson interval over runs, high"),
    "runs_mispredicted": ("1", "runs whose real-scene success differs from the prediction"),
    "median_run_s": (
        "s",
        "median over runs of a planning run's wall time as recorded (machines and load differ)",
    ),
    "mean_gap": ("1", "mean over runs of real-scene success minus the predicted (sim-to-real)"),
    "pairs": (
        "1",
        (
            "runs paired with their twin trained on the real scene's model (the same method, start "
            "and seed: the same draws)"
        ),
    ),
    "better": ("1", "pairs where this training model's run deployed more often on the real scene"),
    "worse": ("1", "pairs where it deployed less often"),
    "tied": ("1", "pairs with equal deployment success"),
    **TIE_COLUMNS,
    "mean_difference": ("1", "mean over pairs of its success minus the twin's"),
    **TEST_COLUMNS,
}


def simulator_keys(sweep_keys: list[str]) -> list[str]:
    """The sweep dimensions that set the planner's own simulator."""
    return [key for key in split_keys(sweep_keys) if key.startswith(SIMULATOR_PREFIX)]


def training_model(levels: pd.Series, keys: list[str]) -> str:
    """A run's training model from its levels of the simulator ``keys`` (``point, 1e+07 N/m``;
    :data:`REAL_SCENE` where none is set)."""
    named = [
        f"{float(levels[key]):g} N/m" if key.endswith("_n_per_m") else str(levels[key])
        for key in keys
        if levels[key] != "None"
    ]
    return ", ".join(named) or REAL_SCENE


def training_model_table(
    deployments: pd.DataFrame, sweep_keys: list[str], start_std_m: float
) -> pd.DataFrame:
    """Per method and training model, from starts offset by ``start_std_m`` (the headline's):
    deployment success on the real scene, the simulator's prediction, and pairs
    against the twins trained on the real scene's model. Only runs trained on the true hole: a
    simulator that also moves the hole is docs/sim_to_real.md's question. Empty without
    simulator dimensions."""
    keys = simulator_keys(sweep_keys)
    columns = list(TRAINING_MODEL_COLUMNS)
    if not keys:
        return pd.DataFrame(columns=columns)
    frame = deployments
    if SIMULATED_HOLE_KEY in frame:
        frame = frame[frame[SIMULATED_HOLE_KEY] == "true_hole"]
    frame = frame.assign(training_model=frame.apply(training_model, axis=1, args=(keys,)))
    twins = [key for key in split_keys(sweep_keys) if key not in keys]
    index = ["method", "training_model", *twins]
    seconds = frame.groupby(index)["run_seconds"].max() if "run_seconds" in frame else None
    # A run redeployed at its own deployment's std counts once (deployment is deterministic).
    frame = frame[frame["start_std_m"] == start_std_m].drop_duplicates(["run", "model_error"])
    real = frame[frame["model_error"] == NO_MODEL_ERROR].set_index(index)["deploy_success_rate"]
    predicted = frame[frame["on_simulator"]].set_index(index)["deploy_success_rate"]
    runs = pd.DataFrame({"real": real, "predicted": predicted.reindex(real.index)})
    runs["seconds"] = math.nan if seconds is None else seconds.reindex(runs.index)
    trained_real = runs.index.get_level_values("training_model") == REAL_SCENE
    reference = runs[trained_real]["real"].droplevel("training_model")
    rows = []
    for (method, model), part in runs.groupby(level=["method", "training_model"]):
        rate, low, high = rate_over_runs(part["real"])
        predicted_rate, predicted_low, predicted_high = rate_over_runs(part["predicted"])
        gap = (part["real"] - part["predicted"]).dropna()
        own = part["real"].droplevel("training_model")
        pairs = pair_counts(own, reference.reindex(own.index))
        if model == REAL_SCENE or not pairs["pairs"]:
            pairs = {
                column: 0
                if column in ("pairs", "better", "worse", "tied", "tied_at_ceiling")
                else math.nan
                for column in pairs
            }
        rows.append(
            {
                "method": method,
                "training_model": model,
                "start_std_m": start_std_m,
                "runs": len(part),
                "deploy_success_rate": rate,
                "deploy_ci_low": low,
                "deploy_ci_high": high,
                "predicted_success_rate": predicted_rate,
                "predicted_ci_low": predicted_low,
                "predicted_ci_high": predicted_high,
                "runs_mispredicted": int((gap != 0).sum()),
                "median_run_s": float(part["seconds"].median()),
                # Rounded: a mean of differences of tenths leaves float noise (−3.5e-18).
                "mean_gap": round(float(gap.mean()), 12) if len(gap) else math.nan,
                **pairs,
            }
        )
    table = pd.DataFrame(rows, columns=columns)
    # Per method, the real scene's model first: the twins the other rows are paired with.
    order = table["training_model"] != REAL_SCENE
    return (
        table.assign(order=order)
        .sort_values(["method", "order"], kind="stable")[columns]
        .reset_index(drop=True)
    )
