"""Dataclass configs to JSON-able dicts and back (checkpoint headers, run records).

``from_dict(cls, d)`` rebuilds nested dataclasses (flax-struct configs included) and turns
JSON lists back into tuples where the field's default is a tuple; unknown keys are refused
with the field's dotted name, so a header from another version of the code fails loudly.
Each value must have its default's type (a bool for a bool, a number for a float, a string
for a string, a list of such for a tuple); a field whose default is None takes anything.
"""

from __future__ import annotations

import copy
import dataclasses
from typing import Any


class ConfigDictError(ValueError):
    """A dict that does not describe the expected config; the message names the field."""


def from_dict(cls: type, d: dict, where: str = "") -> Any:
    if not isinstance(d, dict):
        raise ConfigDictError(
            f"{where or cls.__name__}: expected an object, got {type(d).__name__}"
        )
    fields = {f.name: f for f in dataclasses.fields(cls)}
    unknown = sorted(set(d) - set(fields))
    if unknown:
        name = f"{where}." if where else ""
        raise ConfigDictError(f"unknown config field {name}{unknown[0]} for {cls.__name__}")
    default = cls()
    kwargs = {}
    for name, value in d.items():
        current = getattr(default, name)
        path = f"{where}.{name}" if where else name
        if dataclasses.is_dataclass(current):
            kwargs[name] = from_dict(type(current), value, path)
        else:
            kwargs[name] = _typed(value, current, path)
    return dataclasses.replace(default, **kwargs)


def _kind(default: Any) -> str:
    for t, name in ((bool, "a boolean"), (int, "an integer"), (float, "a number")):
        if isinstance(default, t):
            return name
    return "a string" if isinstance(default, str) else type(default).__name__


def _typed(value: Any, default: Any, path: str) -> Any:
    """``value`` as the type of ``default``, or ConfigDictError naming ``path``."""
    ok = True
    if default is None:
        return value
    if isinstance(default, bool):
        ok = isinstance(value, bool)
    elif isinstance(default, int):
        ok = isinstance(value, int) and not isinstance(value, bool)
    elif isinstance(default, float):
        ok = isinstance(value, int | float) and not isinstance(value, bool)
        value = float(value) if ok else value
    elif isinstance(default, str):
        ok = isinstance(value, str)
    elif isinstance(default, tuple):
        ok = isinstance(value, list | tuple)
        if ok:
            like = default[0] if default else None
            return tuple(_typed(v, like, f"{path}[{i}]") for i, v in enumerate(value))
    if not ok:
        raise ConfigDictError(f"{path} is {value!r}, expected {_kind(default)}")
    return value


def to_json(cfg: Any) -> Any:
    """A config (nested dataclasses, tuples, paths) as JSON values (tuples become lists,
    paths strings)."""
    import json

    d = dataclasses.asdict(cfg) if dataclasses.is_dataclass(cfg) else cfg
    return json.loads(json.dumps(d, default=str))


def flatten(d: Any, prefix: str = "") -> dict[str, Any]:
    """Nested dicts as one dict with dotted keys (``{"a": {"b": 1}}`` -> ``{"a.b": 1}``)."""
    if not isinstance(d, dict):
        return {prefix: d}
    out: dict[str, Any] = {}
    for k, v in d.items():
        out.update(flatten(v, f"{prefix}.{k}" if prefix else str(k)))
    return out


def fill_missing(d: dict, values: dict[str, Any]) -> dict:
    """``d`` (nested dicts) with each dotted key of ``values`` that it lacks set to its value
    (``fill_missing({"a": {}}, {"a.b": 1})`` -> ``{"a": {"b": 1}}``); ``d`` is not changed.
    Keys ``d`` has, and non-dict values on the way, are left as they are."""
    out = copy.deepcopy(d)
    for key, value in values.items():
        *groups, name = key.split(".")
        node = out
        for g in groups:
            node = node.setdefault(g, {})
            if not isinstance(node, dict):
                break
        else:
            node.setdefault(name, value)
    return out


def config_diff(old: Any, new: Any) -> dict[str, tuple[Any, Any]]:
    """Dotted field names whose values differ between two configs (or their JSON dicts),
    mapped to ``(old, new)``; a field missing on one side reads as None."""
    a, b = flatten(to_json(old)), flatten(to_json(new))
    return {k: (a.get(k), b.get(k)) for k in sorted(set(a) | set(b)) if a.get(k) != b.get(k)}
