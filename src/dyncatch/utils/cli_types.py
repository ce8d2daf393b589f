"""Command-line name types whose choices are read from a registry when the command line is
parsed, so an entry registered at run time is a valid choice with no edit here.

Generic: each registry declares its own name type next to it (``BehaviorName`` beside
``BEHAVIORS``, ``SceneName`` beside ``SCENES``, ...) with ``live_name``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Annotated

import tyro
from tyro.constructors import PrimitiveConstructorSpec


class LiveChoices(Sequence):
    """The keys of a registry, read at every use (tyro checks and lists them)."""

    def __init__(self, keys: Callable[[], Sequence[str]]):
        self._keys = keys

    def __getitem__(self, i):
        return tuple(self._keys())[i]

    def __len__(self) -> int:
        return len(tuple(self._keys()))

    def __hash__(self) -> int:
        return id(self)

    def __eq__(self, other) -> bool:
        return self is other

    def __add__(self, other) -> tuple:
        return tuple(self) + tuple(other)

    def __radd__(self, other) -> tuple:
        return tuple(other) + tuple(self)

    def __repr__(self) -> str:
        return ", ".join(self._keys())


def live_name(keys: Callable[[], Sequence[str]], metavar: str, aliases: tuple[str, ...] = ()):
    """A ``str`` flag type whose choices are ``keys()`` when the command line is parsed.

    ``aliases`` are extra flag names (tyro does not prefix an alias, so a field of a nested
    config reads ``--scene`` as well as ``--world.scene.name``).
    """
    spec = PrimitiveConstructorSpec(
        nargs=1,
        metavar=metavar,
        instance_from_str=lambda args: args[0],
        is_instance=lambda x: isinstance(x, str),
        str_from_instance=lambda x: [x],
        choices=LiveChoices(keys),
    )
    if aliases:
        return Annotated[str, spec, tyro.conf.arg(aliases=aliases)]
    return Annotated[str, spec]
