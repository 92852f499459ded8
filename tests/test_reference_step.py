"""The deployment trials replayed at the step check's reference step (issue 68): the replay
files of ``published/paper``, pooled into the study's tables beside the trials at the runs' own
step, and refused when they would mix parts of different physics or replay other data."""

import shutil
from pathlib import Path

import pandas as pd
import pyarrow.parquet as pq
import pytest

from pih.analysis.pooling import find_outputs, pool
from pih.analysis.time_step import replay_rates, time_step_pairs, time_step_table
from pih.config import ConfigError
from pih.publishing.published import PUBLISHED_STUDIES
from pih.publishing.reference_step import REFERENCE_STEP_S
from pih.records.outputs import read_provenance, write_table
from pih.study.replay_record import COLUMNS, replay_name

ROOT = Path(__file__).resolve().parents[1]
PLANNING = ROOT / PUBLISHED_STUDIES["paper"].directory / "planning"
NAME = replay_name(REFERENCE_STEP_S)
POINT = "start_x_m~-0.034"  # one-level flips most here: 6 of its 20 deployed trials


def _replayed_point(tmp_path: Path, point: str = POINT) -> Path:
    """The three methods' published runs at one start, with their replays, copied."""
    runs = sorted(PLANNING.glob(f"{point}_goal~*_seed~0"))
    if len(runs) != 3 or not all((run / NAME).is_file() for run in runs):
        pytest.skip(f"the published replays at {point} are not all here")
    for run in runs:
        shutil.copytree(run, tmp_path / run.name)
    return tmp_path


def test_replay_rates_count_each_step_start_and_policy():
    """A run's rates at its own step come from the recorded outcomes and at the replay's from
    the replayed ones; a flip counts at the replay's step only; a replay at the run's own step
    gives its rows once."""
    replay = pd.DataFrame(
        {
            "source": ["training start"] * 4 + ["start_std_m~0.001"] * 2,
            "phase": ["deploy", "deploy", "deploy_final_mean", "deploy_final_mean"]
            + ["deploy"] * 2,
            "recorded_inserted": [True, True, False, True, True, False],
            "inserted": [True, False, False, True, True, True],
        }
    )
    replay["flipped"] = replay["inserted"] != replay["recorded_inserted"]
    rates = replay_rates(replay, 6.25e-5, 5e-4, 0.0)
    rates = rates.set_index(["time_step_s", "start_std_m", "phase"])
    assert rates.loc[(5e-4, 0.0, "deploy"), "deploy_success_rate"] == 1.0
    assert rates.loc[(6.25e-5, 0.0, "deploy"), "deploy_success_rate"] == 0.5
    assert rates.loc[(6.25e-5, 0.001, "deploy"), "deploy_success_rate"] == 1.0
    assert rates.loc[(6.25e-5, 0.001, "deploy"), "flipped_trials"] == 1
    assert rates.xs(5e-4)["flipped_trials"].sum() == 0
    assert len(replay_rates(replay, 5e-4, 5e-4, 0.0)) == 3
    # A run deployed from offset starts itself: its own trials are at its std.
    assert set(replay_rates(replay, 6.25e-5, 5e-4, 5e-4)["start_std_m"]) == {5e-4, 0.001}


def test_the_published_replays_pool_beside_the_runs_own_trials(tmp_path):
    """Pooled, each run's trials at its own step, as the replay file recorded them, are the ones
    the study's robustness table counts; the table at the reference step differs only where
    trials flipped; the pairs at both steps join the paired table."""
    from pih.analysis.aggregate import planning_tables
    from pih.analysis.time_step import with_time_step

    pooled = pool(*find_outputs([_replayed_point(tmp_path)]))
    assert len(pooled.replays) == 3 * 2 * 2 * 2  # runs x steps x starts x policies
    recorded = pooled.replays[pooled.replays["time_step_s"] == 5e-4]
    deployed = recorded[recorded["phase"] == "deploy"].set_index(["run", "start_std_m"])
    trained = pooled.deployments[pooled.deployments["model_error"] == "none"]
    counted = trained.set_index(["run", "start_std_m"])["deploy_success_rate"]
    pd.testing.assert_series_equal(
        deployed["deploy_success_rate"], counted.loc[deployed.index], check_names=False
    )
    keys = pooled.sweep_keys
    table = time_step_table(pooled.replays, keys)
    fine = table[table["time_step_s"] == REFERENCE_STEP_S].set_index(["method", "start_std_m"])
    coarse = table[table["time_step_s"] == 5e-4].set_index(["method", "start_std_m"])
    fine, coarse = (t[t["phase"] == "deploy"] for t in (fine, coarse))
    moved = fine["deploy_success_rate"] != coarse.loc[fine.index, "deploy_success_rate"]
    assert (moved == (fine["flipped_trials"] > 0)).all()
    assert fine.loc[("one_level", 0.0), "flipped_trials"] > 0  # the point flips one-level trials
    pairs = time_step_pairs(pooled.replays, keys)
    assert set(pairs["level"]) == {
        f"{start} at {step:g} s"
        for step in (5e-4, REFERENCE_STEP_S)
        for start in ("training start", "starts 0.001 m off")
    }
    tables = with_time_step(
        planning_tables(pooled.runs, pooled.summaries, pooled.deployments, keys),
        pooled.replays,
        keys,
    )
    assert tables.paired[tables.paired["dimension"] == "time_step_s"].equals(
        pairs.set_axis(tables.paired.index[-len(pairs) :])
    )


def _rewrite(path: Path, change) -> None:
    provenance = read_provenance(path)
    change(provenance)
    write_table(pd.read_parquet(path), path, provenance, COLUMNS)


def test_replays_of_other_physics_or_other_data_are_never_mixed(tmp_path):
    """Parts of one replay must share Drake, and rollout code unless each is verified current;
    a replay of data its run no longer holds is refused; each in one line naming the file."""
    planning = _replayed_point(tmp_path)
    replays = sorted(planning.glob(f"*/{NAME}"))
    other_drake = replays[-1]

    def drake(p):
        p["packages"]["drake"] = "0.0.0"

    _rewrite(other_drake, drake)
    with pytest.raises(ConfigError, match=rf"{NAME}: replayed by Drake 0\.0\.0, but .* by 1\.58"):
        pool(*find_outputs([planning]))
    _rewrite(
        other_drake,
        lambda p: p["packages"].update(drake=read_provenance(replays[0])["packages"]["drake"]),
    )

    codes = [read_provenance(replays[0])["rollout_code_sha256"], "f" * 64]

    def code(p):
        p["rollout_code_sha256"] = codes[1]

    _rewrite(other_drake, code)
    with pytest.raises(ConfigError, match="neither is verified equivalent"):
        pool(*find_outputs([planning]))
    assert len(pool(*find_outputs([planning]), current_codes=frozenset(codes)).replays) == 24

    redeployed = other_drake.parent / "redeploy_start_std_m~0.001.parquet"
    pq.write_table(pq.read_table(redeployed).slice(0, 5), redeployed)  # provenance kept
    with pytest.raises(
        ConfigError, match=r"replays .*redeploy_start_std_m~0\.001\.parquet as it was"
    ):
        pool(*find_outputs([planning]), current_codes=frozenset(codes))


def test_tables_without_replays_leave_no_time_step_table_behind(tmp_path):
    """Re-made after its replays are gone, a study's summary holds no time-step table from
    before: it would report replays the tables no longer pool."""
    import shutil

    from pih.analysis.pooling import find_outputs, pool
    from pih.reporting.planning_summary import write_pooled_summary

    run = min(PLANNING.glob("start_x_m~-0.04_goal~*_seed~0"))
    copy = tmp_path / "planning" / run.name
    shutil.copytree(run, copy)
    summary = tmp_path / "planning" / "summary"
    write_pooled_summary(pool(*find_outputs([tmp_path / "planning"])), summary)
    assert (summary / "time_step.parquet").is_file() and (summary / "time_step.md").is_file()
    for replay in copy.glob("replay_*.parquet"):
        replay.unlink()
    write_pooled_summary(pool(*find_outputs([tmp_path / "planning"])), summary)
    assert not (summary / "time_step.parquet").exists() and not (summary / "time_step.md").exists()
