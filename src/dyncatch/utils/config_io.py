"""Dataclass configs to JSON-able dicts and back (checkpoint headers, run records).

``from_dict(cls, d)`` rebuilds nested dataclasses (flax-struct configs included) and turns
JSON lists back into tuples where the field's default is a tuple; unknown keys are refused
with the field's dotted name, so a header from another version of the code fails loudly.
"""

from __future__ import annotations

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
        elif isinstance(current, tuple) and isinstance(value, list):
            kwargs[name] = tuple(value)
        else:
            kwargs[name] = value
    return dataclasses.replace(default, **kwargs)
