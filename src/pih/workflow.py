"""The study's configuration file: its JSON schema and its typed sections.

``config/config.yaml`` has sections ``scene``, ``validation``, ``planner``, ``sweep`` and
``figure_point``; :func:`config_schema` is what ``workflow/schemas/config.schema.json`` holds
(``python -m pih schema`` regenerates it; a test checks they agree).
"""

from __future__ import annotations

import logging
import traceback
from collections.abc import Iterator, Mapping
from contextlib import contextmanager, redirect_stderr, redirect_stdout
from dataclasses import dataclass, field
from typing import Any

from pih import provenance
from pih.config import ConfigError, from_mapping, json_schema
from pih.planner import PlannerConfig
from pih.scene import SceneConfig
from pih.study import override
from pih.validation import ValidationConfig, validation_scene_config


@dataclass(frozen=True)
class ValidationSection:
    """The hydroelastic-vs-Whitney validation runs."""

    offsets_m: tuple[float, ...] = (0.0005, 0.001, 0.0015, 0.002)
    contact_models: tuple[str, ...] = ("hydroelastic", "point")
    experiment: ValidationConfig = field(default_factory=ValidationConfig)
    # Scene settings of the validation runs that differ from the planner's scene, as dotted
    # paths under `scene` (e.g. "hole.fillet_radius_m"); docs/validation.md says why.
    scene_overrides: dict[str, Any] = field(default_factory=dict)

    def validate(self, prefix: str = "") -> None:
        if not self.offsets_m or any(not (0 < o < 0.01) for o in self.offsets_m):
            raise ConfigError(
                f"{prefix}offsets_m: {self.offsets_m!r}; expected lateral offsets in (0, 0.01) m"
            )
        allowed = ("hydroelastic", "hydroelastic_with_fallback", "point")
        bad = [m for m in self.contact_models if m not in allowed]
        if not self.contact_models or bad:
            raise ConfigError(
                f"{prefix}contact_models: {list(self.contact_models)!r}; expected a non-empty list of {list(allowed)}"
            )
        self.experiment.validate(prefix + "experiment.")

    def scene(self, scene: Mapping[str, Any], contact_model: str) -> SceneConfig:
        """The validation runs' scene: the study's scene with ``scene_overrides`` and the
        contact model applied, and a hole deep enough for the whole insertion."""
        point = {f"scene.{path}": value for path, value in self.scene_overrides.items()}
        try:
            data = override({"scene": scene}, point)
            base = from_mapping(SceneConfig, data["scene"], "scene")
            return validation_scene_config(
                base.replace(solver__contact_model=contact_model), self.experiment
            )
        except ConfigError as error:
            raise ConfigError(f"validation.scene_overrides: {error}") from None


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
            "figure_point": {
                "type": "object",
                "description": "levels of the sweep point whose best paths Fig. 8 shows (per method)",
                "additionalProperties": {"type": ["number", "string", "integer", "boolean"]},
            },
        },
        "required": ["scene", "validation", "planner", "sweep", "figure_point"],
        "additionalProperties": False,
    }


OWN_SECTIONS = ("sweep", "variants", "figure_point")
"""Sections a config file given with --configfile replaces whole instead of merging."""


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
            if section in data:
                config[section] = data[section]


def load_yaml_strictly(path: str) -> Any:
    """YAML that rejects a repeated key, naming the file and line."""
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
        return yaml.load(handle, Loader=Loader)


def check_study(config: Mapping[str, Any], points: list[Mapping[str, Any]]) -> None:
    """Validate every section, every variant and every sweep point strictly, before any job."""
    section = from_mapping(ValidationSection, config["validation"], "validation")
    for model in section.contact_models:
        section.scene(config["scene"], model)
    for name in config.get("variants") or {}:
        data = override(config, {"variant": name})
        from_mapping(SceneConfig, data["scene"], f"variants.{name}: scene")
        from_mapping(PlannerConfig, data["planner"], f"variants.{name}: planner")
    for point in points or [{}]:
        data = override(config, point)
        from_mapping(SceneConfig, data["scene"], "scene")
        from_mapping(PlannerConfig, data["planner"], "planner")
    unknown = sorted(set(config["figure_point"]) - set(config["sweep"]))
    if unknown:
        raise ConfigError(f"figure_point: {unknown} are not sweep keys ({sorted(config['sweep'])})")


@contextmanager
def logged(path: str) -> Iterator[None]:
    """Send a job's stdout/stderr (and Python warnings) to its log file."""
    with open(path, "w") as log, redirect_stdout(log), redirect_stderr(log):
        logging.basicConfig(stream=log, level=logging.INFO, force=True)
        logging.captureWarnings(True)
        try:
            yield
        except BaseException:
            traceback.print_exc(file=log)  # the job's log keeps the traceback too
            raise


def job_provenance(
    smk: Any, step: str, *, point: Mapping[str, Any] | None = None, **fields: Any
) -> dict[str, Any]:
    """Provenance of a Snakemake job: the step, its wildcards/sweep point and input hashes."""
    wildcards = {k: v for k, v in dict(smk.wildcards).items()}
    return provenance.record(
        step, point=point if point is not None else wildcards, inputs=list(smk.input), **fields
    )
