"""``results/summary.md``: the study's headline numbers beside the paper's, at a glance.

The paper's numbers are quoted from its text (Tables 2 and 3, §4); everything else is read from
the workflow's tables. One unit per column; the detailed tables are linked.
"""

from __future__ import annotations

import math
from collections.abc import Mapping

import numpy as np
import pandas as pd

from pih.analysis.aggregate import (
    ROBUSTNESS_COLUMNS,
    compared_rows,
    headline_std,
    level_label,
    model_error_level,
    offset_level,
    on_training_scene,
)
from pih.analysis.run_summary import NO_MODEL_ERROR
from pih.analysis.training_model import REAL_SCENE
from pih.records.outputs import markdown_table
from pih.validation.experiment import PAPER_PEARSON_R, PAPER_RELATIVE_ERROR_PCT

# Paper §4 (conclusions): bilevel, with its outer rule, "100% successful insertion within 50
# iterations across a wide range of starting positions"; one-level's "mean cost ... diverges" (no
# success rate given). Our outer rule is not the paper's, so the paper has no number for it.
PAPER_PLANNING = {
    "one_level": "mean cost diverges (no rate)",
    "bilevel/explored_argmin": "100 % insertion",
    "bilevel/deepest_explored": "— (our rule)",
    "one_level/mean_sensed_hole": "— (not in the paper)",
    "one_level/calibrated_mean_sensed_hole": "— (not in the paper)",
}
FEATURE_NAMES = {
    "initial_f_x": "initial F_x",
    "final_f_x": "final F_x",
    "initial_f_z": "initial F_z",
    "final_f_z": "final F_z",
    "final_theta": "final θ",
}


def _hydroelastic(comparison: pd.DataFrame, alignment: str) -> pd.DataFrame:
    """The rows of the first hydroelastic variant in the comparison table."""
    hydro = comparison[comparison["contact_model"] == "hydroelastic"]
    first = hydro["variant"].iloc[0] if len(hydro) else None
    return hydro[(hydro["variant"] == first) & (hydro["alignment"] == alignment)]


def relative_error_table(
    comparison: pd.DataFrame, alignment: str = "chamfer_start"
) -> pd.DataFrame:
    """Table 2 (relative errors, %), hydroelastic: per feature, the paper and ours per offset."""
    runs = _hydroelastic(comparison, alignment)
    runs = runs[runs["offset"] != "pooled"].sort_values("offset_m")
    rows = []
    for feature, paper in PAPER_RELATIVE_ERROR_PCT.items():
        row: dict[str, object] = {"relative error (%)": FEATURE_NAMES[feature]}
        for _, run in runs.iterrows():
            offset = round(float(run["offset_m"]), 6)
            row[f"ε0 {1e3 * offset:g} mm: paper"] = paper.get(offset, np.nan)
            row[f"ε0 {1e3 * offset:g} mm: ours"] = run[f"rel_err_{feature}_pct"]
        rows.append(row)
    return pd.DataFrame(rows)


def pearson_table(comparison: pd.DataFrame, alignment: str = "chamfer_start") -> pd.DataFrame:
    """Table 3 (Pearson r over all offsets), hydroelastic: the paper's and ours."""
    pooled = _hydroelastic(comparison, alignment)
    pooled = pooled[pooled["offset"] == "pooled"]
    return pd.DataFrame(
        {
            "Pearson r (1)": ["r(F_x)", "r(F_z)"],
            "paper": list(PAPER_PEARSON_R.values()),
            "ours": [float(pooled[c].iloc[0]) if len(pooled) else np.nan for c in PAPER_PEARSON_R],
        }
    )


def chosen_variants(variants: pd.DataFrame) -> pd.DataFrame:
    """The selection rule's choice per contact model (pooled, paper's alignment)."""
    chosen = variants[variants["chosen"].astype(bool)]
    return pd.DataFrame(
        {
            "contact model": chosen["contact_model"],
            "variant": chosen["variant"],
            "r(F_x) (1)": chosen["r_f_x"],
            "r(F_z) (1)": chosen["r_f_z"],
            "max Table 2 error (%)": chosen["max_rel_err_pct"],
        }
    )


def _interval(rate: float, low: float, high: float) -> str:
    return "—" if not np.isfinite(rate) else f"{rate:.2f} ({low:.2f}–{high:.2f})"


def model_error_rows(robustness: pd.DataFrame, paired: pd.DataFrame) -> pd.DataFrame:
    """Per model error (``robustness.model_error``), level of the compared dimensions (all runs
    when there are none: the levels do not pool) and method: deployment success on the changed
    real scene with its interval, beside the same std on the training scene at that level, and
    against one-level at the same points (paired)."""
    if "model_error" not in robustness:
        return pd.DataFrame()
    compared = [c for c in robustness.columns if c not in ROBUSTNESS_COLUMNS]
    errors = robustness[robustness["model_error"] != NO_MODEL_ERROR]
    exact = on_training_scene(robustness)
    rows = []
    for _, row in errors.iterrows():
        at_level = (exact[compared] == row[compared]).all(axis=1)
        same = exact[
            at_level
            & (exact["method"] == row["method"])
            & (exact["start_std_m"] == row["start_std_m"])
        ]
        label = level_label(compared, tuple(row[compared]))
        pair = paired[
            (paired["dimension"] == "model_error")
            & (paired["level"] == model_error_level(row["model_error"], label))
            & (paired["method"] == row["method"])
            & (paired["versus"] == "one_level")
        ]
        rows.append(
            {
                "model error": row["model_error"],
                "dimension": ", ".join(compared) or "all",
                "level": ", ".join(str(level) for level in row[compared]) or "all",
                "method": row["method"],
                "runs": row["runs"],
                "deployed": _interval(
                    row["deploy_success_rate"], row["deploy_ci_low"], row["deploy_ci_high"]
                ),
                "without it": (
                    _interval(
                        *same.iloc[0][["deploy_success_rate", "deploy_ci_low", "deploy_ci_high"]]
                    )
                    if len(same)
                    else "—"
                ),
                "vs one-level: better / worse / tied": (
                    f"{pair.iloc[0]['better']} / {pair.iloc[0]['worse']} / {pair.iloc[0]['tied']}"
                    if len(pair)
                    else "—"
                ),
            }
        )
    return pd.DataFrame(rows)


def planning_rows(
    success: pd.DataFrame, robustness: pd.DataFrame, time_step: pd.DataFrame | None = None
) -> pd.DataFrame:
    """The headline per method (and per compared level, e.g. an ablation's variants, whose
    levels are different designs that do not pool): deployment success from starts offset by
    N(0, σ²), a test the learned policy can fail, and, with the study's replays
    (:func:`pih.analysis.time_step.time_step_table`), the same trials at the finest step
    replayed; beside it the nominal deployment, how many runs' nominal trials only repeated a
    training rollout, and the final mean's deployment."""
    compared = compared_rows(success)
    overall = compared if len(compared) else success[success["dimension"] == "all"]
    robustness = on_training_scene(robustness)
    std = headline_std(robustness)
    offset = f"from starts {1e3 * std:g} mm off" if std else "from offset starts"
    replayed = _replayed_headline(time_step, std)
    rows = []
    for _, row in overall.iterrows():
        levels = {"dimension": row["dimension"], "level": row["level"]} if len(compared) else {}
        perturbed = robustness[robustness["method"] == row["method"]]
        if len(compared):
            perturbed = perturbed[perturbed[row["dimension"]].astype(str) == str(row["level"])]
        perturbed = perturbed[perturbed["start_std_m"] == std] if std is not None else perturbed[:0]
        off = perturbed.iloc[0] if len(perturbed) else None
        at_steps = {
            offset: (
                _interval(off["deploy_success_rate"], off["deploy_ci_low"], off["deploy_ci_high"])
                if off is not None
                else "— (not redeployed)"
            )
        }
        if replayed is not None:
            coarse, fine, trials = replayed
            if len(compared):
                trials = trials[trials[row["dimension"]].astype(str) == str(row["level"])]
            trials = trials[trials["method"] == row["method"]]
            at_steps = {
                f"{offset}, {_ms(coarse)}": at_steps[offset],
                f"{offset}, {_ms(fine)}": (
                    _interval(*trials.iloc[0][list(_RATE)])
                    if len(trials) and trials.iloc[0]["runs"] == row["runs"]
                    else f"— ({trials['runs'].sum()} of {row['runs']} runs replayed)"
                ),
            }
        rows.append(
            {
                "method": row["method"],
                **levels,
                "paper": PAPER_PLANNING.get(row["method"], ""),
                "runs": row["runs"],
                **at_steps,
                "runs all inserted (offset)": off["runs_all_inserted"] if off is not None else "—",
                "from the training start": _interval(
                    row["deploy_success_rate"], row["deploy_ci_low"], row["deploy_ci_high"]
                ),
                "runs only repeating training": row["runs_repeating_training"],
                "final mean, training start": _interval(
                    row["final_mean_deploy_success_rate"],
                    row["final_mean_deploy_ci_low"],
                    row["final_mean_deploy_ci_high"],
                ),
                "median goal iteration": (
                    "never"
                    if math.isnan(row["median_goal_iteration"])
                    else row["median_goal_iteration"]
                ),
            }
        )
    return pd.DataFrame(rows)


_RATE = ("deploy_success_rate", "deploy_ci_low", "deploy_ci_high")


def _ms(step_s: float) -> str:
    return f"at {1e3 * step_s:g} ms"


def _replayed_headline(
    time_step: pd.DataFrame | None, std: float | None
) -> tuple[float, float, pd.DataFrame] | None:
    """The runs' own step, the finest replayed one and the deployed policy's rows there from
    the headline's offset starts; None without replays."""
    if time_step is None or std is None:
        return None
    steps = sorted(time_step["time_step_s"].unique())
    rows = time_step[
        (time_step["time_step_s"] == steps[0])
        & (time_step["start_std_m"] == std)
        & (time_step["phase"] == "deploy")
    ]
    return steps[-1], steps[0], rows


def step_pairs(paired: pd.DataFrame, robustness: pd.DataFrame) -> pd.DataFrame:
    """The paired comparisons on the headline's offset starts, one row a pair: at the runs' own
    step and at each step their trials were replayed at
    (:func:`pih.analysis.time_step.time_step_pairs`' rows), ``better / worse / tied`` and the
    sign test's p for each; "—" where a pair's runs were not all replayed. Pooled, the runs' own
    step reads every pair (:func:`perturbed_pairs`); with compared dimensions, whose levels do
    not pool, a row a pair and joint level (``level``, as the time-step rows name it)."""
    std = headline_std(on_training_scene(robustness))
    rows = paired[paired["dimension"] == "time_step_s"]
    parts = rows["level"].str.extract(rf"^starts {std:g} m off at ([^ ,]+) s(?:, (.+))?$")
    found = parts[0].notna()
    at_step = rows[found].assign(
        step=parts.loc[found, 0].astype(float), level=parts.loc[found, 1].fillna("")
    )
    own_step = at_step["step"].max()
    own = perturbed_pairs(paired, robustness)
    per_level = "level" in own.columns
    at_step = at_step[(at_step["level"] != "") == per_level]
    pair = ["level", "method", "versus"] if per_level else ["method", "versus"]
    if per_level:
        own = at_step[at_step["step"] == own_step]
    table = own[[*pair, "pairs"]].reset_index(drop=True)
    for step in sorted(at_step["step"].unique(), reverse=True):
        here = own if step == own_step else at_step[at_step["step"] == step]
        here = table[pair].merge(here, on=pair, how="left")
        whole = pd.Series(here["pairs"].to_numpy() == table["pairs"].to_numpy())
        evidence = pair_evidence(
            here.fillna({"better": 0, "worse": 0, "tied": 0}).astype(
                {"better": int, "worse": int, "tied": int}
            )
        )
        at = f"{1e3 * step:g} ms"
        for column, name in (
            ("better / worse / tied", f"at {at}: better / worse / tied"),
            ("difference (95 % CI)", f"difference at {at} (95 % CI)"),
            ("p (least possible)", f"p at {at} (least possible)"),
        ):
            table[name] = evidence[column].where(whole, "—")
        if step == own_step:
            for column in ("tied at the ceiling", "detectable"):
                table[f"{column} at {at}"] = evidence[column].where(whole, "—")
    return table


def _signed(value: float) -> str:
    return f"{value:+.2f}".replace("+0.00", "0.00").replace("-0.00", "0.00")


def _detectable(value: float) -> str:
    return f"{value:.2f}" if np.isfinite(value) else "—"


def pair_evidence(rows: pd.DataFrame) -> pd.DataFrame:
    """Paired rows (:func:`pih.analysis.statistics.pair_counts`' columns) as a reader weighs
    them: the signs, the pairs tied at the ceiling, the mean difference with its 95 % interval,
    the sign test's p beside the least its untied pairs allow, and the smallest difference the
    pairs could detect ("—": too few pairs for the sign test to reach 0.05, or none within
    [−1, 1])."""
    keep = [c for c in rows.columns if c in ("level", "method", "versus", "pairs")]
    return rows[keep].assign(
        **{
            "better / worse / tied": [
                f"{r.better} / {r.worse} / {r.tied}" for r in rows.itertuples()
            ],
            "tied at the ceiling": rows["tied_at_ceiling"],
            "difference (95 % CI)": [
                f"{_signed(r.mean_difference)} ({_signed(r.difference_ci_low)} to "
                f"{_signed(r.difference_ci_high)})"
                for r in rows.itertuples()
            ],
            "p (least possible)": [
                f"{r.sign_test_p:.3g} ({r.least_possible_p:.3g})" for r in rows.itertuples()
            ],
            "detectable": [_detectable(r.detectable_difference) for r in rows.itertuples()],
        }
    )


def perturbed_pairs(paired: pd.DataFrame, robustness: pd.DataFrame) -> pd.DataFrame:
    """The paired comparisons on the headline's offset starts (same draws at each point): per
    level of a compared dimension where the study has one (its levels do not pool), else over
    all points."""
    std = headline_std(on_training_scene(robustness))
    if std is None:
        return paired[:0]
    suffix = offset_level("", std)
    per_level = paired[paired["level"].str.endswith(suffix)]
    if len(per_level):
        levels = per_level["level"].str.slice(stop=-len(suffix))
        return per_level.assign(level=levels).reset_index(drop=True)
    rows = paired[(paired["dimension"] == "start_std_m") & (paired["level"] == str(std))]
    return rows.drop(columns=["dimension", "level"]).reset_index(drop=True)


def training_model_rows(table: pd.DataFrame) -> pd.DataFrame:
    """The planner's simulator against reality, a row per method and training model
    (:func:`pih.analysis.training_model.training_model_table`): success on the real scene and as
    the simulator predicted it, with intervals over runs, the runs it mispredicted, and the runs
    against their twins trained on the real scene's model."""
    rows = []
    for row in table.itertuples():
        paired = row.pairs > 0
        rows.append(
            {
                "method": row.method,
                "trained in": row.training_model,
                "runs": row.runs,
                "on the real scene": _interval(
                    row.deploy_success_rate, row.deploy_ci_low, row.deploy_ci_high
                ),
                "predicted by its simulator": (
                    "(the same trials)"
                    if row.training_model == REAL_SCENE
                    else _interval(
                        row.predicted_success_rate, row.predicted_ci_low, row.predicted_ci_high
                    )
                ),
                "runs mispredicted": row.runs_mispredicted,
                "vs twin trained on the real scene's model: better / worse / tied": (
                    f"{row.better} / {row.worse} / {row.tied}" if paired else "—"
                ),
                "tied at the ceiling": row.tied_at_ceiling if paired else "—",
                "difference (95 % CI)": (
                    f"{_signed(row.mean_difference)} ({_signed(row.difference_ci_low)} to "
                    f"{_signed(row.difference_ci_high)})"
                    if paired
                    else "—"
                ),
                "p (least possible)": (
                    f"{row.sign_test_p:.3g} ({row.least_possible_p:.3g})" if paired else "—"
                ),
                "detectable": _detectable(row.detectable_difference) if paired else "—",
                "median run (s)": row.median_run_s,
            }
        )
    return pd.DataFrame(rows)


def paired_rows(paired: pd.DataFrame) -> pd.DataFrame:
    """The overall rows of :func:`pih.analysis.aggregate.paired_table`."""
    overall = paired[paired["dimension"] == "all"]
    return overall.drop(columns=["dimension", "level"]).reset_index(drop=True)


def study_header(study: Mapping[str, object], code_version: str) -> str:
    """What the summary summarises: config files, budget, runs, code version; a visible note when
    the study is not the default one (its numbers are then not the published ones)."""
    files = ", ".join(f"`{f}`" for f in study["config_files"])
    note = (
        ""
        if study["default"]
        else "\n> **Not the default study**: the config above changes `config/config.yaml`, so "
        'these numbers are not the published ones (README, "Results"); a reduced budget '
        "(e.g. the smoke study's) is a check of the code paths, not a result.\n"
    )
    return f"""Study: {files}; budget {study["iterations"]} iterations × \
{study["rollouts_per_iteration"]} rollouts per planning run, {study["planning_runs"]} planning runs, \
{study["deploy_trials"]} deployment trials per run; code version `{code_version}`. The paper's \
numbers are quoted from its text; ours come from the tables linked at the end.
{note}"""


def summary_markdown(
    comparison: pd.DataFrame,
    variants: pd.DataFrame,
    success: pd.DataFrame,
    paired: pd.DataFrame,
    robustness: pd.DataFrame,
    code_version: str,
    links: Mapping[str, str],
    study: Mapping[str, object],
) -> str:
    """The summary page: planning headline first (the paper's contribution), then validation."""
    links_md = "\n".join(f"- [{name}]({target})" for name, target in links.items())
    std = headline_std(on_training_scene(robustness))
    # The headline's σ is the runs' own deployment's when that is offset, else a redeployment's.
    key = (
        "planner.deploy_start_std_m"
        if std and std == study.get("deploy_start_std_m")
        else "robustness.start_std_m"
    )
    errors = model_error_rows(robustness, paired)
    moved = on_training_scene(robustness)
    moved = robustness.drop(moved.index) if "model_error" in robustness else robustness[:0]
    error_std = f"{1e3 * moved['start_std_m'].min():g} mm" if len(moved) else "σ"
    model_error = (
        ""
        if errors.empty
        else f"""
Deployed on a real scene that differs from the one the policy was trained on
(`robustness.model_error`), from starts {error_std} off (the smallest `robustness.start_std_m`
above 0): success with its interval over runs,
the same without the model error, and the pairs against one-level at the same points, per level
of every compared dimension (the levels do not pool).

{markdown_table(errors, "{:.3g}")}
"""
    )
    sigma = f"{1e3 * std:g} mm" if std else "σ"
    return f"""# pih study summary

{study_header(study, code_version)}
## Would the learned policy insert? (paper §3–4)

Deployment success: the fraction of deployment trials of the learned policy that inserted,
averaged over independent runs (one per start and seed), with a 95 % Wilson interval that counts
each run as one observation. **The headline is from starts {sigma} off**: each trial's start
offset by N(0, ({sigma})²) in x and y (`{key}`), a test every method can fail.
From the training start, a run whose target reads no fresh sensing (our rule, once it has found
the hole) deploys by repeating a training rollout ("runs only repeating training"), which cannot
fail once its mean inserted. `median goal iteration`: the first iteration whose goal was within
the success tolerance of the true hole (median over runs; blank: in fewer than half the runs).

{markdown_table(planning_rows(success, robustness), "{:.3g}")}

Paired from starts {sigma} off, over the sweep points both methods ran (the same random draws):
at how many `method` deployed more often than `versus`, less often or equally, and how many of
the ties were both inserting in every trial (a ceiling that hides any difference); the mean
difference with a 95 % paired t-interval; a two-sided exact sign test over the untied pairs,
beside the least p their number allows; the smallest mean difference the pairs could detect (a
paired t-test at 0.05 with 80 % power; docs/planner.md, "Intervals and tests").

{markdown_table(pair_evidence(perturbed_pairs(paired, robustness)), "{:.3g}")}

The same from the training start (nominal deployment):

{markdown_table(pair_evidence(paired_rows(paired)), "{:.3g}")}
{model_error}
## Hydroelastic contact vs Whitney's theory (paper Tables 2–3)

Hydroelastic model, the paper's depth alignment (chamfer start); ε0 is the lateral offset.

{markdown_table(relative_error_table(comparison), "{:.3g}")}

{markdown_table(pearson_table(comparison), "{:.4g}")}

Every validation variant (geometry, margin, solver, point-contact stiffness) is compared in the
variants table; the selection rule (among variants that get through every offset with every
Table 2 error within the paper's worst, the highest weaker pooled r of F_x and F_z) picks, per
contact model:

{markdown_table(chosen_variants(variants), "{:.4g}")}

## Detailed tables

{links_md}
"""
