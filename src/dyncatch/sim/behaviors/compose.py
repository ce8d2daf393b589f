"""``TargetCfg`` built from the body config and every registered behaviour's config class.

The composed class inherits from each ``cfg_cls``, so ``isinstance(world.target, CircleCfg)``
holds, every field keeps its docstring for ``--help``, and the flag and header names stay
``target.<field>`` whichever behaviour declares the field.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Iterable

from flax import struct

from dyncatch.sim.behaviors.base import Behavior, TargetBodyCfg


def _default(f: dataclasses.Field):
    if f.default is not dataclasses.MISSING:
        return f.default
    if f.default_factory is not dataclasses.MISSING:
        return f.default_factory()
    return dataclasses.MISSING


def _owner(cls: type, name: str) -> str:
    """The class that declares field ``name`` (the first in the MRO that annotates it)."""
    for base in cls.__mro__:
        if name in base.__dict__.get("__annotations__", {}):
            return base.__qualname__
    return cls.__qualname__


def field_conflicts(cfg_classes: Iterable[type]) -> list[str]:
    """One line per field that lacks a default or has two different defaults."""
    seen: dict[str, tuple[object, str]] = {}
    problems = []
    for cls in cfg_classes:
        for f in dataclasses.fields(cls):
            default, owner = _default(f), _owner(cls, f.name)
            if default is dataclasses.MISSING:
                problems.append(f"{owner}.{f.name} has no default; give it one")
            elif f.name not in seen:
                seen[f.name] = (default, owner)
            elif seen[f.name][0] != default:
                first_default, first_owner = seen[f.name]
                problems.append(
                    f"target.{f.name} is declared by {first_owner} (default {first_default!r}) "
                    f"and by {owner} (default {default!r}); rename one or use one default"
                )
    return problems


def cfg_classes(behaviors: Iterable[Behavior]) -> list[type]:
    """The distinct config classes of ``behaviors``, the body's first, in registration order."""
    out = [TargetBodyCfg]
    for b in behaviors:
        if b.cfg_cls is not None and b.cfg_cls not in out:
            out.append(b.cfg_cls)
    return out


def compose_target_cfg(behaviors: Iterable[Behavior], doc: str) -> type:
    """A frozen ``struct.dataclass`` whose fields are the body's and every behaviour's.

    Raises TypeError when two config classes declare one field with different defaults.
    Fields are ordered body first, then by registration order.
    """
    classes = cfg_classes(behaviors)
    problems = field_conflicts(classes)
    if problems:
        raise TypeError("cannot compose TargetCfg:\n  " + "\n  ".join(problems))
    # A class already inherited by another one (RandomReactiveCfg(ReactiveCfg)) is not repeated,
    # and dataclasses orders fields from the last base to the first: reverse the list.
    leaves = [c for c in classes if not any(o is not c and issubclass(o, c) for o in classes)]
    namespace = {"__doc__": doc, "__module__": __name__.rsplit(".", 1)[0]}
    return struct.dataclass(type("TargetCfg", tuple(reversed(leaves)), namespace))


def missing_fields(cfg_cls: type | None, target_cfg: type) -> list[str]:
    """Fields of ``cfg_cls`` that ``target_cfg`` lacks or defaults differently, one line each."""
    if cfg_cls is None:
        return []
    have = {f.name: _default(f) for f in dataclasses.fields(target_cfg)}
    out = []
    for f in dataclasses.fields(cfg_cls):
        if f.name not in have:
            out.append(f"target.{f.name} (not a field of TargetCfg)")
        elif have[f.name] != _default(f):
            out.append(f"target.{f.name} (default {_default(f)!r}, TargetCfg's {have[f.name]!r})")
    return out
