"""Pooling planning runs from several studies' result directories into one set of tables
(``pih aggregate``): each distinct training counted once, with its deployments at every start
std gathered from its own records, its twins' (the same training recorded at another
``planner.deploy_start_std_m``) and its redeployments. Runs pool only when nothing but their sweep
levels tells them apart, and pair only when they share their random draws. docs/planner.md,
"Pooling studies".
"""

from __future__ import annotations

import fnmatch
import itertools
import math
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any

import pandas as pd

from pih.analysis.run_summary import (
    NO_MODEL_ERROR,
    model_error_name,
    model_error_settings,
    on_simulator,
    run_tables,
    split_keys,
    variant,
)
from pih.analysis.time_step import replay_rates
from pih.config import ConfigError, recorded_config, to_mapping
from pih.planning.config import OuterConfig, is_one_level, recorded_planner, replace
from pih.planning.run_record import DEPLOYMENT_PHASES, Phase, phase_rows
from pih.records.outputs import read_provenance
from pih.records.provenance import canonical_json, input_sha256
from pih.scene.config import SceneConfig
from pih.study import replay_record
from pih.study.points import GOAL_KEY, OUTER_PREFIX, VARIANT_KEY, is_method_key, upgraded_point

DEPLOY_STD_KEY = "planner.deploy_start_std_m"
REDEPLOY_PATTERNS = ("redeploy_start_std_m~*.parquet", "redeploy_model_error~*.parquet")
LABEL_KEYS = (GOAL_KEY,)
"""Keys the method label (:func:`pih.analysis.run_summary.variant`) shows, so runs may differ in them."""


def _provenance(path: Path, step: str) -> dict[str, Any]:
    try:
        record = read_provenance(path)
    except Exception as error:  # any unreadable file: say which
        raise ConfigError(f"{path}: not a pih output with provenance ({error})") from error
    if record.get("step") != step:
        raise ConfigError(f"{path}: not a {step} output (its step is {record.get('step')!r})")
    return record


@dataclass(frozen=True)
class RunRecord:
    """One ``rollouts.parquet``: its method, its settings as one flat mapping (keys the run
    predates read as their defaults; a one-level run's outer level, which it ignores, as the
    defaults) and the training it shares with its copies and twins."""

    path: Path
    record: dict[str, Any]
    method: str
    settings: dict[str, Any]
    start_std_m: float
    training: str
    one_level: bool
    """whether the run plans one-level (it ignores planner.outer)"""

    @classmethod
    def read(cls, path: Path) -> RunRecord:
        record = _provenance(path, "plan")
        config = record["config"]
        scene = recorded_config(SceneConfig, config, "scene")
        planner = recorded_planner(config)
        if is_one_level(planner.goal):
            planner = replace(planner, outer=OuterConfig())
        settings = _flat({"scene": to_mapping(scene), "planner": to_mapping(planner)})
        undeployed = to_mapping(replace(planner, deploy_start_std_m=0.0))
        training = canonical_json(
            {"scene": to_mapping(scene), "planner": undeployed, "seed_key": record["seed_key"]}
        )
        method = variant(to_mapping(planner))
        one_level = is_one_level(planner.goal)
        return cls(path, record, method, settings, planner.deploy_start_std_m, training, one_level)

    @property
    def seed_key(self) -> str:
        return self.record["seed_key"]

    @cached_property
    def sha256(self) -> str:
        return input_sha256(self.path)

    def level(self, key: str) -> Any:
        """The run's level of a sweep key: its config's value, or its sweep point's (for keys
        that are not config paths, such as ``variant``)."""
        if key in self.settings:
            return self.settings[key]
        point = upgraded_point(self.record["sweep_point"])
        if key in point:
            return point[key]
        raise ConfigError(
            f"{self.path}: no level for sweep key {key!r} (neither in its sweep point nor in its "
            "config); pool runs of studies that share their sweep dimensions"
        )

    @cached_property
    def _decisive_rows(self) -> pd.DataFrame:
        columns = ["phase", "cost", "success", "final_bottom_x_m", "final_bottom_y_m"]
        return pd.read_parquet(self.path, columns=columns)

    def rows(self, phases: tuple[Phase, ...]) -> pd.DataFrame:
        """The rollouts of these phases, as much of them as decides the pooled tables (read
        once per file)."""
        rollouts = self._decisive_rows
        return rollouts[rollouts["phase"].isin([p.value for p in phases])].reset_index(drop=True)


def _flat(mapping: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    flat: dict[str, Any] = {}
    for key, value in mapping.items():
        if isinstance(value, Mapping):
            flat |= _flat(value, f"{prefix}{key}.")
        else:
            flat[f"{prefix}{key}"] = value
    return flat


def find_outputs(paths: Iterable[str | Path]) -> tuple[list[Path], list[Path], list[Path]]:
    """The planning runs (``rollouts.parquet``), the redeployment rules' files and the replay
    files (:mod:`pih.study.replay_record`) under each directory; a file given itself is a run
    (``rollouts.parquet``), a replay file or a redeployment file (the rule's, or ``pih redeploy
    --output``'s)."""
    runs, redeployments, replays = [], [], []
    for path in map(Path, paths):
        if path.is_dir():
            runs += sorted(path.rglob("rollouts.parquet"))
            redeployments += sorted(f for p in REDEPLOY_PATTERNS for f in path.rglob(p))
            replays += sorted(path.rglob(replay_record.PATTERN))
        elif path.name == "rollouts.parquet":
            runs.append(path)
        elif fnmatch.fnmatch(path.name, replay_record.PATTERN) and path.is_file():
            replays.append(path)
        elif path.is_file():
            redeployments.append(path)
        else:
            raise ConfigError(f"{path}: no such file or directory")
    if not runs:
        raise ConfigError(f"no planning runs (rollouts.parquet) under {[str(p) for p in paths]}")
    return runs, redeployments, replays


@dataclass
class PooledRuns:
    """What :func:`pool` gathers: the sweep keys, one best-cost table and one summary row per
    training (deployed at the headline start std), every deployment at every std, its
    deployment trials' success at their own step and at each replay's
    (:func:`pih.analysis.time_step.replay_rates` rows; empty without replays), and where each
    training's rows came from. A training's ``run`` is its headline record's directory."""

    sweep_keys: list[str]
    runs: pd.DataFrame
    summaries: pd.DataFrame
    deployments: pd.DataFrame
    sources: pd.DataFrame
    replays: pd.DataFrame


def pool(
    run_files: list[Path],
    redeploy_files: list[Path],
    replay_files: Sequence[Path] = (),
    current_codes: frozenset[str] = frozenset(),
) -> PooledRuns:
    """Pool planning runs. Records of one training (same settings but the deployment std, same
    seed key) must agree in every training rollout and count once; each training's headline
    record is at the smallest std at which every training has a record; runs may differ only in
    their sweep levels; runs at the same levels but the method's must share their draws (and
    only those). Redeployments and replays attach to the run they redeployed or replayed, found
    by its data's hash and its directory (the sweep point); the replays at one step must share
    their Drake and their rollout code, or each be of code in ``current_codes`` (today's and
    what it was verified equivalent to), and replay the files beside their run."""
    # In path order, so that which copy heads a training does not depend on the arguments' order.
    records = sorted((RunRecord.read(path) for path in run_files), key=lambda run: str(run.path))
    swept = {k for run in records for k in upgraded_point(run.record["sweep_point"])}
    # Sorted: the tables' columns and joint level labels must not depend on where the pooled
    # trees lie (pih compare pools a fresh run in /tmp with published studies).
    keys = sorted(k for k in swept if k != DEPLOY_STD_KEY)
    trainings: dict[str, list[RunRecord]] = {}
    for run in records:
        trainings.setdefault(run.training, []).append(run)
    for group in trainings.values():
        _check_same_training(group)
    std = _headline_std(trainings)
    headline = {t: next(r for r in group if r.start_std_m == std) for t, group in trainings.items()}
    chosen = list(headline.values())
    _check_settings(chosen, keys)
    _check_distinct_levels(chosen, keys)
    _check_draws(chosen, keys)

    name = {t: str(run.path.parent) for t, run in headline.items()}
    tags = {
        run.path: {"run": name[t], **{k: run.level(k) for k in split_keys(keys)}}
        for t, run in headline.items()
    }
    runs, summaries = run_tables(list(tags), keys, tags)
    deployments, sources = [summaries], []
    for training, group in trainings.items():
        lead = headline[training]
        for run in group:
            role = "summary" if run is lead else "copy" if run.start_std_m == std else "deployment"
            sources.append(_source(run.path, name[training], run.start_std_m, role))
            if role == "deployment":
                rate = _deploy_rate(pd.read_parquet(run.path, columns=["phase", "success"]))
                deployments.append(_deployment(lead, keys, name[training], run.start_std_m, rate))
    by_hash: dict[str, list[RunRecord]] = {}
    for run in records if redeploy_files or replay_files else []:
        by_hash.setdefault(run.sha256, []).append(run)
    for path in redeploy_files:
        for source, redeployed_std, error, settings, rate in _redeployments(path):
            run = _redeployed_run(by_hash.get(source[1], []), Path(source[0])) or _outside_run(
                path, *source
            )
            if run.training not in headline:
                raise ConfigError(f"{path}: redeploys {run.path}, not one of the pooled trainings")
            lead = headline[run.training]
            deployments.append(
                _deployment(lead, keys, name[run.training], redeployed_std, rate, error, settings)
            )
            sources.append(_source(path, name[run.training], redeployed_std, "redeployment"))
    replays, replay_records = [], []
    for path in replay_files:
        record, source = _replay_source(path)
        run = _redeployed_run(by_hash.get(source[1], []), Path(source[0])) or _outside_run(
            path, *source
        )
        if run.training not in headline:
            raise ConfigError(f"{path}: replays {run.path}, not one of the pooled trainings")
        lead = headline[run.training]
        rates = replay_rates(
            pd.read_parquet(path),
            record["simulator"]["time_step_s"],
            run.settings["scene.solver.time_step_s"],
            run.start_std_m,
        )
        levels = {key: str(lead.level(key)) for key in split_keys(keys)}
        replays.append(rates.assign(method=lead.method, run=name[run.training], **levels))
        replay_records.append((path, record))
        sources.append(_source(path, name[run.training], math.nan, "replay"))
    _check_replay_parts(replay_records, current_codes)
    deployments = pd.concat(deployments, ignore_index=True)
    # The runs' own deployments (``summaries``) are on the scene they trained on.
    if "hole_shift_m" in deployments:
        trained = deployments["model_error"].isna()
        deployments["hole_shift_m"] = deployments["hole_shift_m"].mask(trained, 0.0)
    else:
        deployments["hole_shift_m"] = 0.0
    # A training at the same std more than once (a redeployment at a recorded std) counts once:
    # deployment is deterministic given the training and the std.
    deployments = deployments.drop_duplicates(
        ["run", "start_std_m", "model_error"], ignore_index=True
    )
    replayed = pd.concat(replays, ignore_index=True) if replays else pd.DataFrame()
    return PooledRuns(keys, runs, summaries, deployments, pd.DataFrame(sources), replayed)


def _replay_source(path: Path) -> tuple[dict[str, Any], tuple[str, str]]:
    """A replay file's provenance and (the replayed run's recorded path, its data's sha256);
    refused when a file it replayed no longer holds, beside it, the data it replayed."""
    record = _provenance(path, replay_record.STEP)
    for recorded, sha256 in record["inputs"].items():
        beside = path.parent / Path(recorded).name
        if not beside.is_file() or input_sha256(beside) != sha256:
            raise ConfigError(f"{path}: replays {recorded} as it was, not the {beside} beside it")
    runs = [item for item in record["inputs"].items() if Path(item[0]).name == "rollouts.parquet"]
    if len(runs) != 1:
        raise ConfigError(f"{path}: expected one replayed run among its inputs")
    return record, runs[0]


def _check_replay_parts(
    records: list[tuple[Path, dict[str, Any]]], current_codes: frozenset[str]
) -> None:
    """Replays at one step are parts of one measurement: one Drake, and one rollout code or
    codes all verified current; otherwise they are never mixed."""
    first: dict[float, tuple[Path, dict[str, Any]]] = {}
    for path, record in records:
        step = record["simulator"]["time_step_s"]
        other_path, other = first.setdefault(step, (path, record))
        drakes = [r["packages"]["drake"] for r in (other, record)]
        codes = {r["rollout_code_sha256"] for r in (other, record)}
        if drakes[0] != drakes[1]:
            raise ConfigError(
                f"{path}: replayed by Drake {drakes[1]}, but {other_path} by {drakes[0]}; parts "
                "of one replay are never mixed"
            )
        if len(codes) > 1 and not codes <= current_codes:
            raise ConfigError(
                f"{path}: replayed by rollout code {record['code_version']}, {other_path} by "
                f"{other['code_version']}, and neither is verified equivalent to the other; "
                "parts of one replay are never mixed"
            )


def _check_same_training(group: list[RunRecord]) -> None:
    """Copies and twins must have trained alike, and copies (records at one std) deployed alike:
    they would not if the code changed between their studies. Then it does not matter which
    copy heads a training."""
    first_at: dict[float, RunRecord] = {}
    for run in group:
        copied = first_at.setdefault(run.start_std_m, run)
        if run is not group[0]:
            _check_same_rows(group[0], run, (Phase.TRAIN,), "training rollouts")
        if run is not copied:
            _check_same_rows(copied, run, DEPLOYMENT_PHASES, "deployments")


def _check_same_rows(
    first: RunRecord, run: RunRecord, phases: tuple[Phase, ...], what: str
) -> None:
    expected, rows = first.rows(phases), run.rows(phases)
    if not expected.equals(rows):  # NaN equals NaN here
        codes = f"code {first.record['code_version']} and {run.record['code_version']}"
        raise ConfigError(
            f"{first.path} and {run.path}: the same config and seeds but different {what} "
            f"({codes}); pool one of them"
        )


def _headline_std(trainings: Mapping[str, list[RunRecord]]) -> float:
    stds = [{run.start_std_m for run in group} for group in trainings.values()]
    common = set.intersection(*stds)
    if not common:
        examples = {f"{sorted(s)} m: {g[0].path}" for s, g in zip(stds, trainings.values())}
        raise ConfigError(
            f"{DEPLOY_STD_KEY}: no start std at which every pooled training has a run record "
            f"(e.g. {'; '.join(sorted(examples)[:2])}); pool runs recorded at one std "
            "(deployments at others can come from redeployment files)"
        )
    return min(common)


def _check_settings(runs: list[RunRecord], keys: list[str]) -> None:
    """Runs pool only where their settings differ in sweep keys or the method label, and runs
    of two ablation variants also in the settings either variant overrides (as its runs record
    them; a record without them is trusted to differ only as its variant's name says):
    otherwise one table would mix study designs."""
    allowed = {*keys, DEPLOY_STD_KEY, *LABEL_KEYS}
    heads: dict[Any, RunRecord] = {}
    for run in runs:
        head = heads.setdefault(run.level(VARIANT_KEY) if VARIANT_KEY in keys else None, run)
        _check_same_design(head, run, allowed)
    for first, other in itertools.combinations(heads.values(), 2):
        overrides = [run.record.get("variant_overrides") for run in (first, other)]
        if None not in overrides:
            _check_same_design(first, other, allowed | {k for o in overrides for k in o})


def _check_same_design(first: RunRecord, run: RunRecord, allowed: set[str]) -> None:
    # A one-level run ignores the outer level, whatever the bilevel runs set there.
    ignored = OUTER_PREFIX if first.one_level or run.one_level else None
    differing = sorted(
        key
        for key in first.settings.keys() | run.settings.keys()
        if key not in allowed
        and not (ignored and key.startswith(ignored))
        and first.settings.get(key) != run.settings.get(key)
    )
    if differing:
        key = differing[0]
        raise ConfigError(
            f"{key}: {first.settings.get(key)!r} in {first.path} but "
            f"{run.settings.get(key)!r} in {run.path}, and it is neither a sweep dimension of "
            "theirs nor a setting their variants override; pool runs of one study design"
        )


def _levels(run: RunRecord, keys: list[str]) -> list[Any]:
    """The run's levels of the split keys; a one-level run has no outer level."""
    return [
        None if run.one_level and k.startswith(OUTER_PREFIX) else run.level(k)
        for k in split_keys(keys)
    ]


def _check_distinct_levels(runs: list[RunRecord], keys: list[str]) -> None:
    seen: dict[str, RunRecord] = {}
    for run in runs:
        levels = canonical_json([run.method, *_levels(run, keys)])
        if levels in seen:
            raise ConfigError(
                f"{seen[levels].path} and {run.path}: the same method and sweep levels but "
                "different trainings (their configs or seeds differ); pool one of them"
            )
        seen[levels] = run


def _check_draws(runs: list[RunRecord], keys: list[str]) -> None:
    """Runs at the same levels but the method's are paired, so they must share their random
    draws (seed key); runs at other levels are independent, so they must not."""
    situation = [k for k in keys if not is_method_key(k)]
    at_levels: dict[str, RunRecord] = {}
    with_seeds: dict[str, RunRecord] = {}
    for run in runs:
        levels = canonical_json([run.level(k) for k in situation])
        first = at_levels.setdefault(levels, run)
        if first.seed_key != run.seed_key:
            raise ConfigError(
                f"{first.path} and {run.path}: the same sweep levels but different random draws "
                f"(seed keys {first.seed_key} and {run.seed_key}), so they are not a pair; pool "
                "runs whose studies sweep the same situation keys (start, seed, scene)"
            )
        first = with_seeds.setdefault(run.seed_key, run)
        if canonical_json([first.level(k) for k in situation]) != levels:
            raise ConfigError(
                f"{first.path} and {run.path}: the same random draws (seed key {run.seed_key}) "
                "at different sweep levels, so they are not independent; pool runs whose "
                "studies sweep the same situation keys (start, seed, scene)"
            )


def _deploy_rate(rollouts: pd.DataFrame) -> float:
    return float(phase_rows(rollouts, Phase.DEPLOY)["success"].mean())


def _deployment(
    run: RunRecord,
    keys: list[str],
    name: str,
    std: float,
    rate: float,
    model_error: str = NO_MODEL_ERROR,
    model_error_settings: Mapping[str, Any] | None = None,
) -> pd.DataFrame:
    row = {
        "method": run.method,
        "run": name,
        **{key: str(run.level(key)) for key in split_keys(keys)},
        "start_std_m": std,
        "model_error": model_error,
        "on_simulator": on_simulator(run.record["config"], model_error_settings, model_error),
        "hole_shift_m": hole_shift(run, model_error_settings or {}),
        "deploy_success_rate": rate,
    }
    return pd.DataFrame([row])


def hole_shift(run: RunRecord, model_error_settings: Mapping[str, Any]) -> float:
    """How far a model error moved the real hole in x from where the run trained (0 without a
    model error); NaN when it changed anything else too (friction, stiffness, contact)."""
    if not model_error_settings:
        return 0.0
    if set(model_error_settings) != {"hole.x_m"}:
        return math.nan
    return float(model_error_settings["hole.x_m"]) - float(run.settings["scene.hole.x_m"])


def _source(path: Path, run: str, std: float, role: str) -> dict[str, Any]:
    return {"file": str(path), "run": run, "start_std_m": std, "role": role}


def _redeployed_run(candidates: list[RunRecord], source: Path) -> RunRecord | None:
    """The pooled run a redeployment redeployed: among the runs with its input's data hash, the
    one in the directory (sweep point) it names. Two runs can hold identical data (e.g. both
    rules' runs before either found the hole, in a short study): the hash alone would attach
    both redeployments to one of them."""
    named = [run for run in candidates if run.path.parent.name == source.parent.name]
    return (named or candidates or [None])[0]


def _redeployments(
    path: Path,
) -> list[tuple[tuple[str, str], float, str, dict[str, Any], float]]:
    """((redeployed run's recorded path, its data's sha256), start std, model error, its dotted
    scene settings, deployment success) per run in a redeployment file: the ``redeploy`` rule's (one run) or ``pih redeploy
    --output``'s (several, a ``run`` column naming their directories)."""
    record = _provenance(path, "redeploy")
    rollouts = pd.read_parquet(path)
    inputs = list(record["inputs"].items())
    # Files of pih redeploy before 0.4.0 recorded the std at the config's top level.
    config = record["config"].get("planner", record["config"])
    std, error = config["deploy_start_std_m"], model_error_name(record)
    settings = model_error_settings(record)
    if "run" not in rollouts:
        sources = [item for item in inputs if Path(item[0]).name == "rollouts.parquet"]
        if len(sources) != 1:
            raise ConfigError(f"{path}: expected one redeployed run among its inputs {inputs}")
        return [(sources[0], std, error, settings, _deploy_rate(rollouts))]
    found = []
    for run, part in rollouts.groupby("run"):
        sources = [item for item in inputs if Path(item[0]).parent.name == run]
        if len(sources) != 1:
            raise ConfigError(f"{path}: rows of run {run!r} match {len(sources)} of its inputs")
        found.append((sources[0], std, error, settings, _deploy_rate(part)))
    return found


def _outside_run(redeployment: Path, source: str, sha256: str) -> RunRecord:
    """The redeployed run when it is not among the given paths: at its recorded path, if that
    still holds the data it redeployed (a copy or twin of a pooled training)."""
    path = Path(source)
    if not path.is_file():
        raise ConfigError(
            f"{redeployment}: the run it redeploys, {source}, is neither among the pooled runs "
            "nor there"
        )
    run = RunRecord.read(path)
    if run.sha256 != sha256:
        raise ConfigError(f"{redeployment}: {source} has changed since it was redeployed")
    return run


SOURCE_COLUMNS: dict[str, tuple[str, str]] = {
    "file": ("", "a pooled file"),
    "run": ("", "the training it belongs to (the directory of its headline record)"),
    "start_std_m": ("m", "std of its deployment trials' start offset in x and y"),
    "role": (
        "",
        (
            "its part: summary (headline record), copy, deployment (a twin's), redeployment or "
            "replay (its trials at another step; NaN std: every std)"
        ),
    ),
}
