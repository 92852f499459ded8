"""A sweep point: which of its keys choose the method and which the situation (a run's
draws depend only on the situation, so the methods at one point share them), the seed key
derived from it, the overrides its ``variant`` level stands for, and a recorded point in
today's keys. Imports no simulator and no validation: a planning job's code is what it reaches,
and editing the validation's config re-runs no planning run."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

from pih.config import ConfigError, plain
from pih.planning.config import ONE_LEVEL
from pih.records.provenance import canonical_json

GOAL_KEY = "planner.goal"
"""The sweep key of the method: the DMP's goal (one-level's sensed hole, or an outer rule)."""
OUTER_PREFIX = "planner.outer."
"""Sweep keys under this prefix configure bilevel's outer rules; one-level runs ignore them."""


DEPLOY_KEYS = ("planner.deploy_policy", "planner.deploy_start_std_m")
"""How the learned policy is deployed (which weights, from how exact a start): training is the
same for every level, so these are method keys (shared draws) that one-level runs depend on."""

TRAINING_KEYS = ("planner.train_start_std_m", "planner.simulated_hole")
"""How the policy is trained (from offset starts; on the real or a sensed hole): a method
choice, so these are method keys too (shared draws), and one-level runs depend on them."""
SIMULATOR_PREFIX = "planner.simulator."
"""Sweep keys under this prefix choose the training simulator: training keys as above."""

VARIANT_KEY = "variant"
"""Sweep key whose levels name entries of the config's ``variants`` (one-at-a-time ablations)."""


def is_method_key(path: str) -> bool:
    """Whether a sweep key selects the method (the method, its outer level, or a named variant)
    rather than the situation (start, seed, noise, scene): runs differing only in such keys
    share their random draws (common random numbers), so their comparison is paired."""
    return path in (GOAL_KEY, *DEPLOY_KEYS, *TRAINING_KEYS, VARIANT_KEY) or path.startswith(
        (OUTER_PREFIX, SIMULATOR_PREFIX)
    )


def upgraded_point(point: Mapping[str, Any]) -> dict[str, Any]:
    """A recorded sweep point in today's keys: points from before ``planner.goal`` name the
    method with ``planner.method`` (one_level, bilevel) and ``planner.outer.rule``."""
    point = dict(point)
    if "planner.method" in point:
        method = point.pop("planner.method")
        rule = point.pop("planner.outer.rule", "explored_argmin")
        point[GOAL_KEY] = ONE_LEVEL if method == "one_level" else rule
    return point


def seed_key(point: Mapping[str, Any]) -> str:
    """Stable encoding of a sweep point's non-method levels: the per-run seed is derived from it
    (:func:`pih.planning.planner.run_seeds`), so every other difference gives independent draws."""
    return canonical_json({k: plain(v) for k, v in point.items() if not is_method_key(k)})


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
