"""Typed, validated configuration: nested frozen dataclasses built from plain mappings (YAML).

Every section is a frozen dataclass with defaults (for use from Python) and a ``validate`` method
for ranges. :func:`from_mapping` builds one from a mapping *strictly*: every field must be present,
no unknown key is allowed, and types are checked, so a config file is complete and explicit. Errors
are :class:`ConfigError` naming the dotted key (``scene.material.friction``) and what is allowed.
"""

from __future__ import annotations

import dataclasses
import json
import math
import types
import typing
from collections.abc import Mapping
from typing import Any, Literal, TypeVar, get_args, get_origin

T = TypeVar("T")


class ConfigError(ValueError):
    """A configuration value is missing, of the wrong type, or outside its allowed range."""


def require(condition: bool, key: str, allowed: str, value: Any) -> None:
    """Raise :class:`ConfigError` naming ``key`` unless ``condition`` holds."""
    if not condition:
        raise ConfigError(f"{key}: {value!r} is not allowed; expected {allowed}")


def require_positive(
    obj: Any, names: tuple[str, ...], prefix: str, *, allow_zero: bool = False
) -> None:
    """Each named field of ``obj`` is finite and > 0 (or >= 0 with ``allow_zero``)."""
    for name in names:
        value = getattr(obj, name)
        ok = math.isfinite(value) and (value >= 0 if allow_zero else value > 0)
        require(ok, prefix + name, f"a finite value {'>=' if allow_zero else '>'} 0", value)


def require_finite(key: str, value: float | tuple[float, ...]) -> None:
    values = value if isinstance(value, tuple) else (value,)
    require(all(math.isfinite(v) for v in values), key, "finite number(s)", value)


def _coerce(tp: Any, value: Any, key: str) -> Any:
    origin = get_origin(tp)
    if dataclasses.is_dataclass(tp):
        return _build(tp, value, key)
    if origin is dict and get_origin(get_args(tp)[1]) is dict:
        # Named sets of overrides (variants).
        require(isinstance(value, Mapping), key, "a mapping of names to override mappings", value)
        return {
            str(name): _coerce(get_args(tp)[1], v, f"{key}.{name}") for name, v in value.items()
        }
    if origin is dict:
        # Dotted-path overrides: the keys are checked where they are applied.
        ok = isinstance(value, Mapping) and all(
            isinstance(k, str) and isinstance(v, (int, float, str, bool)) for k, v in value.items()
        )
        require(ok, key, "a mapping of dotted config paths to numbers, strings or booleans", value)
        return dict(value)
    if origin is Literal:
        require(value in get_args(tp), key, f"one of {list(get_args(tp))}", value)
        return value
    if origin in (typing.Union, types.UnionType):
        args = [a for a in get_args(tp) if a is not type(None)]
        if value is None:
            require(type(None) in get_args(tp), key, "a value (not null)", value)
            return None
        return _coerce(args[0], value, key)
    if origin is tuple:
        args = get_args(tp)
        require(isinstance(value, (list, tuple)), key, f"a list of {len(args)} numbers", value)
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_coerce(args[0], v, f"{key}[{i}]") for i, v in enumerate(value))
        require(len(value) == len(args), key, f"a list of exactly {len(args)} values", value)
        return tuple(_coerce(a, v, f"{key}[{i}]") for i, (a, v) in enumerate(zip(args, value)))
    if tp is float:
        ok = isinstance(value, (int, float)) and not isinstance(value, bool)
        require(ok, key, "a number", value)
        return float(value)
    if tp is int:
        require(isinstance(value, int) and not isinstance(value, bool), key, "an integer", value)
        return value
    if tp is bool:
        require(isinstance(value, bool), key, "true or false", value)
        return value
    if tp is str:
        require(isinstance(value, str), key, "a string", value)
        return value
    raise TypeError(f"{key}: unsupported field type {tp!r}")


def from_mapping(cls: type[T], data: Any, key: str = "") -> T:
    """Build dataclass ``cls`` from ``data`` and validate it; every field required, unknown keys
    rejected. ``key`` is the dotted path of ``data`` in the whole configuration, for messages."""
    obj = _build(cls, data, key)
    validate = getattr(obj, "validate", None)
    if validate is not None:
        validate(f"{key}." if key else "")
    return obj


def _build(cls: type[T], data: Any, key: str) -> T:
    where = key or cls.__name__
    if not isinstance(data, Mapping):
        raise ConfigError(f"{where}: expected a mapping of {cls.__name__} fields, got {data!r}")
    hints = typing.get_type_hints(cls)
    fields = [f.name for f in dataclasses.fields(cls) if f.init]
    unknown = sorted(set(data) - set(fields))
    if unknown:
        raise ConfigError(f"{where}: unknown key(s) {unknown}; allowed keys are {fields}")
    missing = [f for f in fields if f not in data]
    if missing:
        raise ConfigError(f"{where}: missing key(s) {missing}")
    prefix = f"{key}." if key else ""
    return cls(**{f: _coerce(hints[f], data[f], prefix + f) for f in fields})


def with_defaults(cls: type, data: Mapping[str, Any]) -> dict[str, Any]:
    """``data`` with the keys it lacks filled in from ``cls()``'s defaults, at every level: the
    config of a record written before those keys existed (a new key's default keeps the
    behaviour from before it)."""

    def overlay(base: dict[str, Any], over: Mapping[str, Any]) -> dict[str, Any]:
        for name, value in over.items():
            nested = isinstance(value, Mapping) and isinstance(base.get(name), dict)
            base[name] = overlay(base[name], value) if nested else value
        return base

    return overlay(to_mapping(cls()), data)


def recorded_config(cls: type[T], config: Mapping[str, Any], key: str) -> T:
    """Section ``key`` of a recorded config (a provenance record's) as ``cls``. A record written
    before a key existed reads with that key's default (its behaviour from before the key)."""
    return from_mapping(cls, with_defaults(cls, config[key]), key)


def to_mapping(obj: Any) -> dict[str, Any]:
    """Plain nested dict (tuples as lists) of a config dataclass, the inverse of from_mapping."""
    return json.loads(json.dumps(dataclasses.asdict(obj)))


def json_schema(tp: Any) -> dict[str, Any]:
    """JSON schema (2020-12) of a config dataclass or field type: types, required keys, enums.
    Ranges are checked by each dataclass's ``validate``."""
    origin = get_origin(tp)
    if dataclasses.is_dataclass(tp):
        hints = typing.get_type_hints(tp)
        names = [f.name for f in dataclasses.fields(tp) if f.init]
        doc = (tp.__doc__ or "").strip()
        generated = doc.startswith(f"{tp.__name__}(")  # dataclass's own signature docstring
        return {
            "type": "object",
            "description": tp.__name__ if generated or not doc else doc.splitlines()[0],
            "properties": {name: json_schema(hints[name]) for name in names},
            "required": names,
            "additionalProperties": False,
        }
    if origin is Literal:
        return {"enum": list(get_args(tp))}
    if origin is dict and get_origin(get_args(tp)[1]) is dict:
        return {"type": "object", "additionalProperties": json_schema(get_args(tp)[1])}
    if origin is dict:
        return {
            "type": "object",
            "additionalProperties": {"type": ["number", "string", "integer", "boolean"]},
        }
    if origin is tuple:
        args = get_args(tp)
        if len(args) == 2 and args[1] is Ellipsis:
            return {"type": "array", "items": json_schema(args[0])}
        return {
            "type": "array",
            "prefixItems": [json_schema(a) for a in args],
            "minItems": len(args),
            "maxItems": len(args),
        }
    simple = {float: "number", int: "integer", bool: "boolean", str: "string"}
    if tp in simple:
        return {"type": simple[tp]}
    raise TypeError(f"no JSON schema for {tp!r}")
