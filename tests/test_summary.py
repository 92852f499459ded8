"""results/summary.md: the paper's numbers beside ours, read from the workflow's tables."""

from pathlib import Path

import numpy as np
import pandas as pd

from pih.reporting.summary import (
    PAPER_PEARSON_R,
    chosen_variants,
    pearson_table,
    planning_rows,
    relative_error_table,
    step_pairs,
    study_header,
    summary_markdown,
)


def _comparison() -> pd.DataFrame:
    rows = []
    for alignment in ("chamfer_start", "first_peak"):
        for model in ("hydroelastic", "point"):
            for offset in (0.0005, 0.002):
                rows.append(
                    {
                        "variant": model,
                        "contact_model": model,
                        "alignment": alignment,
                        "offset": f"{1e3 * offset:g} mm",
                        "offset_m": offset,
                        **{
                            f"rel_err_{k}_pct": 1.0 + offset * 1e3 + (alignment != "chamfer_start")
                            for k in (
                                "initial_f_x",
                                "final_f_x",
                                "initial_f_z",
                                "final_f_z",
                                "final_theta",
                            )
                        },
                        "r_f_x": np.nan,
                        "r_f_z": np.nan,
                    }
                )
            rows.append(
                {
                    "variant": model,
                    "contact_model": model,
                    "alignment": alignment,
                    "offset": "pooled",
                    "offset_m": np.nan,
                    "r_f_x": 0.98 if model == "hydroelastic" else 0.5,
                    "r_f_z": 0.93 if alignment == "chamfer_start" else 0.1,
                }
            )
    return pd.DataFrame(rows)


def test_validation_tables_put_the_papers_numbers_beside_ours_for_hydroelastic_chamfer_start():
    errors = relative_error_table(_comparison()).set_index("relative error (%)")
    assert list(errors.columns) == [
        "ε0 0.5 mm: paper",
        "ε0 0.5 mm: ours",
        "ε0 2 mm: paper",
        "ε0 2 mm: ours",
    ]
    assert errors.loc["initial F_x"].tolist() == [10.7575, 1.5, 2.9370, 3.0]  # not first_peak
    assert errors.loc["final θ", "ε0 2 mm: paper"] == 14.3666
    r = pearson_table(_comparison())
    assert r["paper"].tolist() == [PAPER_PEARSON_R["r_f_x"], PAPER_PEARSON_R["r_f_z"]]
    assert r["ours"].tolist() == [0.98, 0.93]


def _success() -> pd.DataFrame:
    return pd.DataFrame(
        {
            "method": [
                "bilevel/deepest_explored",
                "bilevel/explored_argmin",
                "one_level",
                "one_level",
            ],
            "dimension": ["all", "all", "all", "planner.seed"],
            "level": ["all", "all", "all", "0"],
            "runs": [10, 10, 10, 2],
            "deploy_success_rate": [0.9, 0.6, 0.2, 0.0],
            "deploy_ci_low": [0.6, 0.3, 0.05, 0.0],
            "deploy_ci_high": [0.98, 0.85, 0.5, 0.8],
            "final_mean_deploy_success_rate": [0.7, 0.5, 0.1, 0.0],
            "final_mean_deploy_ci_low": [0.4, 0.2, 0.02, 0.0],
            "final_mean_deploy_ci_high": [0.9, 0.8, 0.4, 0.8],
            "median_goal_iteration": [6.0, 12.0, np.nan, np.nan],
            "runs_repeating_training": [9, 0, 0, 0],
        }
    )


def _robustness() -> pd.DataFrame:
    """Perturbed redeployment (1 mm) per method, and a 3 mm level the headline does not use."""
    return pd.DataFrame(
        {
            "method": [
                "bilevel/deepest_explored",
                "bilevel/explored_argmin",
                "one_level",
                "one_level",
            ],
            "start_std_m": [0.001, 0.001, 0.001, 0.003],
            "runs": [10, 10, 10, 10],
            "deploy_success_rate": [0.8, 0.55, 0.25, 0.1],
            "deploy_ci_low": [0.5, 0.3, 0.1, 0.02],
            "deploy_ci_high": [0.95, 0.8, 0.6, 0.4],
            "runs_all_inserted": [6, 3, 0, 0],
        }
    )


def test_planning_rows_lead_with_offset_starts_beside_the_papers_claim():
    rows = planning_rows(_success(), _robustness()).set_index("method")
    assert rows.index.tolist() == [
        "bilevel/deepest_explored",
        "bilevel/explored_argmin",
        "one_level",
    ]
    # The headline column is the smallest σ > 0 redeployed; the nominal one follows it.
    columns = rows.columns.tolist()
    assert columns.index("from starts 1 mm off") < columns.index("from the training start")
    assert rows["from starts 1 mm off"].tolist() == [
        "0.80 (0.50–0.95)",
        "0.55 (0.30–0.80)",
        "0.25 (0.10–0.60)",
    ]
    assert rows["from the training start"].tolist()[0] == "0.90 (0.60–0.98)"
    assert rows["runs only repeating training"].tolist() == [9, 0, 0]
    assert rows["final mean, training start"].tolist()[2] == "0.10 (0.02–0.40)"
    # The paper's 100 % is its own rule's claim; it has no number for ours.
    assert rows.loc["bilevel/explored_argmin", "paper"].startswith("100 %")
    assert "100 %" not in rows.loc["bilevel/deepest_explored", "paper"]
    # Without a redeployment the headline says so rather than showing the nominal numbers.
    bare = planning_rows(_success(), _robustness().query("start_std_m == 0"))
    assert set(bare["from offset starts"]) == {"— (not redeployed)"}
    # An ablation's variants are different designs: one row per method and variant, not pooled.
    ablation = pd.concat(
        [_success(), _success().query("dimension == 'all'").assign(dimension="variant", level="x")]
    )
    rows = planning_rows(ablation, _robustness().assign(variant="x"))
    assert set(rows["dimension"]) == {"variant"} and set(rows["level"]) == {"x"}
    assert rows["from starts 1 mm off"].tolist()[0] == "0.80 (0.50–0.95)"


def _time_step(runs: int = 10) -> pd.DataFrame:
    """The deployed policy's success from 1 mm off at the runs' step and at a finer one."""
    methods = ["bilevel/deepest_explored", "bilevel/explored_argmin", "one_level"]
    return pd.DataFrame(
        {
            "method": methods * 2,
            "time_step_s": [5e-4] * 3 + [6.25e-5] * 3,
            "start_std_m": 0.001,
            "phase": "deploy",
            "runs": [10, 10, 10, runs, runs, runs],
            "deploy_success_rate": [0.8, 0.55, 0.25, 0.8, 0.5, 0.2],
            "deploy_ci_low": [0.5, 0.3, 0.1, 0.5, 0.25, 0.05],
            "deploy_ci_high": [0.95, 0.8, 0.6, 0.95, 0.75, 0.5],
        }
    )


def test_the_headline_at_a_finer_step_stands_beside_the_runs_own():
    """With the trials replayed at a finer step, the headline column names its step and the
    replayed one follows it; replays of only some runs are said, not shown as a rate."""
    rows = planning_rows(_success(), _robustness(), _time_step()).set_index("method")
    columns = rows.columns.tolist()
    at_coarse, at_fine = "from starts 1 mm off, at 0.5 ms", "from starts 1 mm off, at 0.0625 ms"
    assert columns.index(at_coarse) + 1 == columns.index(at_fine)
    assert rows[at_coarse].tolist() == ["0.80 (0.50–0.95)", "0.55 (0.30–0.80)", "0.25 (0.10–0.60)"]
    assert rows[at_fine].tolist() == ["0.80 (0.50–0.95)", "0.50 (0.25–0.75)", "0.20 (0.05–0.50)"]
    partial = planning_rows(_success(), _robustness(), _time_step(runs=6))
    assert set(partial[at_fine]) == {"— (6 of 10 runs replayed)"}
    # The pairs at each step, a row a pair: the runs' own from the offset starts' rows, the
    # replayed step's from its pooled rows; a pair whose runs were not all replayed is a dash.
    pair = {"pairs": 10, "better": 9, "worse": 1, "tied": 0, "sign_test_p": 0.0215}
    pair |= {
        "tied_at_ceiling": 0,
        "mean_difference": 0.4,
        "difference_ci_low": 0.2,
        "difference_ci_high": 0.6,
        "least_possible_p": 0.00195,
        "detectable_difference": 0.3,
    }
    fewer = {**pair, "pairs": 6, "better": 6, "worse": 0, "sign_test_p": 0.0312}
    fewer |= {"least_possible_p": 0.0312, "mean_difference": -0.05, "difference_ci_low": -0.1}
    paired = pd.DataFrame(
        [
            {"method": "a", "versus": versus, "dimension": "time_step_s", "level": level, **p}
            for versus, level, p in (
                ("one_level", "training start at 0.0005 s", pair),
                ("one_level", "starts 0.001 m off at 0.0005 s", pair),
                ("one_level", "starts 0.001 m off at 6.25e-05 s", {**pair, "better": 8, "tied": 1}),
                ("one_level", "starts 0.001 m off at 6.25e-05 s, friction = 0.3", pair),
                ("one_level", "starts 0.003 m off at 6.25e-05 s", pair),
                ("b", "starts 0.001 m off at 6.25e-05 s", fewer),
            )
        ]
        + [
            {"method": "a", "versus": versus, "dimension": "start_std_m", "level": "0.001", **pair}
            for versus in ("one_level", "b")
        ]
    )
    pairs = step_pairs(paired, _robustness())
    assert pairs.columns.tolist() == [
        "method",
        "versus",
        "pairs",
        "at 0.5 ms: better / worse / tied",
        "difference at 0.5 ms (95 % CI)",
        "p at 0.5 ms (least possible)",
        "tied at the ceiling at 0.5 ms",
        "detectable at 0.5 ms",
        "at 0.0625 ms: better / worse / tied",
        "difference at 0.0625 ms (95 % CI)",
        "p at 0.0625 ms (least possible)",
    ]
    at_both = ["9 / 1 / 0", "+0.40 (+0.20 to +0.60)", "0.0215 (0.00195)"]
    assert pairs.values.tolist() == [
        ["a", "one_level", 10, *at_both, 0, "0.30", "8 / 1 / 1", *at_both[1:]],
        ["a", "b", 10, *at_both, 0, "0.30", "—", "—", "—"],
    ]
    # With a compared dimension (its levels do not pool): a row a pair and level, each step's
    # counts from the time-step rows of that level.
    per_level = pd.DataFrame(
        [
            {"method": "a", "versus": "one_level", "dimension": "time_step_s", "level": level, **p}
            for level, p in (
                ("starts 0.001 m off at 0.0005 s, friction = 0.3", pair),
                ("starts 0.001 m off at 0.0005 s, friction = 0.5", fewer),
                (
                    "starts 0.001 m off at 6.25e-05 s, friction = 0.3",
                    {**pair, "better": 8, "tied": 1},
                ),
                ("starts 0.001 m off at 6.25e-05 s, friction = 0.5", fewer),
                ("starts 0.001 m off at 0.0005 s", pair),  # pooled over the levels: not shown
            )
        ]
        + [
            {"method": "a", "versus": "one_level", "dimension": "friction", **p}
            for p in ({"level": "0.3, starts 0.001 m off", **pair},)
        ]
    )
    pairs = step_pairs(per_level, _robustness())
    assert pairs.columns.tolist()[:4] == ["level", "method", "versus", "pairs"]
    six = ["6 / 0 / 0", "-0.05 (-0.10 to +0.60)", "0.0312 (0.0312)"]
    assert pairs.drop(columns=["method", "versus"]).values.tolist() == [
        ["friction = 0.3", 10, *at_both, 0, "0.30", "8 / 1 / 1", *at_both[1:]],
        ["friction = 0.5", 6, *six, 0, "0.30", *six],
    ]


def test_summary_names_the_code_version_and_links_the_tables():
    variants = _comparison().assign(chosen=False, max_rel_err_pct=np.nan)
    paired = pd.DataFrame(
        {
            "method": ["bilevel/deepest_explored", "bilevel/deepest_explored"],
            "dimension": ["all", "variant"],
            "level": ["all", "paper"],
            "versus": ["one_level", "one_level"],
            "pairs": [12, 6],
            "better": [12, 6],
            "worse": [0, 0],
            "tied": [0, 0],
            "mean_difference": [0.89, 0.9],
            "sign_test_p": [0.000488, 0.03125],
            "tied_at_ceiling": [0, 0],
            "difference_ci_low": [0.8, 0.8],
            "difference_ci_high": [0.95, 0.95],
            "least_possible_p": [0.000488, 0.03125],
            "detectable_difference": [0.1, 0.2],
        }
    )
    paired = pd.concat(
        [
            paired,
            paired.iloc[:1].assign(
                dimension="start_std_m", level="0.001", better=7, worse=2, tied=3, sign_test_p=0.18
            ),
        ]
    )
    study = {
        "config_files": ["config/config.yaml", "config/smoke.yaml"],
        "default": False,
        "iterations": 3,
        "rollouts_per_iteration": 4,
        "deploy_trials": 2,
        "planning_runs": 6,
    }

    def summary(links: dict[str, str], about: dict) -> str:
        return summary_markdown(
            _comparison(), variants, _success(), paired, _robustness(), "abc123", links, about
        )

    text = summary({"success": "planning/s.md"}, study)
    offset = (
        "| bilevel/deepest_explored | one_level | 12 | 7 / 2 / 3 | 0 | +0.89 (+0.80 to +0.95) |"
    )
    assert f"{offset} 0.18 (0.000488) | 0.10 |" in text
    nominal = (
        "| bilevel/deepest_explored | one_level | 12 | 12 / 0 / 0 | 0 | +0.89 (+0.80 to +0.95) |"
    )
    assert nominal in text
    assert text.index("| 7 / 2 / 3 |") < text.index("| 12 / 0 / 0 |")  # offset starts first
    assert "0.03125" not in text  # only the overall comparison
    assert "`abc123`" in text
    assert "`config/config.yaml`, `config/smoke.yaml`; budget 3 iterations × 4 rollouts" in text
    assert "6 planning runs" in text and "Not the default study" in text
    assert "Not the default study" not in summary({}, study | {"default": True})
    assert "- [success](planning/s.md)" in text
    assert text.index("Would the learned policy insert") < text.index("Whitney")
    # Every σ the text shows names the key it comes from: the runs' own offset deployment
    # (the smoke study's 0.5 mm) or a redeployment's; the model errors' from starts 1 mm off.
    assert "N(0, (1 mm)²) in x and y (`robustness.start_std_m`)" in text
    own = _robustness().assign(start_std_m=[0.0005, 0.0005, 0.0005, 0.001])
    errors = _robustness().iloc[:1].assign(start_std_m=0.001, model_error="friction_0_5")
    robustness = pd.concat([own.assign(model_error="none"), errors], ignore_index=True)
    paired_errors = paired.iloc[:1].assign(dimension="model_error", level="friction_0_5")
    smoke = summary_markdown(
        _comparison(),
        variants,
        _success(),
        pd.concat([paired, paired_errors]),
        robustness,
        "abc123",
        {},
        study | {"deploy_start_std_m": 0.0005},
    )
    assert "N(0, (0.5 mm)²) in x and y (`planner.deploy_start_std_m`)" in smoke
    assert "(`robustness.model_error`), from starts 1 mm off (the smallest" in " ".join(
        smoke.split()
    )


def test_summary_reads_the_first_hydroelastic_variant_and_lists_the_rules_choices():
    two = pd.concat([_comparison().assign(variant="hydroelastic_b", r_f_x=0.1), _comparison()])
    assert pearson_table(two)["ours"].tolist()[0] == 0.1  # the first hydroelastic variant only
    variants = _comparison().assign(
        chosen=lambda t: (t["offset"] == "pooled") & (t["alignment"] == "chamfer_start"),
        max_rel_err_pct=4.0,
    )
    chosen = chosen_variants(variants)
    assert chosen["variant"].tolist() == ["hydroelastic", "point"]
    assert chosen["r(F_x) (1)"].tolist() == [0.98, 0.5]


def test_the_model_error_table_splits_by_a_swept_scene_key_with_pairs_per_level():
    """A sweep over ``scene.material.friction`` (a new dimension, as a user adds one): each
    (model error, method) row once per friction level, labelled with it, beside that level's
    deployment without the error, with the pairs against one-level at that level only."""
    from pih.analysis.aggregate import robustness_pairs, robustness_table
    from pih.reporting.summary import model_error_rows

    keys = ["planner.goal", "planner.start_x_m", "scene.material.friction"]
    rows = []
    for friction, ours_rate in (("0.3", 1.0), ("0.6", 0.0)):
        for start in ("-0.04", "-0.03"):
            for method, rate in (("bilevel/deepest_explored", ours_rate), ("one_level", 0.5)):
                for error in ("none", "hole_left"):
                    rows.append(
                        {
                            "method": method,
                            "run": f"{method}{friction}{start}",
                            "planner.start_x_m": start,
                            "scene.material.friction": friction,
                            "start_std_m": 0.001,
                            "model_error": error,
                            "deploy_success_rate": rate if error == "none" else rate / 2,
                        }
                    )
    deployments = pd.DataFrame(rows)
    table = model_error_rows(
        robustness_table(deployments, keys), robustness_pairs(deployments, keys)
    ).set_index(["level", "method"])
    assert len(table) == 4 and (table["dimension"] == "scene.material.friction").all()
    ours = "bilevel/deepest_explored"
    assert (table["runs"] == 2).all()
    assert table.loc[("0.3", ours), "without it"].startswith("1.00 ")
    assert table.loc[("0.6", ours), "without it"].startswith("0.00 ")
    pairs = "vs one-level: better / worse / tied"
    assert table.loc[("0.3", ours), pairs] == "2 / 0 / 0"
    assert table.loc[("0.6", ours), pairs] == "0 / 2 / 0"


def test_the_reports_pages_render_the_summarys_markdown():
    """The report shows results/summary.md as HTML (workflow/report/report_tables.py): its
    block quote (the note that a study is not the default one) renders as one, not as a literal
    "> **...**", and a wide table sits in a box that scrolls sideways."""
    import importlib.util

    path = Path(__file__).resolve().parents[1] / "workflow" / "report" / "report_tables.py"
    spec = importlib.util.spec_from_file_location("report_tables", path)
    tables = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(tables)
    header = study_header(
        {
            "config_files": ["config/config.yaml", "config/smoke.yaml"],
            "default": False,
            "iterations": 3,
            "rollouts_per_iteration": 4,
            "planning_runs": 6,
            "deploy_trials": 2,
        },
        "abc123",
    )
    wide = "| " + " | ".join(f"column {k}" for k in range(30)) + " |"
    rule = "|" + "---|" * 30
    html = tables.page("summary", "", f"# pih\n\n{header}\n\n{wide}\n{rule}\n")
    assert "<blockquote><p><strong>Not the default study</strong>" in html
    assert "&gt;" not in html
    assert '<div class="scroll"><table>' in html and "overflow-x: auto" in html
