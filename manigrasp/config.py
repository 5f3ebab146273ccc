"""Strict construction of frozen config dataclasses from plain mappings.

A misspelled key is an error that names the nearest valid key; every value
is checked against its field's annotation (an `int` field refuses ``2.5``,
``true`` and ``"abc"``); nested dataclass fields are built recursively; lists
become tuples. Overrides are
``dotted.key=value`` strings whose values are parsed as YAML scalars/lists.
"""

from __future__ import annotations

import collections.abc
import dataclasses
import math
import numbers
import re
import types
import typing
from collections.abc import Mapping, Sequence
from typing import Any, TypeVar

import numpy as np
import yaml

from manigrasp.errors import ConfigError
from manigrasp.registry import nearest

T = TypeVar("T")


OMIT_DEFAULT = "omit_default"
"""Field metadata key: `to_mapping` leaves the field out while it holds its default (a field added later, so
configs that do not use it keep their run identity and run.json)."""

MAX_DEPTH = 20
"""Deepest nesting accepted in free-form parameter values (lists and mappings)."""


def from_mapping(cls: type[T], data: Mapping[str, Any] | None, where: str = "config") -> T:
    """Build dataclass `cls` from `data`, refusing unknown keys with a hint and values of the wrong type.

    A key `cls` names in its class attribute ``RENAMED`` ({old key: what replaced it}) is refused with that text.

    Every value is checked against the field's annotation before the dataclass is built: ``int`` takes
    integers only (not ``true``, not ``2.5``, not ``"3"``), ``float`` takes finite integers or floats,
    ``str`` strings, ``bool`` booleans, ``tuple[X, ...]`` lists of X, a nested dataclass a mapping, and
    ``Mapping[str, Any]`` a mapping of plain YAML data (nested at most `MAX_DEPTH` deep).
    """
    if data is None:
        data = {}
    if not isinstance(data, Mapping):
        raise ConfigError(f"{where}: expected a mapping, got {_kind(data)}")
    data = dict(data)
    fields = {f.name: f for f in dataclasses.fields(cls)}  # type: ignore[arg-type]
    renamed = getattr(cls, "RENAMED", {})
    for key in data:
        if isinstance(key, str) and key in renamed:
            raise ConfigError(f"{where}: {key!r} is no longer a key: {renamed[key]}")
        if not isinstance(key, str) or key not in fields:
            hint = nearest(str(key), list(fields))
            did_you_mean = f"; did you mean {hint!r}?" if hint else ""
            raise ConfigError(f"{where}: unknown key {key!r}{did_you_mean} (valid: {', '.join(fields)})")
    hints = typing.get_type_hints(cls)
    kwargs = {key: _convert(hints[key], value, f"{where}.{key}") for key, value in data.items()}
    try:
        return cls(**kwargs)
    except TypeError as exc:
        raise ConfigError(f"{where}: {exc}") from exc


def _kind(value: Any) -> str:
    """A value's type as a user reads it in YAML terms, with the value when short."""
    names = {bool: "a boolean", int: "an integer", float: "a number", str: "a string", list: "a list",
             tuple: "a list", dict: "a mapping", type(None): "null"}
    name = names.get(type(value), type(value).__name__)
    text = repr(value)
    return f"{name} ({text})" if len(text) <= 40 else name


def _convert(hint: Any, value: Any, where: str) -> Any:
    """`value` checked against the annotation `hint` (and converted: lists to tuples, ints to floats)."""
    origin = typing.get_origin(hint)
    if hint is Any:
        return _plain(value, where)
    if dataclasses.is_dataclass(hint):
        if isinstance(value, hint):
            return value
        return from_mapping(hint, value, where)  # type: ignore[arg-type]
    if origin in (typing.Union, types.UnionType):
        options = typing.get_args(hint)
        if value is None and type(None) in options:
            return None
        errors = []
        for option in (o for o in options if o is not type(None)):
            try:
                return _convert(option, value, where)
            except ConfigError as exc:
                errors.append(exc)
        raise errors[0] if len(errors) == 1 else ConfigError(f"{where}: {_kind(value)} is not one of {hint}")
    if origin is tuple:
        if not isinstance(value, list | tuple):
            raise ConfigError(f"{where}: expected a list, got {_kind(value)}")
        args = typing.get_args(hint)
        if len(args) == 2 and args[1] is Ellipsis:
            return tuple(_convert(args[0], v, f"{where}[{i}]") for i, v in enumerate(value))
        if len(value) != len(args):
            raise ConfigError(f"{where}: expected a list of {len(args)} values, got {len(value)}")
        return tuple(_convert(a, v, f"{where}[{i}]") for i, (a, v) in enumerate(zip(args, value, strict=True)))
    if origin in (Mapping, dict, collections.abc.Mapping):
        if not isinstance(value, Mapping):
            raise ConfigError(f"{where}: expected a mapping, got {_kind(value)}")
        bad = [k for k in value if not isinstance(k, str)]
        if bad:
            raise ConfigError(f"{where}: keys must be strings, got {bad[0]!r}")
        return _plain(dict(value), where)
    return _scalar(hint, value, where)


_EXPONENT = re.compile(r"[-+]?(\d+\.?\d*|\.\d+)[eE][-+]?\d+")


def _scalar(hint: Any, value: Any, where: str) -> Any:
    if hint is bool:
        if not isinstance(value, bool | np.bool_):
            raise ConfigError(f"{where}: expected true or false, got {_kind(value)}")
        return bool(value)
    if hint is int:
        if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Integral):
            raise ConfigError(f"{where}: expected an integer, got {_kind(value)}")
        return int(value)
    if hint is float:
        if isinstance(value, str) and _EXPONENT.fullmatch(value.strip()):
            value = float(value)  # YAML 1.1 (PyYAML) reads 1e-6, without a dot, as a string; YAML 1.2 and JSON do not
        if isinstance(value, bool | np.bool_) or not isinstance(value, numbers.Real):
            raise ConfigError(f"{where}: expected a number, got {_kind(value)}")
        if not math.isfinite(float(value)):
            raise ConfigError(f"{where}: expected a finite number, got {value}")
        return float(value)
    if hint is str:
        if not isinstance(value, str):
            raise ConfigError(f"{where}: expected a string, got {_kind(value)}")
        return value
    return value


def _plain(value: Any, where: str, depth: int = 0) -> Any:
    """`value` if it is plain YAML data (null, booleans, numbers, strings, lists, string-keyed mappings)."""
    if depth > MAX_DEPTH:
        raise ConfigError(f"{where}: nested more than {MAX_DEPTH} levels deep")
    if value is None or isinstance(value, bool | int | float | str):
        return value
    if isinstance(value, list | tuple):
        return [_plain(v, f"{where}[{i}]", depth + 1) for i, v in enumerate(value)]
    if isinstance(value, Mapping):
        bad = [k for k in value if not isinstance(k, str)]
        if bad:
            raise ConfigError(f"{where}: keys must be strings, got {bad[0]!r}")
        return {k: _plain(v, f"{where}.{k}", depth + 1) for k, v in value.items()}
    raise ConfigError(f"{where}: {_kind(value)} is not plain data (null, boolean, number, string, list, mapping)")


def to_mapping(obj: Any) -> Any:
    """A dataclass (recursively) as plain dicts, lists and scalars (for run.json); a field marked `OMIT_DEFAULT`
    is left out while it holds its default, and so is one not set at construction (``init=False``: a planner's
    caches are not its parameters)."""
    if dataclasses.is_dataclass(obj):
        return {f.name: to_mapping(getattr(obj, f.name)) for f in dataclasses.fields(obj)
                if f.init and not (f.metadata.get(OMIT_DEFAULT) and getattr(obj, f.name) == f.default)}
    if isinstance(obj, Mapping):
        return {k: to_mapping(v) for k, v in obj.items()}
    if isinstance(obj, list | tuple):
        return [to_mapping(v) for v in obj]
    return obj


def apply_overrides(data: dict[str, Any], overrides: Sequence[str]) -> dict[str, Any]:
    """Apply ``a.b.c=value`` overrides to a nested dict (a copy); values are YAML-parsed."""
    data = yaml.safe_load(yaml.safe_dump(data))  # deep copy of plain data
    for item in overrides:
        key, sep, raw = item.partition("=")
        if not sep or not key:
            raise ConfigError(f"override {item!r} is not of the form key=value")
        try:
            value = yaml.safe_load(raw)
        except yaml.YAMLError as exc:
            problem = " ".join(str(getattr(exc, "problem", None) or exc).split())
            hint = (" (a list or mapping with spaces is split by the shell: write it without spaces, "
                    f"{key}=[a,b], or quote it, '{key}=[a, b]')" if raw.lstrip()[:1] in "[{" else "")
            raise ConfigError(f"override {item!r}: cannot parse value: {problem}{hint}") from exc
        node = data
        parts = key.split(".")
        for part in parts[:-1]:
            child = node.setdefault(part, {})
            if not isinstance(child, dict):
                raise ConfigError(f"override {item!r}: {part!r} is not a section")
            node = child
        node[parts[-1]] = value
    return data
