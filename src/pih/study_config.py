"""The study's configuration: the config file's sections, its schema, and the sweep.

``config/config.yaml`` has sections ``scene`` (:class:`pih.scene_config.SceneConfig`),
``validation`` (:class:`ValidationSection`), ``planner`` (:class:`pih.planner.PlannerConfig`),
a ``sweep`` whose keys are dotted config paths (``planner.start_x_m``) with lists of levels,
optional ``variants``, ``figure_point`` and ``robustness`` (:class:`RobustnessSection`). A sweep point overrides those paths; :func:`resolve`
applies it and validates the result strictly, and :func:`check_study` does so for every point
before any job runs. :func:`config_schema` is what ``workflow/schemas/config.schema.json`` holds
(``python -m pih schema`` regenerates it; a test checks they agree). docs/workflow.md explains
the conventions.
"""

from __future__ import annotations

import copy
import itertools
import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from pih.config import ConfigError, from_mapping, json_schema, to_mapping
from pih.planner import PlannerConfig, replace
from pih.provenance import canonical_json
from pih.scene_config import SceneConfig
from pih.validation import ValidationConfig, validation_scene_config

METHOD_KEY = "planner.method"
OUTER_PREFIX = "planner.outer."
"""Sweep keys under this prefix configure bilevel's outer level; one-level runs ignore them."""


DEPLOY_KEYS = ("planner.deploy_policy", "planner.deploy_start_std_m")
"""How the learned policy is deployed (which weights, from how exact a start): training is the
same for every level, so these are method keys (shared draws) that one-level runs depend on."""

TRAINING_KEYS = ("planner.train_start_std_m",)
"""How robustly the policy is trained (training from offset starts): a method choice, so these
are method keys too (shared draws), and one-level runs depend on them."""

VARIANT_KEY = "variant"
"""Sweep key whose levels name entries of the config's ``variants`` (one-at-a-time ablations)."""


def is_method_key(path: str) -> bool:
    """Whether a sweep key selects the method (the method, its outer level, or a named variant)
    rather than the situation (start, seed, noise, scene): runs differing only in such keys
    share their random draws (common random numbers), so their comparison is paired."""
    return path in (METHOD_KEY, *DEPLOY_KEYS, *TRAINING_KEYS, VARIANT_KEY) or path.startswith(
        OUTER_PREFIX
    )


def seed_key(point: Mapping[str, Any]) -> str:
    """Stable encoding of a sweep point's non-method levels: the per-run seed is derived from it
    (:func:`pih.planner.run_seeds`), so every other difference gives independent draws."""
    return canonical_json({k: plain(v) for k, v in point.items() if not is_method_key(k)})


def sweep_points(
    sweep: Mapping[str, list[Any]],
    variants: Mapping[str, Mapping[str, Any]] | None = None,
    method: str = "bilevel",
) -> list[dict[str, Any]]:
    """The planning runs of a sweep: the Cartesian product of its levels, except that one-level
    runs (by their level of ``planner.method``, their variant's, or else ``method``, the config's)
    that differ only in settings of bilevel's outer level (``planner.outer.*`` keys, or variants
    that change only those) are made once. Duplicate levels, unknown variants and keys whose
    directory names would collide are errors."""
    variants = variants or {}
    for path, levels in sweep.items():
        encoded = [canonical_json(plain(v)) for v in levels]
        repeated = sorted({v for v in encoded if encoded.count(v) > 1})
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
        if settings.get(METHOD_KEY, method) == "one_level":
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


def plain(value: Any) -> Any:
    return value.item() if isinstance(value, np.generic) else value


def variant_overrides(config: Mapping[str, Any], point: Mapping[str, Any]) -> dict[str, Any]:
    """The dotted-path overrides a sweep point's ``variant`` level stands for (none without one).
    Each planning run records them, so that pooling knows what a variant's name covers."""
    if VARIANT_KEY not in point:
        return {}
    name = plain(point[VARIANT_KEY])
    variants = config.get("variants") or {}
    if name not in variants:
        raise ConfigError(f"variant {name!r} is not defined under variants ({sorted(variants)})")
    return dict(variants[name])


def override(config: Mapping[str, Any], point: Mapping[str, Any]) -> dict[str, Any]:
    """Deep copy of ``config`` with each dotted path of ``point`` set to its value; a
    ``variant`` level applies that entry of ``config["variants"]`` first."""
    out = copy.deepcopy(dict(config))
    point = dict(point)
    if VARIANT_KEY in point:
        point = {**variant_overrides(config, point), **point}
        del point[VARIANT_KEY]
    for path, value in point.items():
        node = out
        *parents, leaf = path.split(".")
        for key in parents:
            if not isinstance(node.get(key), dict):
                raise ConfigError(f"sweep key {path!r}: {key!r} is not a config section")
            node = node[key]
        if leaf not in node:
            raise ConfigError(
                f"sweep key {path!r}: no such config key {leaf!r}; allowed: {sorted(node)}"
            )
        node[leaf] = plain(value)  # Paramspace gives numpy scalars
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

    offsets_m: tuple[float, ...] = (0.0005, 0.001, 0.0015, 0.002)
    experiment: ValidationConfig = field(default_factory=ValidationConfig)
    # Scene settings of the validation runs that differ from the planner's scene, as dotted
    # paths under `scene` (e.g. "hole.fillet_radius_m"); docs/validation.md says why.
    scene_overrides: dict[str, Any] = field(default_factory=dict)
    # Named validation settings, each a set of dotted scene paths applied over scene_overrides;
    # every variant runs at every offset and goes into results/validation/variants.*.
    variants: dict[str, dict[str, Any]] = field(
        default_factory=lambda: {"hydroelastic": {}, "point": {"solver.contact_model": "point"}}
    )
    # The variants the comparison table and Figs 4, 5, A1, A2 show.
    figure_variants: tuple[str, ...] = ("hydroelastic", "point")

    def validate(self, prefix: str = "") -> None:
        if not self.offsets_m or any(not (0 < o < 0.01) for o in self.offsets_m):
            raise ConfigError(
                f"{prefix}offsets_m: {self.offsets_m!r}; expected lateral offsets in (0, 0.01) m"
            )
        bad = [name for name in self.variants if not re.fullmatch(r"[a-z0-9_]+", name)]
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
    """Every planning run's learned policy deployed again from inexact starts."""

    # One redeployment of every run per std: the deployment trials from starts offset in x and
    # y by N(0, std²) (`pih redeploy`, docs/planner.md). Empty: none.
    start_std_m: tuple[float, ...] = (0.001,)

    def validate(self, prefix: str = "") -> None:
        stds = [canonical_json(v) for v in self.start_std_m]
        if len(set(stds)) != len(stds):
            raise ConfigError(f"{prefix}start_std_m: {list(self.start_std_m)} repeats a level")


def scene_with(scene: Mapping[str, Any], overrides: Mapping[str, Any], key: str) -> SceneConfig:
    """The scene with dotted-path ``overrides`` (``"solver.time_step_s"``) applied, validated;
    an error names ``key``, the config entry the overrides came from."""
    try:
        data = override({"scene": scene}, {f"scene.{path}": v for path, v in overrides.items()})
        return from_mapping(SceneConfig, data["scene"], "scene")
    except ConfigError as error:
        raise ConfigError(f"{key}: {error}") from None


def config_schema() -> dict[str, Any]:
    sweep_levels = {
        "type": "array",
        "minItems": 1,
        "items": {"type": ["number", "string", "integer", "boolean"]},
    }
    return {
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": "pih study configuration",
        "type": "object",
        "properties": {
            "scene": json_schema(SceneConfig),
            "validation": json_schema(ValidationSection),
            "planner": json_schema(PlannerConfig),
            "sweep": {
                "type": "object",
                "description": "dotted config path -> list of levels; planning runs are the Cartesian product",
                "propertyNames": {
                    "pattern": r"^((scene|planner)(\.[A-Za-z_][A-Za-z0-9_]*)+|variant)$"
                },
                "additionalProperties": sweep_levels,
                "minProperties": 1,
            },
            "variants": {
                "type": "object",
                "description": "named sets of dotted-path overrides, swept by the 'variant' key",
                "additionalProperties": {
                    "type": "object",
                    "propertyNames": {"pattern": r"^(scene|planner)(\.[A-Za-z_][A-Za-z0-9_]*)+$"},
                    "additionalProperties": {"type": ["number", "string", "integer", "boolean"]},
                },
            },
            "robustness": json_schema(RobustnessSection),
            "figure_point": {
                "type": "object",
                "description": "levels of the sweep point whose best paths Fig. 8 shows (per method)",
                "additionalProperties": {"type": ["number", "string", "integer", "boolean"]},
            },
        },
        "required": ["scene", "validation", "planner", "sweep", "figure_point", "robustness"],
        "additionalProperties": False,
    }


OWN_SECTIONS = ("sweep", "variants", "figure_point", "validation.variants")
"""Sections (dotted paths) a config file given with --configfile replaces whole instead of
merging: they define *which* runs exist."""


def read_config_files(
    config: dict[str, Any], default_files: list[str], command_line_files: list[str]
) -> None:
    """Check every config file for repeated keys (YAML lets a later key silently replace a whole
    section) and take the sections that define *which runs* exist (:data:`OWN_SECTIONS`) whole
    from the last command-line file that has them: Snakemake would merge a user's sweep onto the
    default's levels key by key."""
    for path in default_files:
        load_yaml_strictly(path)
    for path in command_line_files:
        data = load_yaml_strictly(path) or {}
        for section in OWN_SECTIONS:
            *parents, leaf = section.split(".")
            source, target = data, config
            for key in parents:
                source, target = source.get(key) or {}, target.setdefault(key, {})
            if isinstance(source, dict) and leaf in source:
                target[leaf] = source[leaf]


def load_yaml_strictly(path: str) -> Any:
    """YAML that rejects a repeated key, and reports a syntax error, naming the file and line."""
    import yaml

    class Loader(yaml.SafeLoader):
        def construct_mapping(self, node, deep=False):  # type: ignore[override]
            seen: set[Any] = set()
            for key_node, _ in node.value:
                key = self.construct_object(key_node, deep=deep)
                if key in seen:
                    line = key_node.start_mark.line + 1
                    raise ConfigError(f"{path}, line {line}: key {key!r} appears twice")
                seen.add(key)
            return super().construct_mapping(node, deep=deep)

    with open(path) as handle:
        try:
            return yaml.load(handle, Loader=Loader)
        except yaml.MarkedYAMLError as error:
            mark = error.problem_mark or error.context_mark
            where = f", line {mark.line + 1}, column {mark.column + 1}" if mark else ""
            raise ConfigError(f"{path}{where}: not valid YAML ({error.problem})") from None


def validation_scenes(config: Mapping[str, Any]) -> dict[str, dict[str, Any]]:
    """Each validation variant's resolved scene, as a plain mapping."""
    section = from_mapping(ValidationSection, config["validation"], "validation")
    return {v: to_mapping(section.scene(config["scene"], v)) for v in section.variants}


def check_study(config: Mapping[str, Any], points: list[Mapping[str, Any]]) -> None:
    """Validate every section, every variant and every sweep point strictly, before any job."""
    validation_scenes(config)
    for name in config.get("variants") or {}:
        data = override(config, {"variant": name})
        from_mapping(SceneConfig, data["scene"], f"variants.{name}: scene")
        from_mapping(PlannerConfig, data["planner"], f"variants.{name}: planner")
    robustness = from_mapping(RobustnessSection, config["robustness"], "robustness")
    for point in points or [{}]:
        data = override(config, point)
        from_mapping(SceneConfig, data["scene"], "scene")
        planner = from_mapping(PlannerConfig, data["planner"], "planner")
        for std in robustness.start_std_m:
            try:
                replace(planner, deploy_start_std_m=std)
            except ConfigError as error:
                raise ConfigError(f"robustness.start_std_m: {error}") from None
    figure_point = config["figure_point"]
    unknown = sorted(set(figure_point) - set(config["sweep"]))
    if unknown:
        raise ConfigError(f"figure_point: {unknown} are not sweep keys ({sorted(config['sweep'])})")
    if points and not any(all(p[k] == v for k, v in figure_point.items()) for p in points):
        raise ConfigError(
            f"figure_point: {dict(figure_point)} is not a sweep point, so Fig. 8 would show no "
            "run; use levels from sweep"
        )
