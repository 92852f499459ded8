"""Pooling planning runs from several studies' result directories into one set of tables
(``pih aggregate``): each distinct training counted once, with its deployments at every start
std gathered from its own records, its twins' (the same training recorded at another
``planner.deploy_start_std_m``) and its redeployments. Runs pool only when nothing but their sweep
levels tells them apart. docs/planner.md, "Pooling studies".
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from pih.aggregate import run_tables, split_keys, variant
from pih.config import ConfigError, recorded_config, to_mapping
from pih.outputs import read_provenance
from pih.planner import PlannerConfig, replace
from pih.provenance import canonical_json
from pih.scene_config import SceneConfig
from pih.study_config import VARIANT_KEY

DEPLOY_STD_KEY = "planner.deploy_start_std_m"
REDEPLOY_PATTERN = "redeploy_start_std_m~*.parquet"


@dataclass(frozen=True)
class RunRecord:
    """One ``rollouts.parquet``: its method, its settings as one flat mapping (keys the run
    predates read as their defaults) and the training it shares with its twins."""

    path: Path
    record: dict[str, Any]
    method: str
    settings: dict[str, Any]
    start_std_m: float
    training: str

    @classmethod
    def read(cls, path: Path) -> RunRecord:
        record = read_provenance(path)
        if record.get("step") != "plan":
            raise ConfigError(f"{path}: not a planning run (step {record.get('step')!r})")
        config = record["config"]
        scene = recorded_config(SceneConfig, config, "scene")
        planner = recorded_config(PlannerConfig, config, "planner")
        settings = _flat({"scene": to_mapping(scene), "planner": to_mapping(planner)})
        undeployed = replace(planner, deploy_start_std_m=0.0)
        training = canonical_json(
            {
                "scene": to_mapping(scene),
                "planner": to_mapping(undeployed),
                "seed": record["seed_key"],
            }
        )
        return cls(
            path,
            record,
            variant(to_mapping(planner)),
            settings,
            planner.deploy_start_std_m,
            training,
        )

    def level(self, key: str) -> Any:
        """The run's level of a sweep key: its sweep point's, else its config's value."""
        point = self.record["sweep_point"]
        if key in point:
            return point[key]
        if key in self.settings:
            return self.settings[key]
        raise ConfigError(
            f"{self.path}: no level for sweep key {key!r} (neither in its sweep point nor in its "
            "config); pool runs of studies that share their sweep dimensions"
        )


def _flat(mapping: Mapping[str, Any], prefix: str = "") -> dict[str, Any]:
    flat: dict[str, Any] = {}
    for key, value in mapping.items():
        if isinstance(value, Mapping):
            flat |= _flat(value, f"{prefix}{key}.")
        else:
            flat[f"{prefix}{key}"] = value
    return flat


def find_outputs(paths: Iterable[str | Path]) -> tuple[list[Path], list[Path]]:
    """The planning runs (``rollouts.parquet``) and redeployments (the ``redeploy`` rule's files,
    or ``pih redeploy --output`` files) under each path, a directory or a file."""
    runs, redeployments = [], []
    for path in map(Path, paths):
        if path.is_dir():
            runs += sorted(path.rglob("rollouts.parquet"))
            redeployments += sorted(path.rglob(REDEPLOY_PATTERN))
        elif path.name == "rollouts.parquet":
            runs.append(path)
        elif path.is_file():
            redeployments.append(path)
        else:
            raise ConfigError(f"{path}: no such file or directory")
    if not runs:
        raise ConfigError(f"no planning runs (rollouts.parquet) under {[str(p) for p in paths]}")
    return runs, redeployments


@dataclass
class PooledRuns:
    """What :func:`pool` gathers: the sweep keys, one best-cost table and one summary row per
    training (deployed at the headline start std), every deployment at every std, and where
    each training's rows came from."""

    sweep_keys: list[str]
    runs: pd.DataFrame
    summaries: pd.DataFrame
    deployments: pd.DataFrame
    sources: pd.DataFrame


def pool(run_files: list[Path], redeploy_files: list[Path]) -> PooledRuns:
    """Pool planning runs: the same training recorded twice (another deployment std, another
    directory) counts once; a training's summary row is its record at the smallest std, which
    must be the same std for all; runs may differ only in their sweep levels. Redeployments
    attach to the training of the run they redeployed."""
    records = [RunRecord.read(path) for path in run_files]
    keys = _sweep_keys(records)
    trainings: dict[str, list[RunRecord]] = {}
    for run in records:
        trainings.setdefault(run.training, []).append(run)
    headline = {t: min(runs, key=lambda r: r.start_std_m) for t, runs in trainings.items()}
    _check_headline_std(list(headline.values()))
    _check_settings(list(headline.values()), keys)
    _check_distinct_levels(list(headline.values()), keys)

    by_path = {run.path.resolve(): run for run in records}
    name = {t: run.path.parent.name for t, run in headline.items()}
    levels = {run.path: {k: run.level(k) for k in split_keys(keys)} for run in headline.values()}
    runs, summaries = run_tables(list(levels), keys, levels)
    deployments, sources = [summaries], []
    for training, run in headline.items():
        sources.append(_source(run.path, name[training], run.start_std_m, "summary"))
        for twin in trainings[training]:
            if twin is run:
                continue
            if twin.start_std_m == run.start_std_m:
                sources.append(_source(twin.path, name[training], twin.start_std_m, "copy"))
                continue
            rate = _deploy_rate(pd.read_parquet(twin.path, columns=["phase", "success"]))
            deployments.append(_deployment(run, keys, name[training], twin.start_std_m, rate))
            sources.append(_source(twin.path, name[training], twin.start_std_m, "deployment"))
    for path in redeploy_files:
        for source, std, rate in _redeployments(path):
            run = by_path.get(source.resolve())
            if run is None:  # a run outside the given paths: pooled if it is a copy or twin
                if not source.is_file():
                    raise ConfigError(f"{path}: the run it redeploys, {source}, is not there")
                run = RunRecord.read(source)
            training = run.training
            if training not in headline:
                raise ConfigError(f"{path}: redeploys {source}, which is not among the pooled runs")
            deployments.append(_deployment(headline[training], keys, name[training], std, rate))
            sources.append(_source(path, name[training], std, "redeployment"))
    deployments = pd.concat(deployments, ignore_index=True)
    # The same training at the same std more than once (copies, or a redeployment at its own
    # std) counts once; deployment is deterministic given the training and the std.
    deployments = deployments.drop_duplicates(["run", "start_std_m"], ignore_index=True)
    return PooledRuns(keys, runs, summaries, deployments, pd.DataFrame(sources))


def _sweep_keys(records: list[RunRecord]) -> list[str]:
    keys: list[str] = []
    for run in records:
        keys += [k for k in run.record["sweep_point"] if k not in keys and k != DEPLOY_STD_KEY]
    return keys


def _check_headline_std(runs: list[RunRecord]) -> None:
    stds = {run.start_std_m: run for run in runs}
    if len(stds) > 1:
        examples = ", ".join(f"{std:g} m ({run.path})" for std, run in sorted(stds.items()))
        raise ConfigError(
            f"{DEPLOY_STD_KEY}: the pooled trainings are deployed at different start stds and "
            f"share none ({examples}); redeploy them at a common std first (pih redeploy)"
        )


def _check_distinct_levels(runs: list[RunRecord], keys: list[str]) -> None:
    seen: dict[str, RunRecord] = {}
    for run in runs:
        levels = canonical_json([run.method, *[run.level(k) for k in keys]])
        if levels in seen:
            raise ConfigError(
                f"{seen[levels].path} and {run.path}: the same method and sweep levels but "
                "different trainings (their configs or seeds differ); pool one of them"
            )
        seen[levels] = run


def _check_settings(runs: list[RunRecord], keys: list[str]) -> None:
    """Runs pool only where their settings differ in sweep keys (or, for a variant sweep, within
    each variant only in sweep keys): otherwise a table would mix study designs."""
    allowed = {*keys, DEPLOY_STD_KEY}
    groups: dict[Any, list[RunRecord]] = {}
    for run in runs:
        group = run.level(VARIANT_KEY) if VARIANT_KEY in keys else None
        groups.setdefault(group, []).append(run)
    for group in groups.values():
        first = group[0]
        for run in group[1:]:
            differing = sorted(
                key
                for key in first.settings.keys() | run.settings.keys()
                if key not in allowed and first.settings.get(key) != run.settings.get(key)
            )
            if differing:
                key = differing[0]
                raise ConfigError(
                    f"{key}: {first.settings.get(key)!r} in {first.path} but "
                    f"{run.settings.get(key)!r} in {run.path}, and it is not a sweep dimension "
                    "of theirs; pool runs of one study design"
                )


def _deploy_rate(rollouts: pd.DataFrame) -> float:
    return float(rollouts.loc[rollouts["phase"] == "deploy", "success"].mean())


def _deployment(
    run: RunRecord, keys: list[str], name: str, std: float, rate: float
) -> pd.DataFrame:
    row = {
        "method": run.method,
        "run": name,
        **{key: str(run.level(key)) for key in split_keys(keys)},
        "start_std_m": std,
        "deploy_success_rate": rate,
    }
    return pd.DataFrame([row])


def _source(path: Path, run: str, std: float, role: str) -> dict[str, Any]:
    return {"file": str(path), "run": run, "start_std_m": std, "role": role}


def _redeployments(path: Path) -> list[tuple[Path, float, float]]:
    """(redeployed run's rollouts.parquet, start std, deployment success) per run in a
    redeployment file: the ``redeploy`` rule's (one run, beside it) or ``pih redeploy
    --output``'s (several, a ``run`` column naming their directories)."""
    record = read_provenance(path)
    rollouts = pd.read_parquet(path)
    if "run" not in rollouts:
        std = record["config"]["planner"][DEPLOY_STD_KEY.split(".")[1]]
        return [(path.with_name("rollouts.parquet"), std, _deploy_rate(rollouts))]
    std = record["config"]["deploy_start_std_m"]
    inputs = {Path(p).parent.name: Path(p) for p in record["inputs"]}
    return [(inputs[run], std, _deploy_rate(part)) for run, part in rollouts.groupby("run")]


SOURCE_COLUMNS: dict[str, tuple[str, str]] = {
    "file": ("", "a pooled file"),
    "run": ("", "the training it belongs to (the directory of its headline record)"),
    "start_std_m": ("m", "std of its deployment trials' start offset in x and y"),
    "role": (
        "",
        "its part: summary (headline record), copy, deployment (a twin's) or redeployment",
    ),
}
