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
from typing import Any, Literal, get_args, get_origin

import numpy as np


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
        nested = (
            [k for k, v in value.items() if isinstance(v, Mapping)]
            if isinstance(value, Mapping)
            else []
        )
        if nested:
            raise ConfigError(f"{key}: {_dotted_hint(nested[0], value[nested[0]])}")
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


def from_mapping[T](cls: type[T], data: Any, key: str = "") -> T:
    """Build dataclass ``cls`` from ``data`` and validate it; every field required, unknown keys
    rejected. ``key`` is the dotted path of ``data`` in the whole configuration, for messages."""
    obj = _build(cls, data, key)
    validate = getattr(obj, "validate", None)
    if validate is not None:
        validate(f"{key}." if key else "")
    return obj


def _build[T](cls: type[T], data: Any, key: str) -> T:
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
    for field in dataclasses.fields(cls):
        removed = field.metadata.get("removed", {})
        value = data.get(field.name)
        if isinstance(value, str) and value in removed:
            raise ConfigError(
                f"{prefix}{field.name}: {value!r} is no longer available: {removed[value]}"
            )
    return cls(**{f: _coerce(hints[f], data[f], prefix + f) for f in fields})


def with_defaults(cls: type, data: Mapping[str, Any]) -> dict[str, Any]:
    """``data`` with the keys it lacks filled in from ``cls()``'s defaults, at every level: the
    config of a record written before those keys existed (a new key's default keeps the
    behaviour from before it). A mapping-valued key (not a config dataclass) is taken as
    recorded: merging its default entries in would add entries the record never had."""
    defaults = cls()
    filled = dict(data)
    for field in (f for f in dataclasses.fields(cls) if f.init):
        default = getattr(defaults, field.name)
        if field.name not in data:
            plain = dataclasses.asdict(default) if dataclasses.is_dataclass(default) else default
            filled[field.name] = json.loads(json.dumps(plain))
        elif dataclasses.is_dataclass(default) and isinstance(data[field.name], Mapping):
            filled[field.name] = with_defaults(type(default), data[field.name])
    return filled


def recorded_config[T](cls: type[T], config: Mapping[str, Any], key: str) -> T:
    """Section ``key`` of a recorded config (a provenance record's) as ``cls``. A record written
    before a key existed reads with that key's default (its behaviour from before the key)."""
    return from_mapping(cls, with_defaults(cls, config[key]), key)


def described(
    default: Any = dataclasses.MISSING,
    description: str = "",
    *,
    default_factory: Any = dataclasses.MISSING,
    removed: Mapping[str, str] | None = None,
) -> Any:
    """A config dataclass field with what its key means: :func:`json_schema` gives it as the
    key's ``description``, and docs/configuration.md (:func:`markdown_tables`) shows it.
    ``removed`` maps values the key once allowed to why they no longer are."""
    metadata = {"description": description, "removed": dict(removed or {})}
    return dataclasses.field(default=default, default_factory=default_factory, metadata=metadata)


def to_mapping(obj: Any) -> dict[str, Any]:
    """Plain nested dict (tuples as lists) of a config dataclass, the inverse of from_mapping."""
    return json.loads(json.dumps(dataclasses.asdict(obj)))


def json_schema(tp: Any) -> dict[str, Any]:
    """JSON schema (2020-12) of a config dataclass or field type: types, required keys, enums.
    Ranges are checked by each dataclass's ``validate``."""
    origin = get_origin(tp)
    if dataclasses.is_dataclass(tp):
        hints = typing.get_type_hints(tp)
        fields = [f for f in dataclasses.fields(tp) if f.init]
        properties = {}
        for f in fields:
            properties[f.name] = json_schema(hints[f.name])
            if f.metadata.get("description"):
                properties[f.name]["description"] = f.metadata["description"]
            if f.metadata.get("removed"):
                properties[f.name]["x-removed"] = f.metadata["removed"]
        return {
            "type": "object",
            "description": _summary(tp),
            "properties": properties,
            "required": [f.name for f in fields],
            "additionalProperties": False,
        }
    if origin is Literal:
        return {"enum": list(get_args(tp))}
    if origin in (typing.Union, types.UnionType) and type(None) in get_args(tp):
        (inner,) = (a for a in get_args(tp) if a is not type(None))
        return {"anyOf": [json_schema(inner), {"type": "null"}]}
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


def _summary(cls: type) -> str:
    """The first paragraph of a config dataclass's docstring, on one line, else its name."""
    doc = (cls.__doc__ or "").strip()
    generated = doc.startswith(f"{cls.__name__}(")  # dataclass's own signature docstring
    return cls.__name__ if generated or not doc else " ".join(doc.split("\n\n")[0].split())


def markdown_tables(cls: type, key: str, level: int = 2) -> str:
    """docs/configuration.md's part for config dataclass ``cls`` at dotted ``key``: a heading and
    a table of its keys (type, default, description), then one such part per nested section."""
    hints = typing.get_type_hints(cls)
    defaults = to_mapping(cls())
    rows, nested = [], []
    for f in dataclasses.fields(cls):
        if not f.init:
            continue
        if dataclasses.is_dataclass(hints[f.name]):
            nested.append(markdown_tables(hints[f.name], f"{key}.{f.name}", level + 1))
            rows.append((f.name, "section", "", f"see `{key}.{f.name}` below"))
            continue
        schema = json_schema(hints[f.name])
        rows.append(
            (
                f.name,
                markdown_type(schema),
                f"`{_yaml_text(defaults[f.name])}`",
                f.metadata.get("description", ""),
            )
        )
    table = ["| key | type | default | description |", "|---|---|---|---|"]
    table += [
        f"| `{name}` | {kind} | {default} | {_cell(text)} |" for name, kind, default, text in rows
    ]
    part = f"{'#' * level} `{key}`\n\n{_summary(cls)}\n\n" + "\n".join(table) + "\n"
    return "\n".join([part, *nested])


def markdown_type(schema: Mapping[str, Any]) -> str:
    """A key's JSON schema as the type column of docs/configuration.md."""
    if "anyOf" in schema:
        return " or ".join(markdown_type(option) for option in schema["anyOf"])
    if "enum" in schema:
        return " \\| ".join(f"`{_yaml_text(v)}`" for v in schema["enum"])
    kind = schema.get("type")
    if kind == "array" and "prefixItems" in schema:
        return "[" + ", ".join(markdown_type(item) for item in schema["prefixItems"]) + "]"
    if kind == "array":
        return f"list of {markdown_type(schema['items'])}"
    if kind == "object":
        inner = schema.get("additionalProperties")
        if isinstance(inner, Mapping) and inner.get("type") == "object":
            return "mapping of names to mappings"
        return "mapping"
    if isinstance(kind, list):
        return " or ".join(kind)
    return str(kind)


def _yaml_text(value: Any) -> str:
    """A default as a config file writes it (YAML flow style): names bare, small and large
    numbers as ``2.0e+10`` (YAML 1.1, PyYAML's, reads ``2e10`` as a string)."""
    if isinstance(value, bool) or value is None:
        return json.dumps(value)
    if isinstance(value, float) and value != 0 and not 1e-3 <= abs(value) < 1e5:
        mantissa, exponent = f"{value:.15e}".split("e")
        mantissa = mantissa.rstrip("0")
        short = f"{mantissa}{'0' if mantissa.endswith('.') else ''}e{int(exponent):+d}"
        return short if float(short) == value else repr(value)
    if isinstance(value, (list, tuple)):
        return "[" + ", ".join(_yaml_text(v) for v in value) + "]"
    if isinstance(value, Mapping):
        return "{" + ", ".join(f"{k}: {_yaml_text(v)}" for k, v in value.items()) + "}"
    return str(value) if isinstance(value, str) else repr(value)


def _cell(text: str) -> str:
    """Text for one Markdown table cell: one line, ``|`` escaped."""
    return " ".join(text.split()).replace("|", "\\|")


def plain(value: Any) -> Any:
    """A numpy scalar as the Python value it holds (Paramspace gives numpy scalars)."""
    return value.item() if isinstance(value, np.generic) else value


def set_paths(config: dict[str, Any], paths: Mapping[str, Any], where: str) -> None:
    """Set each dotted path of ``paths`` in ``config``, in place; an error names the path after
    ``where``, the config entry the paths came from."""
    for path, value in paths.items():
        node = config
        *parents, leaf = str(path).split(".")
        for depth, key in enumerate(parents):
            if not isinstance(node.get(key), dict):
                section = ".".join(parents[: depth + 1])
                raise ConfigError(f"{where}{path}: {section!r} is not a config section")
            node = node[key]
        if leaf not in node:
            section = ".".join(parents)
            raise ConfigError(
                f"{where}{path}: no config key {leaf!r} in {section or 'the config'}; "
                f"allowed: {sorted(node)}"
            )
        if isinstance(value, Mapping) and isinstance(node[leaf], dict) and node[leaf]:
            # A nested mapping would replace the whole section, dropping the keys it lacks.
            raise ConfigError(f"{where}{path}: {_dotted_hint(str(path), value)}")
        node[leaf] = plain(value)


def _dotted_hint(path: str, section: Mapping[str, Any]) -> str:
    """What to write instead of a nested mapping at dotted ``path``: its first setting as a
    dotted path."""
    while isinstance(section, Mapping) and section:
        name, section = next(iter(section.items()))
        path = f"{path}.{name}"
    return f"a nested mapping; write each setting as a dotted path, e.g. {path}: {section!r}"
