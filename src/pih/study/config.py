"""The study's configuration: the config file's sections, its schema, and the sweep.

``config/config.yaml`` has sections ``scene`` (:class:`pih.scene.config.SceneConfig`),
``validation`` (:class:`ValidationSection`), ``planner``
(:class:`pih.planning.config.PlannerConfig`), a ``sweep`` whose keys are dotted config paths
(``planner.start_x_m``) with lists of levels, optional ``variants``, ``figure_point`` and
``robustness`` (:class:`RobustnessSection`) and ``recordings`` (:class:`pih.records.config.RecordingsConfig`). A sweep point overrides those paths; :func:`resolve`
applies it and validates the result strictly, and :func:`check_study` does so for every point
before any job runs. :func:`pih.study.schema.config_schema` is what ``workflow/schemas/config.schema.json`` holds
(``python -m pih schema`` regenerates it; a test checks they agree). docs/workflow.md explains
the conventions.
"""

from __future__ import annotations

import copy
import itertools
import math
import os
import re
import sys
from collections import Counter
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from typing import Any

import yaml

from pih.config import (
    ConfigError,
    described,
    from_mapping,
    plain,
    set_paths,
    to_mapping,
)
from pih.planning.config import PlannerConfig, is_one_level, replace
from pih.records.config import RecordingsConfig
from pih.records.provenance import canonical_json
from pih.scene.config import SceneConfig
from pih.scene.overrides import scene_with
from pih.study.points import (
    GOAL_KEY,
    OUTER_PREFIX,
    VARIANT_KEY,
    is_method_key,
    variant_overrides,
)
from pih.validation.config import ValidationConfig, validation_scene_config

VARIANT_NAME = r"[a-z0-9_]+"
"""What a variant's name (planning's ``variants`` and ``validation.variants``) may be: it is
part of output paths, and the workflow's ``variant`` wildcard matches only these."""


MAX_SWEEP_POINTS = 10_000
"""Default of the config's optional top-level ``max_sweep_points``: a sweep whose Cartesian
product is larger stops before its points are built. Snakemake needs minutes and gigabytes to
plan a study that large before any job runs (10,000 points: about 3 min and 1 GB)."""


def sweep_points(
    sweep: Mapping[str, list[Any]],
    variants: Mapping[str, Mapping[str, Any]] | None = None,
    goal: str = "explored_argmin",
    max_points: int = MAX_SWEEP_POINTS,
) -> list[dict[str, Any]]:
    """The planning runs of a sweep: the Cartesian product of its levels, except that one-level
    runs (by their level of ``planner.goal``, their variant's, or else ``goal``, the config's)
    that differ only in settings of bilevel's outer rules (``planner.outer.*`` keys, or variants
    that change only those) are made once. Duplicate levels, unknown variants, keys whose
    directory names would collide and a product of more than ``max_points`` points (counted
    before any is built) are errors."""
    variants = variants or {}
    count = math.prod(len(levels) for levels in sweep.values())
    if count > max_points:
        sizes = " x ".join(f"{len(levels)} {path}" for path, levels in sweep.items())
        raise ConfigError(
            f"sweep: {count:,} points ({sizes}) exceed max_sweep_points = {max_points:,}; "
            "Snakemake needs minutes and gigabytes to plan that many runs (10,000: about 3 min, "
            "1 GB) before any starts. Sweep fewer levels, or set max_sweep_points at the top "
            "level of your config file to allow more"
        )
    for path, levels in sweep.items():
        counts = Counter(canonical_json(plain(v)) for v in levels)
        repeated = sorted(v for v, n in counts.items() if n > 1)
        if repeated:
            raise ConfigError(
                f"sweep.{path}: repeated level(s) {repeated}; each run must be unique"
            )
    names: dict[str, str] = {}
    for path in sweep:
        name = path.rsplit(".", 1)[-1]
        if name in names:
            raise ConfigError(
                f"sweep: keys {names[name]!r} and {path!r} both end in {name!r}, which names "
                "their level in run directories, so the directories would collide; sweep only one"
            )
        names[name] = path
    unknown = [v for v in sweep.get(VARIANT_KEY, []) if v not in variants]
    if unknown:
        raise ConfigError(
            f"sweep.{VARIANT_KEY}: {unknown} are not defined under variants ({sorted(variants)})"
        )
    points, one_level_seen = [], set()
    for levels in itertools.product(*sweep.values()):
        point = dict(zip(sweep, (plain(v) for v in levels)))
        settings = {**variants.get(point.get(VARIANT_KEY), {}), **point}
        if is_one_level(settings.get(GOAL_KEY, goal)):
            key = canonical_json(
                {
                    k: v
                    for k, v in settings.items()
                    if k != VARIANT_KEY and not k.startswith(OUTER_PREFIX)
                }
            )
            if key in one_level_seen:
                continue
            one_level_seen.add(key)
        points.append(point)
    return points


def override(config: Mapping[str, Any], point: Mapping[str, Any]) -> dict[str, Any]:
    """Deep copy of ``config`` with each dotted path of ``point`` set to its value; a
    ``variant`` level applies that entry of ``config["variants"]`` first. An unknown path is
    an error naming it as ``variants.<name>.<path>`` or ``sweep.<path>``."""
    out = copy.deepcopy(dict(config))
    point = dict(point)
    if VARIANT_KEY in point:
        name = plain(point.pop(VARIANT_KEY))
        set_paths(out, variant_overrides(config, {VARIANT_KEY: name}), f"variants.{name}.")
    set_paths(out, point, "sweep.")
    return out


def resolve(
    config: Mapping[str, Any], point: Mapping[str, Any] | None = None
) -> tuple[SceneConfig, PlannerConfig]:
    """Validated scene and planner configs of one sweep point."""
    data = override(config, point or {})
    return from_mapping(SceneConfig, data["scene"], "scene"), from_mapping(
        PlannerConfig, data["planner"], "planner"
    )


def resolved_sections(
    config: Mapping[str, Any], point: Mapping[str, Any] | None = None
) -> dict[str, dict[str, Any]]:
    """:func:`resolve`'s scene and planner as plain mappings (a planning job's params)."""
    scene, planner = resolve(config, point)
    return {"scene": to_mapping(scene), "planner": to_mapping(planner)}


@dataclass(frozen=True)
class ValidationSection:
    """The hydroelastic-vs-Whitney validation runs."""

    offsets_m: tuple[float, ...] = described(
        (0.0005, 0.001, 0.0015, 0.002),
        "lateral offsets ε0 of the spring base from the hole axis, one run each (paper §2.4: "
        "x_P = −0.5 … −2 mm)",
    )
    experiment: ValidationConfig = field(default_factory=ValidationConfig)
    scene_overrides: dict[str, Any] = described(
        description="scene settings of the validation runs that differ from the planner's "
        "scene, as dotted paths under scene (e.g. hole.fillet_radius_m; docs/validation.md)",
        default_factory=dict,
    )
    variants: dict[str, dict[str, Any]] = described(
        description="named validation settings, each a set of dotted scene paths applied over "
        "scene_overrides; every variant runs at every offset (results/validation/variants.*)",
        default_factory=lambda: {"hydroelastic": {}, "point": {"solver.contact_model": "point"}},
    )
    figure_variants: tuple[str, ...] = described(
        ("hydroelastic", "point"), "the variants the comparison table and Figs 4, 5, A1, A2 show"
    )

    def validate(self, prefix: str = "") -> None:
        if not self.offsets_m or any(not (0 < o < 0.01) for o in self.offsets_m):
            raise ConfigError(
                f"{prefix}offsets_m: {self.offsets_m!r}; expected lateral offsets in (0, 0.01) m"
            )
        bad = [name for name in self.variants if not re.fullmatch(VARIANT_NAME, str(name))]
        if not self.variants or bad:
            raise ConfigError(
                f"{prefix}variants: {bad or 'empty'}; expected at least one variant, each named "
                "with lower-case letters, digits and underscores (the name is a directory)"
            )
        unknown = [name for name in self.figure_variants if name not in self.variants]
        if not self.figure_variants or unknown:
            raise ConfigError(
                f"{prefix}figure_variants: {unknown or 'empty'}; expected names from "
                f"{prefix}variants ({sorted(self.variants)})"
            )
        self.experiment.validate(prefix + "experiment.")

    def scene(self, scene: Mapping[str, Any], variant: str) -> SceneConfig:
        """One variant's scene: the study's scene with ``scene_overrides`` and then the variant's
        overrides applied, and a hole deep enough for the whole insertion."""
        if variant not in self.variants:
            raise ConfigError(
                f"validation.variants: no variant {variant!r} ({sorted(self.variants)})"
            )
        base = scene_with(scene, self.scene_overrides, "validation.scene_overrides")
        base = scene_with(
            to_mapping(base), self.variants[variant], f"validation.variants.{variant}"
        )
        return validation_scene_config(base, self.experiment)


@dataclass(frozen=True)
class RobustnessSection:
    """Every planning run's learned policy deployed again from inexact starts, and on a real
    scene that differs from the one it was trained on (model error)."""

    start_std_m: tuple[float, ...] = described(
        (0.001,),
        "one redeployment of every run per std: the deployment trials from starts offset in x "
        "and y by N(0, std²) (pih redeploy, docs/planner.md); empty: none",
    )
    model_error: dict[str, dict[str, Any]] = described(
        description="one redeployment of every run per entry: the deployment trials on a real "
        "scene with these dotted scene settings (e.g. material.friction, hole.x_m: the hole "
        "moved after training; the camera sees it there), from starts offset by the smallest "
        "start_std_m > 0 (or the training start); docs/planner.md. Empty: none",
        default_factory=dict,
    )

    def validate(self, prefix: str = "") -> None:
        stds = [canonical_json(v) for v in self.start_std_m]
        if len(set(stds)) != len(stds):
            raise ConfigError(f"{prefix}start_std_m: {list(self.start_std_m)} repeats a level")
        for name, settings in self.model_error.items():
            if not re.fullmatch(VARIANT_NAME, str(name)):
                raise ConfigError(
                    f"{prefix}model_error: {name!r}; expected a name of lower-case letters, "
                    "digits and underscores (it is part of a file name)"
                )
            if not isinstance(settings, Mapping) or not settings:
                raise ConfigError(
                    f"{prefix}model_error.{name}: {settings!r}; expected dotted scene settings, "
                    "e.g. {material.friction: 0.5}"
                )

    @property
    def model_error_start_std_m(self) -> float:
        """The start std of the model-error redeployments: the smallest ``start_std_m`` > 0."""
        return min((s for s in self.start_std_m if s > 0), default=0.0)


def recordings_section(config: Mapping[str, Any]) -> RecordingsConfig:
    """The config's ``recordings`` section, validated (absent: the defaults)."""
    section = config.get("recordings")
    return (
        RecordingsConfig()
        if section is None
        else from_mapping(RecordingsConfig, section, "recordings")
    )


def robustness_section(config: Mapping[str, Any]) -> RobustnessSection:
    """The config's ``robustness`` section, validated."""
    return from_mapping(RobustnessSection, config["robustness"], "robustness")


def redeployments(config: Mapping[str, Any]) -> dict[str, tuple[float, dict[str, Any]]]:
    """The redeployment files the workflow makes beside every planning run (the ``robustness``
    section: one per start std, one per model error) -> the start std and the model error
    (``{}``, or its ``name`` and dotted scene ``settings``) each is made with."""
    section = robustness_section(config)
    files: dict[str, tuple[float, dict[str, Any]]] = {
        f"redeploy_start_std_m~{float(std)}.parquet": (float(std), {})
        for std in section.start_std_m
    }
    for name, settings in section.model_error.items():
        model_error = {"name": name, "settings": dict(settings)}
        files[f"redeploy_model_error~{name}.parquet"] = (
            section.model_error_start_std_m,
            model_error,
        )
    return files


OWN_SECTIONS = (
    "sweep",
    "variants",
    "figure_point",
    "validation.variants",
    "validation.scene_overrides",
)
"""Sections (dotted paths) a config file given with --configfile replaces whole instead of
merging: they define *which* runs exist, or (``validation.scene_overrides``) one set of changes
to the scene that an empty mapping must be able to clear."""


def read_config_files(
    config: dict[str, Any], default_files: list[str], command_line_files: list[str]
) -> None:
    """Check every config file for repeated keys (YAML lets a later key silently replace a whole
    section) and take :data:`OWN_SECTIONS` whole from the last command-line file that has them:
    Snakemake would merge a user's sweep onto the default's levels key by key."""
    for path in default_files:
        load_config_file(_relative(path))
    for path in command_line_files:
        data = load_config_file(_relative(path))
        for section in OWN_SECTIONS:
            *parents, leaf = section.split(".")
            source, target = data, config
            for key in parents:
                source, target = source.get(key) or {}, target.setdefault(key, {})
            if isinstance(source, dict) and leaf in source:
                target[leaf] = source[leaf]


def _relative(path: str) -> str:
    """``path`` relative to the working directory when it is below it (Snakemake makes config
    file paths absolute), for messages."""
    relative = os.path.relpath(path)
    return path if relative.startswith("..") else relative


def load_config(files: list[str]) -> dict[str, Any]:
    """The study config as the workflow sees it: ``files[0]`` (the default config), the others
    merged onto it key by key as Snakemake's ``--configfile`` does, :data:`OWN_SECTIONS` whole."""
    config = load_config_file(files[0])
    for path in files[1:]:
        _merge(config, load_config_file(path))
    read_config_files(config, files[:1], files[1:])
    return config


def load_config_file(path: str) -> dict[str, Any]:
    """A config file's top-level mapping, loaded strictly (:func:`load_yaml_strictly`); an
    unreadable or empty file, or one that is not a mapping of sections, is an error naming it."""
    data = load_yaml_strictly(path)
    if not isinstance(data, dict):
        kinds = (
            (bool, "a boolean"),
            ((int, float), "a number"),
            (str, "a string"),
            (list, "a list"),
        )
        kind = next((k for t, k in kinds if isinstance(data, t)), type(data).__name__)
        what = "empty" if data is None else f"{kind}, not a mapping"
        raise ConfigError(
            f"{path}: {what}; expected a mapping of config sections (scene:, planner:, sweep:, ...)"
        )
    return data


def _merge(config: dict[str, Any], update: Mapping[str, Any]) -> None:
    for key, value in update.items():
        if isinstance(value, Mapping) and isinstance(config.get(key), dict):
            _merge(config[key], value)
        else:
            config[key] = value


def load_yaml_strictly(path: str) -> Any:
    """YAML that rejects a repeated key, and reports a syntax error, naming the file and line."""

    class Loader(yaml.SafeLoader):
        def construct_mapping(self, node, deep=False):  # type: ignore[override]
            seen: set[Any] = set()
            for key_node, _ in node.value:
                key = self.construct_object(key_node, deep=deep)
                line = key_node.start_mark.line + 1
                if not isinstance(key, (str, int, float, bool)) and key is not None:
                    raise ConfigError(
                        f"{path}, line {line}: a key is a {type(key).__name__}; expected a name"
                    )
                if key in seen:
                    raise ConfigError(f"{path}, line {line}: key {key!r} appears twice")
                seen.add(key)
            return super().construct_mapping(node, deep=deep)

    try:
        with open(path, encoding="utf-8") as handle:
            return yaml.load(handle, Loader=Loader)
    except yaml.MarkedYAMLError as error:
        mark = error.problem_mark or error.context_mark
        where = f", line {mark.line + 1}, column {mark.column + 1}" if mark else ""
        raise ConfigError(f"{path}{where}: not valid YAML ({error.problem})") from None
    except (yaml.YAMLError, UnicodeDecodeError) as error:
        first = str(error).splitlines()[0] if str(error) else type(error).__name__
        raise ConfigError(f"{path}: not valid YAML ({first})") from None
    except OSError as error:
        raise ConfigError(f"{path}: cannot read it ({error.strerror or error})") from None


def validation_scenes(config: Mapping[str, Any]) -> dict[str, dict[str, Any]]:
    """Each validation variant's resolved scene, as a plain mapping."""
    section = from_mapping(ValidationSection, config["validation"], "validation")
    return {v: to_mapping(section.scene(config["scene"], v)) for v in section.variants}


def check_study(config: Mapping[str, Any], points: list[Mapping[str, Any]]) -> None:
    """Validate every section, every variant and every sweep point strictly, before any job."""
    try:
        validation_scenes(config)
    except ConfigError:
        # The validation scenes are the study's scene with overrides: name the scene's own
        # error as such, not as the overrides'.
        from_mapping(SceneConfig, config["scene"], "scene")
        raise
    for name in config.get("variants") or {}:
        data = override(config, {"variant": name})
        from_mapping(SceneConfig, data["scene"], f"variants.{name}: scene")
        from_mapping(PlannerConfig, data["planner"], f"variants.{name}: planner")
        check_limits(data, f"variants.{name}: ")
    robustness = robustness_section(config)
    for point in points or [{}]:
        try:
            data = override(config, point)
            scene = from_mapping(SceneConfig, data["scene"], "scene")
            planner = from_mapping(PlannerConfig, data["planner"], "planner")
            planner.simulator.check_scene(scene.solver.contact_model)
            check_limits(data)
        except ConfigError as error:
            raise ConfigError(f"{error}{_at_point(config, point, error)}") from None
        for std in robustness.start_std_m:
            try:
                replace(planner, deploy_start_std_m=std)
            except ConfigError as error:
                raise ConfigError(f"robustness.start_std_m: {error}") from None
        for name, settings in robustness.model_error.items():
            scene_with(data["scene"], settings, f"robustness.model_error.{name}")
    recordings_section(config)


def _at_point(config: Mapping[str, Any], point: Mapping[str, Any], error: ConfigError) -> str:
    """The suffix " (at sweep point ...)" for an error only this point's levels make, else ""."""
    if not point or str(error).startswith("sweep."):
        return ""
    try:
        data = override(config, {})
        scene = from_mapping(SceneConfig, data["scene"], "scene")
        planner = from_mapping(PlannerConfig, data["planner"], "planner")
        planner.simulator.check_scene(scene.solver.contact_model)
        check_limits(data)
    except ConfigError as base:
        if str(base) == str(error):
            return ""  # the config's own value, whatever the sweep
    levels = ", ".join(f"{path}={plain(level)}" for path, level in point.items())
    return f" (at sweep point {levels})"


LIMITS: dict[str, float] = {
    "planner.iterations": 10_000,
    "planner.deploy_trials": 10_000,
    "planner.convergence_window": 10_000,
    "planner.optimizer.population_size": 10_000,
    "planner.dmp.n_basis": 1_000,
    "planner.dmp.duration_s": 60.0,
    "planner.settle_s": 60.0,
    "scene.hole.fillet_facets": 1_000,
}
"""Upper bounds of counts and simulated durations (each job's work grows with them): sanity
limits of a study, far above any value it needs (the library itself accepts larger ones)."""


def check_limits(data: Mapping[str, Any], prefix: str = "") -> None:
    """Each of :data:`LIMITS` in a resolved config (sections ``scene`` and ``planner``)."""
    for path, limit in LIMITS.items():
        node: Any = data
        for key in path.split("."):
            node = node.get(key) if isinstance(node, Mapping) else None
        if isinstance(node, (int, float)) and not isinstance(node, bool) and node > limit:
            kind = "an integer" if isinstance(limit, int) else "a value"
            raise ConfigError(
                f"{prefix}{path}: {node!r} is not allowed; expected {kind} <= {limit:g} (a sanity "
                "limit of the study, pih.study.config.LIMITS)"
            )


def check_variant_names(variants: Any) -> None:
    """Planning variants are named like validation's (:data:`VARIANT_NAME`): the name is part of
    the run directories' names."""
    for name in variants or {}:
        if not re.fullmatch(VARIANT_NAME, str(name)):
            raise ConfigError(
                f"variants.{name}: {name!r} is not allowed as a variant name; expected "
                "lower-case letters, digits and underscores (the name is part of run directories)"
            )


def run_names(config: Mapping[str, Any], points: list[dict[str, Any]]) -> list[str]:
    """Each point's run directory, as the workflow names it (:func:`planning_space`)."""
    return list(planning_space(config, points).instance_patterns)


def planning_space(config: Mapping[str, Any], points: list[dict[str, Any]]) -> Any:
    """The planning runs as Snakemake's ``Paramspace``: a run's directory is named by the last
    component of each sweep key and its level, in the sweep's order
    (``start_x_m~-0.035_goal~deepest_explored_seed~0``), the one name a point has in its study,
    whichever study made its run."""
    import pandas as pd
    from snakemake.utils import Paramspace

    sweep = list(config["sweep"])
    return Paramspace(
        pd.DataFrame(
            [[p[path] for path in sweep] for p in points],
            columns=[path.rsplit(".", 1)[-1] for path in sweep],
        ),
        filename_params="*",
        param_sep="~",
    )


def study_points(config: Mapping[str, Any]) -> list[dict[str, Any]]:
    """The study's sweep points (:func:`sweep_points`), its variant names and size checked
    first: a sweep larger than ``max_sweep_points`` stops before any point is built."""
    variants = config.get("variants") or {}
    check_variant_names(variants)
    return sweep_points(
        config["sweep"],
        variants,
        config["planner"]["goal"],
        max_points=config.get("max_sweep_points", MAX_SWEEP_POINTS),
    )


@contextmanager
def stop_on_config_error() -> Iterator[None]:
    """For the workflow's top level: a :class:`ConfigError` is printed as one line on stderr
    (``config error: KEY: what is wrong``, no stack frames) and the process exits with status
    1, before any job starts."""
    try:
        yield
    except ConfigError as error:
        print(f"config error: {' '.join(str(error).split())}", file=sys.stderr)
        sys.exit(1)


def figure_point(config: Mapping[str, Any], points: list[Mapping[str, Any]]) -> dict[str, Any]:
    """The levels of the sweep point Fig. 8 shows: ``figure_point`` when some sweep point has
    them, else the first sweep point's (a user study that sets only ``sweep`` inherits the
    default's figure point), said on stderr."""
    wanted = dict(config.get("figure_point") or {})
    if not points or any(all(p.get(k) == v for k, v in wanted.items()) for p in points):
        return wanted
    first = {k: v for k, v in points[0].items() if k in config["sweep"] and not is_method_key(k)}
    print(
        f"figure_point: {wanted} is not a sweep point of this study; Fig. 8 shows the first "
        f"sweep point, {first}",
        file=sys.stderr,
    )
    return first
