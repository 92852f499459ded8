"""The published studies: what the repository carries, and whether it is still current.

``published/<study>/`` is a copy of one complete ``snakemake -j2`` run of a study
(:data:`PUBLISHED_STUDIES`: the default ``config/config.yaml``) at one commit (:func:`publish`
copies it from ``results/``: data, tables, figures, provenance; not the recordings), or of the
runs of a study published in parts (the paper-scale and sim-to-real studies,
:func:`publish_part`), and README's results for it are generated from its tables. The workflow
never reads it: a fresh clone recomputes everything. :func:`stale_reasons` says why it no longer
matches the config, the rollout code or the Drake that computes it (tests/test_published.py
fails then): a run is current when its rollout code is today's or was verified to compute the
same (:mod:`pih.publishing.equivalence`). Whether another run reproduced a published one is
:mod:`pih.publishing.compare`'s.
"""

from __future__ import annotations

import collections
import functools
import importlib.metadata
import json
import shutil
import subprocess
import tempfile
from collections.abc import Collection, Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from pih.publishing.equivalence import REPOSITORY, current_hashes
from pih.records.outputs import read_provenance
from pih.records.provenance import (
    VALIDATION_MODULES,
    canonical_json,
    module_path,
    modules_hash,
    validation_code_hash,
)


@dataclass(frozen=True)
class PublishedStudy:
    """A study whose run the repository carries: its config files (as given to Snakemake) and
    what README calls it."""

    name: str
    config_files: tuple[str, ...]
    title: str
    globs: tuple[str, ...]
    """What :func:`publish` copies from the study's results tree."""
    page: str = "README.md"
    """The page whose results block :func:`results_block` generates from this study."""
    in_parts: bool = False
    """Published run by run from several results trees (sessions, machines), each run current
    (:func:`run_stale_reasons`: today's config and Drake, today's rollout code or one verified
    equivalent to it) when it joined (:func:`publish_part`); its tables are made once every run
    is in."""
    pools: tuple[str, ...] = ()
    """Published studies whose runs its tables pool with its own (:func:`study_tables`): runs
    that pair with its by seed key."""

    @property
    def directory(self) -> Path:
        return Path("published") / self.name

    @property
    def markers(self) -> tuple[str, str]:
        """The comments around the results generated from this study on its page."""
        tail = "" if self.name == "default" else f" {self.name}"
        return f"<!-- PUBLISHED-RESULTS{tail} -->", f"<!-- /PUBLISHED-RESULTS{tail} -->"


RUN_GLOBS = ("planning/*/rollouts.parquet", "planning/*/redeploy_*.parquet")
"""Every planning run's record and its redeployments: what a study published in parts holds."""

PLANNING_GLOBS = ("summary.md", "provenance.md", *RUN_GLOBS, "planning/summary/*")
"""Every rollout's record (≈ 0.3 MB a run), the planning tables, figures and provenance. Not
the per-step traces (best paths, validation runs: 1–19 MB a run), the recordings or the report,
which the workflow remakes."""

VALIDATION_GLOBS = ("validation/comparison.*", "validation/variants.*", "validation/fig*")
"""The validation's tables and figures. Not its traces, nor the aligned curves (68 MB) the
figures are drawn from: data a 16-minute re-run makes again (docs/workflow.md, "Output sizes")."""

PUBLISHED_STUDIES = {
    study.name: study
    for study in (
        PublishedStudy(
            "default",
            ("config/config.yaml",),
            "default study",
            (*PLANNING_GLOBS, *VALIDATION_GLOBS, "whitney/*.parquet"),
            page="docs/workflow.md",
        ),
        # The paper's 11 starts on seed 0; the default's seed-0 runs are among its 33, draw
        # for draw. Each run is redeployed under the five model errors too.
        PublishedStudy(
            "paper",
            (
                "config/config.yaml",
                "config/paper.yaml",
                "config/model_error.yaml",
                "config/ladder.yaml",
            ),
            "paper-scale study",
            RUN_GLOBS,
            page="docs/planner.md",
            in_parts=True,
        ),
        # One-level with a stable goal beside the paper-scale study, paired with its runs by
        # seed key (pih aggregate published/paper published/stable_goal). Its tables pool the
        # paper-scale study's: README's headline, all five methods.
        PublishedStudy(
            "stable_goal",
            (
                "config/config.yaml",
                "config/stable_goal.yaml",
                "config/model_error.yaml",
                "config/ladder.yaml",
            ),
            "stable-goal study",
            RUN_GLOBS,
            in_parts=True,
            pools=("paper",),
        ),
        # The paper's thesis: trained in point contact, deployed on the hydroelastic scene; paired
        # by seed key with the sim-to-real study's runs on the real hole.
        PublishedStudy(
            "contact_model",
            ("config/config.yaml", "config/contact_model.yaml", "config/ladder.yaml"),
            "contact-model study",
            RUN_GLOBS,
            page="docs/contact_model.md",
            in_parts=True,
            pools=("sim_to_real",),
        ),
        # Planning runs only; the default's 12 runs are its runs on the real hole at -40 and -30
        # mm, draw for draw.
        PublishedStudy(
            "sim_to_real",
            ("config/config.yaml", "config/sim_to_real.yaml", "config/ladder.yaml"),
            "sim-to-real study",
            RUN_GLOBS,
            page="docs/sim_to_real.md",
            in_parts=True,
        ),
    )
}
PUBLISHED_DIR = PUBLISHED_STUDIES["default"].directory


def expected_runs(config_files: tuple[str, ...]) -> dict[str, dict[str, object]]:
    """What a study's config computes: :func:`point_key` of each sweep point -> its resolved
    ``scene`` and ``planner`` sections."""
    from pih.study.config import load_config, resolved_sections, study_points

    config = load_config(list(config_files))
    return {point_key(p): resolved_sections(config, p) for p in study_points(config)}


def run_names_by_point(config_files: tuple[str, ...]) -> dict[str, str]:
    """:func:`point_key` of each sweep point of a study -> the directory its workflow names the
    run with (:func:`pih.study.config.run_names`): a run published into the study takes that
    name, whichever study made it."""
    from pih.study.config import load_config, run_names, study_points

    config = load_config(list(config_files))
    points = study_points(config)
    return dict(zip(map(point_key, points), run_names(config, points), strict=True))


def publish(results: Path, study: PublishedStudy, root: Path = Path(".")) -> int:
    """Copy a finished run of ``study`` (its :attr:`PublishedStudy.globs` under ``results``)
    into its directory under ``root``, replacing what was there; the number of files copied. A
    tree that is not that study's run at this code (:func:`stale_reasons`) is refused before
    anything is copied."""
    files = sorted({f for pattern in study.globs for f in results.glob(pattern) if f.is_file()})
    if not files:
        raise FileNotFoundError(f"{results}: no study outputs to publish")
    config_files = tuple(str(root / f) for f in study.config_files)
    reasons = stale_reasons(results, expected_runs(config_files))
    reasons += validation_stale_reasons(results, expected_validation(config_files))
    if reasons:
        more = f" (and {len(reasons) - 1} more)" if len(reasons) > 1 else ""
        raise ValueError(f"{results} is not a run of the {study.title}: {reasons[0]}{more}")
    _copy_whole(files, results, root / study.directory)
    return len(files)


def stale_reasons(
    published: Path,
    expected: Mapping[str, Mapping[str, object]],
    current: Collection[str] | None = None,
    drake: str | None = None,
) -> list[str]:
    """Why the published planning runs no longer are what the repository would compute: runs
    missing or extra against ``expected`` (:func:`point_key` of a sweep point -> its resolved
    ``scene`` and ``planner`` sections, :func:`pih.study.config.resolved_sections`), a run whose
    recorded config differs, whose rollout code is not ``current`` (default: today's and those
    verified equivalent to it, :func:`pih.publishing.equivalence.current_hashes`), or whose Drake
    is not ``drake`` (default: the installed one)."""
    current = current_hashes() if current is None else current
    drake = drake or importlib.metadata.version("drake")
    runs = runs_by_point(published / "planning", sweep_keys_of(expected))
    reasons = [f"sweep point {key} is not published" for key in sorted(set(expected) - set(runs))]
    reasons += [
        f"{runs[key].parent.name} is not a sweep point of the config"
        for key in sorted(set(runs) - set(expected))
    ]
    for key in sorted(set(runs) & set(expected)):
        reasons += run_stale_reasons(runs[key], expected[key], published, current, drake)
    return reasons


VALIDATION_TABLES = ("validation/comparison.parquet", "validation/variants.parquet")
"""The validation tables README and the selection rule read."""


def expected_validation(config_files: tuple[str, ...]) -> dict[str, object]:
    """What a study's validation tables record as their config: its ``scene`` and
    ``validation`` sections."""
    from pih.study.config import load_config

    config = load_config(list(config_files))
    return {section: config[section] for section in ("scene", "validation")}


def validation_stale_reasons(
    published: Path,
    sections: Mapping[str, object],
    code_sha256: str | None = None,
    drake: str | None = None,
) -> list[str]:
    """Why a study's validation tables (:data:`VALIDATION_TABLES`, those it has) are not what the
    repository computes: made by other validation code (``code_sha256``, default
    :func:`pih.records.provenance.validation_code_hash`: the experiment, the scene and contact,
    Whitney's theory) or another Drake, or for another ``scene`` or ``validation`` config
    section. A table whose record predates the validation hash is judged by the hash of the
    validation modules at the commit that made it, read from git."""
    code_sha256 = code_sha256 or validation_code_hash()
    drake = drake or importlib.metadata.version("drake")
    reasons = []
    for table in VALIDATION_TABLES:
        if not (published / table).is_file():
            continue
        made = read_provenance(published / table)
        made_by = made.get("validation_code_sha256") or validation_hash_at(made["code_version"])
        if made_by is None:
            reasons.append(
                f"{table}: made at {made['code_version']}, a commit this repository's history "
                "does not hold, so its validation code is unknown"
            )
        elif made_by != code_sha256:
            reasons.append(f"{table}: made by other validation code")
        reasons += _made_elsewhere(made, table, None, drake)
        for section, now in sections.items():
            recorded = (made.get("config") or {}).get(section) or {}
            keys = _differing_keys(recorded, json.loads(canonical_json(now)))
            if keys:
                reasons.append(f"{table}: its {section} config differs in {', '.join(keys)}")
    return reasons


def run_stale_reasons(
    path: Path,
    sections: Mapping[str, object],
    root: Path,
    current: Collection[str] | None = None,
    drake: str | None = None,
) -> list[str]:
    """Why one planning run (its ``rollouts.parquet`` and redeployments) is not what the
    repository computes for its sweep point's resolved ``sections`` (:func:`stale_reasons`);
    paths are named relative to ``root``. The run's recorded ``scene`` and ``planner`` read
    through today's schema (:func:`recorded_sections`): a key it predates counts at its
    default, a key today's code no longer has is a reason."""
    current = current_hashes() if current is None else current
    drake = drake or importlib.metadata.version("drake")
    provenances = {
        data: read_provenance(data)
        for data in [path, *sorted(path.parent.glob("redeploy_*.parquet"))]
    }
    reasons = []
    for data, provenance in provenances.items():
        reasons += _made_elsewhere(provenance, data.relative_to(root), current, drake)
    recorded = provenances[path]["config"]
    for section, then in recorded_sections(recorded).items():
        if isinstance(then, str):
            reasons.append(f"{path.parent.name}: its {section} config {then}")
            continue
        now = json.loads(canonical_json(sections[section]))
        if then != now:
            keys = ", ".join(_differing_keys(then, now))
            reasons.append(f"{path.parent.name}: its {section} config differs in {keys}")
    return reasons


def recorded_sections(config: Mapping[str, Any]) -> dict[str, dict[str, Any] | str]:
    """A run's recorded ``scene`` and ``planner`` sections as today's schema reads them (keys
    the run predates at their defaults, :func:`pih.config.recorded_config`), or for a section
    today's schema refuses, why (a key it no longer has)."""
    from pih.config import ConfigError, recorded_config, to_mapping
    from pih.planning.config import recorded_planner
    from pih.scene.config import SceneConfig

    readers = {
        "scene": lambda: recorded_config(SceneConfig, config, "scene"),
        "planner": lambda: recorded_planner(config),
    }
    sections: dict[str, dict[str, Any] | str] = {}
    for section, read in readers.items():
        try:
            sections[section] = to_mapping(read())
        except (ConfigError, KeyError, TypeError) as error:
            sections[section] = f"no longer reads: {str(error).splitlines()[0]}"
    return sections


@functools.cache
def validation_hash_at(commit: str) -> str | None:
    """:func:`pih.records.provenance.modules_hash` of :data:`VALIDATION_MODULES` as they were
    at ``commit`` (``-dirty`` dropped), read from this repository's git history (a module the
    commit did not have reads as empty); None when the history does not hold the commit."""
    revision = commit.removesuffix("-dirty")

    def git(*args: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run(
            ["git", *args], cwd=REPOSITORY, capture_output=True, text=True, timeout=30, check=False
        )

    def source(name: str) -> str:
        path = module_path(name).relative_to(REPOSITORY).as_posix()
        shown = git("show", f"{revision}:{path}")
        if shown.returncode and git("cat-file", "-e", f"{revision}^{{commit}}").returncode:
            raise subprocess.CalledProcessError(shown.returncode, "git show", stderr=shown.stderr)
        return shown.stdout if shown.returncode == 0 else ""

    try:
        return modules_hash(VALIDATION_MODULES, source)
    except (OSError, subprocess.SubprocessError):
        return None


ROLLOUT_LIBRARIES = ("numpy", "cma")
"""Libraries a rollout draws or optimizes with, beside Drake: numpy's Generator streams are not
promised stable across its feature releases, and CMA-ES is cma's. A run made under other
versions than the installed ones is not current (issue 81); they stay out of the rollout hash,
which ``pih verify`` recomputes for old code in today's environment."""


def _made_elsewhere(
    made: Mapping[str, object], name: object, current: Collection[str] | None, drake: str
) -> list[str]:
    """Why a file's provenance ``made`` is not this repository's: rollout code not ``current``
    (None: not checked), another Drake, another version of a :data:`ROLLOUT_LIBRARIES` library
    than the installed one."""
    reasons = []
    if current is not None and made.get("rollout_code_sha256") not in current:
        reasons.append(f"{name}: made by other rollout code")
    packages = made.get("packages") or {}
    if packages.get("drake") != drake:
        reasons.append(f"{name}: made by Drake {packages.get('drake')}, not {drake}")
    for library in ROLLOUT_LIBRARIES:
        installed = importlib.metadata.version(library)
        if packages.get(library) != installed:
            reasons.append(
                f"{name}: made with {library} {packages.get(library)}, {installed} installed"
            )
    return reasons


@dataclass(frozen=True)
class Part:
    """What one :func:`publish_part` call did."""

    added: int
    """runs copied in"""
    unfinished: int
    """runs of the study in the tree whose redeployments are not all there: left out"""
    missing: int
    """runs of the study still to come"""


def publish_part(results: Path, study: PublishedStudy, root: Path = Path(".")) -> Part:
    """Add the finished runs of ``study`` that ``results`` holds (each with every redeployment
    its config makes) to its published directory; runs of other sweep points, and runs whose
    redeployments are not all there yet, are left out. Refused in one line before anything is
    copied: a run, new or published before, that is not what this repository computes
    (:func:`run_stale_reasons`: each run at today's config and Drake, and today's rollout code or
    one verified equivalent to it), or one already published whose rollouts differ. Each run's provenance says where it was made
    (host, CPU, code version, date). Once every run is in, the study's planning tables are made
    from them (``planning/summary``)."""
    config_files = tuple(str(root / f) for f in study.config_files)
    expected, redeployments = expected_runs(config_files), expected_redeployments(config_files)
    destination = root / study.directory / "planning"
    keys = sweep_keys_of(expected)
    published = runs_by_point(destination, keys)
    ours = {k: p for k, p in runs_by_point(results / "planning", keys).items() if k in expected}
    if not ours:
        raise FileNotFoundError(f"{results}: no run of the {study.title}")
    finished = {
        key: path
        for key, path in ours.items()
        if redeployments <= {f.name for f in path.parent.glob("redeploy_*.parquet")}
    }
    current = current_hashes()
    reasons = [
        r for k, p in finished.items() for r in run_stale_reasons(p, expected[k], results, current)
    ]
    reasons += [
        r for k, p in published.items() for r in run_stale_reasons(p, expected[k], root, current)
    ]
    reasons += [
        f"{path.parent.name}: published already, with other rollouts"
        for key, path in finished.items()
        if key in published and not pd.read_parquet(path).equals(pd.read_parquet(published[key]))
    ]
    if reasons:
        more = f" (and {len(reasons) - 1} more)" if len(reasons) > 1 else ""
        raise ValueError(f"{results}: {reasons[0]}{more}")
    new = {key: path for key, path in finished.items() if key not in published}
    directories = run_names_by_point(config_files)
    for key, path in new.items():
        files = [path, *(path.parent / name for name in sorted(redeployments))]
        _copy_whole(files, path.parent, destination / directories[key])
    missing = len(set(expected) - set(runs_by_point(destination, keys)))
    if not missing:
        study_tables(root, study)
    return Part(len(new), len(ours) - len(finished), missing)


def remake_tables(planning: Path, also: Iterable[Path] = ()) -> None:
    """A study's planning tables (``planning/summary``), made from its runs, redeployments and
    replays, and those under ``also``, as ``pih aggregate`` makes them."""
    from pih.analysis.pooling import find_outputs, pool
    from pih.reporting.planning_summary import write_pooled_summary

    pooled = pool(*find_outputs([planning, *also]), current_codes=current_hashes())
    write_pooled_summary(pooled, planning / "summary")


def study_tables(root: Path, study: PublishedStudy) -> None:
    """A published study's tables (:func:`remake_tables`), pooled with the studies it
    :attr:`~PublishedStudy.pools`."""
    remake_tables(root / study.directory / "planning", pooled_planning(root, study))


def pooled_planning(root: Path, study: PublishedStudy) -> list[Path]:
    """The planning directories under ``root`` of the published studies ``study``
    :attr:`~PublishedStudy.pools`."""
    return [root / PUBLISHED_STUDIES[name].directory / "planning" for name in study.pools]


def published_run_reasons(
    root: Path,
    expected: Mapping[str, Mapping[str, object]],
    runs: Mapping[str, Path],
    current: Collection[str],
) -> list[str]:
    """Why published ``runs`` (:func:`published_runs`) may not be worked on in place: a run
    that is not a sweep point of the config, or one that is not current
    (:func:`run_stale_reasons`)."""
    reasons = [
        f"{runs[key].parent.name} is not a sweep point of the config"
        for key in sorted(set(runs) - set(expected))
    ]
    return reasons + [
        reason
        for key in sorted(set(runs) & set(expected))
        for reason in run_stale_reasons(runs[key], expected[key], root, current)
    ]


def one_line(where: Path, reasons: list[str]) -> str:
    """The first of ``reasons``, and how many more."""
    more = f" (and {len(reasons) - 1} more)" if len(reasons) > 1 else ""
    return f"{where}: {reasons[0]}{more}"


def expected_redeployments(config_files: tuple[str, ...]) -> set[str]:
    """The redeployment files the workflow makes beside every planning run of a study (its
    ``robustness`` section: one per start std, one per model error)."""
    from pih.study.config import load_config, redeployments

    return set(redeployments(load_config(list(config_files))))


def runs_by_point(planning: Path, keys: Iterable[str] = ()) -> dict[str, Path]:
    """:func:`point_key` of each run under a ``planning`` directory, in a study that sweeps
    ``keys``, -> its ``rollouts.parquet``. A key the run's own study fixed takes the level its
    recorded config sets: the default study's runs, which fix ``planner.simulated_hole``, are the
    ``true_hole`` runs of a study that sweeps it, draw for draw (the key selects the method, so
    the draws do not depend on it). Where that would give two runs of one tree the same point
    (a default run beside the same run made by a study that sweeps the key), each keeps its
    own."""
    from pih.study.points import upgraded_point

    points = []
    for path in sorted(planning.glob("*/rollouts.parquet")):
        record = read_provenance(path)
        own = upgraded_point(record["sweep_point"])
        points.append((point_key(own), point_key(own | _fixed_levels(record, keys)), path))
    filled = collections.Counter(key for _, key, _ in points)
    return {key if filled[key] == 1 else own: path for own, key, path in points}


def _fixed_levels(record: Mapping[str, Any], keys: Iterable[str]) -> dict[str, Any]:
    """The levels of ``keys`` that a run's own study fixed (not in its sweep point), as its
    recorded config sets them (dotted paths under its config's sections)."""
    levels = {}
    for key in sorted(set(keys) - set(record["sweep_point"])):
        section, *rest = key.split(".")
        level = (record.get("config") or {}).get(section)
        for name in rest:
            level = level.get(name) if isinstance(level, Mapping) else None
        if rest and level is not None:
            levels[key] = level
    return levels


def sweep_keys_of(expected: Mapping[str, object]) -> set[str]:
    """The sweep keys of a study's :func:`expected_runs`."""
    return {key for point in expected for key in json.loads(point)}


def _copy_whole(files: list[Path], source: Path, destination: Path) -> None:
    """Copy ``files`` (under ``source``) to ``destination``, replacing it: copied beside it
    first, so that an interrupted copy leaves what was there whole."""
    destination.parent.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=f".{destination.name}-", dir=destination.parent))
    try:
        for file in files:
            target = staging / file.relative_to(source)
            target.parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(file, target)
        if destination.exists():
            shutil.rmtree(destination)
        staging.rename(destination)
    finally:
        shutil.rmtree(staging, ignore_errors=True)


def point_key(point: Mapping[str, object]) -> str:
    """A sweep point as one comparable string."""
    return canonical_json(dict(point))


def _differing_keys(old: Mapping, new: Mapping, prefix: str = "") -> list[str]:
    keys = []
    for key in sorted(set(old) | set(new)):
        a, b = old.get(key), new.get(key)
        if isinstance(a, Mapping) and isinstance(b, Mapping):
            keys += _differing_keys(a, b, f"{prefix}{key}.")
        elif a != b:
            keys.append(f"{prefix}{key}")
    return keys


def published_runs(
    published: Path, study: PublishedStudy
) -> tuple[dict[str, dict[str, object]], dict[str, Path]]:
    """A study's :func:`expected_runs` (its configs in the repository that holds ``published``)
    and its published runs by their point in it (:func:`runs_by_point`)."""
    root = Path(published).parents[1]
    expected = expected_runs(tuple(str(root / f) for f in study.config_files))
    return expected, runs_by_point(published / "planning", sweep_keys_of(expected))
