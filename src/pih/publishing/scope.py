"""How two result trees are read for ``pih compare`` (:mod:`pih.publishing.compare`): their
planning runs by sweep point, at the points both hold when one holds runs the other lacks
(copies under a scratch directory, their tables remade from those runs), and pooled with the
published studies a study's tables pool."""

from __future__ import annotations

import os
import shutil
from collections.abc import Iterable, Mapping, Sequence
from pathlib import Path

import pandas as pd

from pih.publishing.equivalence import REPOSITORY
from pih.publishing.published import (
    PUBLISHED_STUDIES,
    PublishedStudy,
    expected_runs,
    remake_tables,
    runs_by_point,
    sweep_keys_of,
)
from pih.records.outputs import read_provenance

SUCCESS = "planning/summary/success.parquet"


def swept_keys(tree: Path) -> set[str]:
    """The sweep keys of a tree's planning runs (their recorded sweep points, in today's keys)."""
    from pih.study.points import upgraded_point

    return {
        key
        for path in (tree / "planning").glob("*/rollouts.parquet")
        for key in upgraded_point(read_provenance(path)["sweep_point"])
    }


def run_directories(tree: Path, keys: Iterable[str] = ()) -> dict[str, Path]:
    """A tree's planning run directories by their sweep point over ``keys`` too
    (:func:`runs_by_point`, in today's keys: directory names changed with 0.4.0), so that a
    default run, which fixes ``planner.simulated_hole``, meets its copy in a study that sweeps
    it."""
    return {
        key: rollouts.parent for key, rollouts in runs_by_point(tree / "planning", keys).items()
    }


def run_files(tree: Path, keys: Iterable[str] = ()) -> dict[str, Path]:
    """The planning runs' data files of a tree, by their run's sweep point
    (:func:`run_directories`) and file name."""
    return {
        f"{point} {data.name}": data
        for point, directory in run_directories(tree, keys).items()
        for data in [directory / "rollouts.parquet", *sorted(directory.glob("redeploy_*.parquet"))]
    }


def pools_its_runs(tree: Path) -> bool:
    """Whether a tree's own tables pool exactly the planning runs it holds (a whole study, not
    one with runs lost): its success table counts as many runs as it has run directories."""
    success = tree / SUCCESS
    if not success.is_file():
        return False
    table = pd.read_parquet(success)
    return int(table.loc[table["dimension"] == "all", "runs"].sum()) == len(run_directories(tree))


def runs_at_points(
    old: Path, new: Path, scratch: Path, keys: Iterable[str] = (), pooled: Sequence[Path] = ()
) -> Path | None:
    """When NEW is a whole study (:func:`pools_its_runs`) and OLD holds every planning run NEW
    does and more, or as many without tables of its own (a study published in parts, not yet
    complete): a copy under ``scratch`` of OLD restricted to NEW's sweep points (its other
    outputs whole), with the planning tables remade from those runs, pooled with those under
    ``pooled``, as ``pih aggregate`` makes them; None otherwise."""
    before, after = run_directories(old, keys), run_directories(new, keys)
    bigger = set(after) < set(before) or not (old / SUCCESS).is_file()
    if not after or not set(after) <= set(before) or not bigger or not pools_its_runs(new):
        return None
    return restricted(old, before, set(after), scratch / "old", pooled)


def shared_points(
    old: Path, new: Path, scratch: Path, keys: Iterable[str] = (), pooled: Sequence[Path] = ()
) -> tuple[Path, Path] | None:
    """When NEW is a whole study (:func:`pools_its_runs`) and each tree holds planning runs the
    other lacks: copies under ``scratch`` of both, restricted to the sweep points they share
    (:func:`restricted`, their tables pooled with the runs under ``pooled``); None otherwise
    (no shared point, or one tree holds all the other's)."""
    before, after = run_directories(old, keys), run_directories(new, keys)
    shared = set(before) & set(after)
    if not shared or shared in (set(before), set(after)) or not pools_its_runs(new):
        return None
    return (
        restricted(old, before, shared, scratch / "old", pooled),
        restricted(new, after, shared, scratch / "new", pooled),
    )


def restricted(
    tree: Path, runs: Mapping[str, Path], points: set[str], copy: Path, pooled: Sequence[Path] = ()
) -> Path:
    """``copy``: ``tree`` with only the planning ``runs`` at ``points`` (its other outputs
    whole) and the planning tables remade from them, pooled with the runs under ``pooled``, as
    ``pih aggregate`` makes them. Its files are links to ``tree``'s: a fresh run's directories
    hold its recordings and best paths too."""
    copy.mkdir(parents=True)
    for entry in tree.iterdir():
        if entry.name != "planning" and entry.is_dir():
            (copy / entry.name).symlink_to(entry.resolve(), target_is_directory=True)
    for key in sorted(points):
        target = copy / "planning" / runs[key].name
        shutil.copytree(runs[key].resolve(), target, copy_function=os.symlink)
    remake_tables(copy / "planning", pooled)
    return copy


def pooling_study(tree: Path, root: Path = REPOSITORY) -> PublishedStudy | None:
    """The published study that ``tree``'s planning runs are a run of (each a sweep point of
    its config files under ``root``), when its tables pool other published studies' runs
    (:attr:`~pih.publishing.published.PublishedStudy.pools`): a fresh contact-model run, whose
    twins trained on the real scene's model are the sim-to-real study's runs. None otherwise."""
    for study in PUBLISHED_STUDIES.values():
        config_files = [root / name for name in study.config_files]
        if not study.pools or not all(path.is_file() for path in config_files):
            continue
        expected = expected_runs(tuple(map(str, config_files)))
        runs = runs_by_point(tree / "planning", sweep_keys_of(expected))
        if runs and set(runs) <= set(expected):
            return study
    return None
