"""A scene with dotted-path overrides applied (``solver.time_step_s: 1e-4``): a validation
variant, a model error, a ``--set`` on the command line. Outside the rollout's and the
validation's code hashes (:mod:`pih.records.provenance`): what a scene computes is its config,
however the config was made."""

from __future__ import annotations

import copy
from collections.abc import Mapping
from contextlib import suppress
from typing import Any

import yaml

from pih.config import ConfigError, from_mapping, set_paths
from pih.scene.config import SceneConfig


def scene_with(scene: Mapping[str, Any], overrides: Mapping[str, Any], key: str) -> SceneConfig:
    """The scene with dotted-path ``overrides`` applied, validated. ``key`` is the config entry
    the overrides came from, and every message names a scene key under it as the user writes it
    (``validation.scene_overrides.solver.time_step_s``); a check across fields may name a key
    the overrides did not set, which is then where to set it."""
    data = copy.deepcopy(dict(scene))
    set_paths(data, overrides, f"{key}.")
    return from_mapping(SceneConfig, data, key)


def scene_settings(settings: list[str], option: str = "--set") -> dict[str, Any]:
    """Dotted scene overrides from command-line ``scene.KEY=VALUE`` settings (values read as
    YAML, never evaluated), for :func:`scene_with`; a step set alone brings its retry at half
    of it, as the study's setting has."""
    overrides = {}
    for setting in settings:
        key, sep, value = setting.partition("=")
        if not sep or not key.startswith("scene."):
            raise ConfigError(f"{option} {setting!r}: expected scene.<section>.<key>=<value>")
        overrides[key.removeprefix("scene.")] = yaml.safe_load(value)
    step = overrides.get("solver.time_step_s")
    if step is not None and "solver.retry_time_step_s" not in overrides:
        # YAML 1.1 reads 1e-4 (no dot) as a string; the scene's own check names a bad value.
        with suppress(TypeError, ValueError):
            overrides["solver.retry_time_step_s"] = float(step) / 2
            overrides["solver.time_step_s"] = float(step)
    return overrides
