"""The step check (benchmarks/step_convergence.py): its set, its fine-step reference and the
paired signs it keeps (docs/simulation.md)."""

import importlib.util
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from pih.planning.run_record import RecordedRun
from pih.publishing.published import PUBLISHED_STUDIES
from pih.records.outputs import read_provenance, write_table
from pih.records.provenance import record

ROOT = Path(__file__).resolve().parents[1]
PAPER_DIR = PUBLISHED_STUDIES["paper"].directory


@pytest.fixture(scope="module")
def step_convergence():
    spec = importlib.util.spec_from_file_location(
        "step_convergence", ROOT / "benchmarks" / "step_convergence.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.skipif(not (ROOT / PAPER_DIR).is_dir(), reason="no published paper-scale study here")
def test_the_step_convergence_set_draws_from_the_published_runs(step_convergence):
    """``benchmarks/step_convergence.py --draw-from`` reads today's run records (it broke
    silently when ``planner.goal`` replaced method and rule): an equal share per method, each
    rollout a late training rollout of its run, drawn the same way twice; the committed set is
    that draw."""
    module = step_convergence
    runs = step_convergence.step_runs(ROOT)
    assert len(runs) == 3 * len(module.STEP_STARTS)  # the three methods at every step start
    drawn = module.draw_set(runs)
    assert drawn["method"].value_counts().to_dict() == {
        "deepest_explored": 80,
        "explored_argmin": 80,
        "one_level": 80,
    }
    iterations = pd.read_parquet(runs[0])["iteration"].max()
    assert (drawn["iteration"] > iterations / 2).all()
    assert drawn.equals(module.draw_set(runs))
    committed, planner = module.read_set(module.SET_PATH)
    assert committed.equals(drawn)  # the committed set is the published study's draw
    assert planner == RecordedRun.read(runs[0]).planner


@pytest.mark.skipif(not (ROOT / PAPER_DIR).is_dir(), reason="no published paper-scale study here")
def test_the_step_check_replays_the_deployment_trials_the_headline_counts(step_convergence):
    """The deployments part of the check: every published paper-scale run's deployed policy,
    from the training start and from the offset starts, 10 trials each, beside its outcome at
    the reference step as the run's replay file holds it."""
    from pih.study.replay_record import replay_name

    trials = step_convergence.deployment_reference(ROOT)
    runs = sorted((ROOT / PAPER_DIR / "planning").glob("*/rollouts.parquet"))
    assert trials["run"].nunique() == len(runs) == 33
    per_run = trials.groupby(["run", "source"]).size()
    assert set(per_run.index.get_level_values("source")) == {
        "training start",
        "start_std_m~0.001",
    }
    assert (per_run == 10).all() and len(per_run) == 2 * len(runs)
    assert trials.groupby("point")["method"].nunique().eq(3).all()  # every point pairs 3 methods
    nominal = trials[trials["source"] == "training start"].groupby("run")["start_x_m"].first()
    offset = trials[trials["source"] != "training start"]
    assert (offset["start_x_m"] != offset["run"].map(nominal)).all()
    # The outcomes are the replay's, not the recorded ones.
    name = replay_name(step_convergence.REFERENCE_STEP_S)
    replays = pd.concat(pd.read_parquet(p.parent / name).query("phase == 'deploy'") for p in runs)
    assert trials["inserted"].tolist() == replays["inserted"].tolist()
    assert (replays["inserted"] != replays["recorded_inserted"]).any()


def test_the_check_refuses_missing_replays_in_one_line(step_convergence, tmp_path):
    """Without every run's replay at the reference, the check stops before replaying anything."""
    run = tmp_path / PAPER_DIR / "planning" / "start_x_m~-0.04_goal~sensed_hole_seed~0"
    run.mkdir(parents=True)
    (run / "rollouts.parquet").write_bytes(b"")
    with pytest.raises(SystemExit, match=r"1 of 1 runs have no replay_time_step_s~6\.25e-05"):
        step_convergence.deployment_reference(tmp_path)


def test_paired_signs_are_per_point_source_and_rule(step_convergence):
    """sign(rule − one-level) of the success rate, one per (point, source, rule); a tie is 0."""
    rows = pd.DataFrame(
        [
            (point, source, method)
            for point in ("a", "b")
            for source in ("training start", "offset")
            for method in ("one_level", "ours", "paper")
            for _ in range(2)
        ],
        columns=["point", "source", "method"],
    )
    # Point a: ours beats one-level everywhere, the paper's rule ties; point b: the reverse.
    wins = {("a", "ours"): [1, 1], ("a", "one_level"): [0, 1], ("a", "paper"): [1, 0]}
    wins |= {("b", "ours"): [0, 0], ("b", "one_level"): [1, 0], ("b", "paper"): [1, 1]}
    inserted = np.concatenate(
        [wins[p, m] for p, _, m in rows[::2].itertuples(index=False, name=None)]
    ).astype(bool)
    signs = step_convergence.paired_signs(rows, inserted)
    assert len(signs) == 2 * 2 * 2
    assert signs["a", "offset", "ours"] == 1 and signs["a", "offset", "paper"] == 0
    assert signs["b", "training start", "ours"] == -1
    assert signs["b", "training start", "paper"] == 1


def test_a_reference_made_by_another_drake_is_refused(step_convergence, tmp_path, monkeypatch):
    """The reference stands for one Drake's physics: another Drake's is refused in one line
    naming the file and both versions, before any replay."""
    path = tmp_path / "reference.parquet"
    provenance = record("step_reference_set", config={"planner": {}})
    provenance["packages"]["drake"] = "1.51.1"
    write_table(pd.DataFrame({"inserted": [True]}), path, provenance, {"inserted": ("1", "x")})
    monkeypatch.setitem(step_convergence.REFERENCE_PATHS, "set", path)
    with pytest.raises(SystemExit, match=r"reference.parquet: made by Drake 1\.51\.1, not 1\.58"):
        step_convergence.read_reference()


def test_the_check_names_what_the_setting_changes(step_convergence):
    """The check prints every scene key a lever changes against the reference's scene."""
    from pih.config import to_mapping
    from pih.scene.config import SceneConfig

    scene = SceneConfig()
    reference = to_mapping(step_convergence.at_step(scene, step_convergence.REFERENCE_STEP_S))
    setting = step_convergence.overridden(scene, ["scene.hole.fillet_facets=5"])
    assert sorted(step_convergence.scene_differences(to_mapping(setting), reference)) == [
        "hole.fillet_facets=5 (reference 9)",
        f"solver.retry_time_step_s={scene.solver.retry_time_step_s} (reference 3.125e-05)",
        f"solver.time_step_s={scene.solver.time_step_s} (reference 6.25e-05)",
    ]


def test_the_committed_reference_is_the_set(step_convergence):
    """The committed reference replays exactly the committed set's rollouts, at the reference
    step, under this Drake."""
    path = step_convergence.REFERENCE_PATHS["set"]
    reference, planner = step_convergence.read_reference()
    provenance = read_provenance(path)
    assert provenance["simulator"]["time_step_s"] == step_convergence.REFERENCE_STEP_S
    assert provenance["config"]["scene"]["solver"]["time_step_s"] == 6.25e-5
    rows, set_planner = step_convergence.read_set(step_convergence.SET_PATH)
    assert set_planner == planner
    assert (reference["varies"] | reference["confirmed"]).all()
    keys = [c for c in rows.columns if c != "weights"]
    pd.testing.assert_frame_equal(reference[keys], rows[keys])
    assert all(np.array_equal(a, b) for a, b in zip(reference["weights"], rows["weights"]))
