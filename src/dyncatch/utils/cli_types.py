"""Command-line types whose choices are read from a registry when the command line is parsed,
so a behaviour registered at run time is a valid choice with no edit here."""

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


def live_name(keys: Callable[[], Sequence[str]], metavar: str):
    """A ``str`` flag type whose choices are ``keys()`` when the command line is parsed."""
    return Annotated[
        str,
        PrimitiveConstructorSpec(
            nargs=1,
            metavar=metavar,
            instance_from_str=lambda args: args[0],
            is_instance=lambda x: isinstance(x, str),
            str_from_instance=lambda x: [x],
            choices=LiveChoices(keys),
        ),
    ]


def _behaviors() -> Sequence[str]:
    from dyncatch.sim.behaviors import BEHAVIORS

    return tuple(BEHAVIORS)


def _loggers() -> Sequence[str]:
    from dyncatch.rl.logging import LOGGERS

    return tuple(LOGGERS)


BehaviorName = live_name(_behaviors, "BEHAVIOR")
"""A key of ``dyncatch.sim.behaviors.BEHAVIORS``."""
LoggerName = live_name(_loggers, "LOGGER")
"""A key of ``dyncatch.rl.logging.LOGGERS``."""


def _readings() -> Sequence[str]:
    from dyncatch.reproduce.readings import READINGS

    return tuple(READINGS)


ReadingName = live_name(_readings, "READING")
"""A key of ``dyncatch.reproduce.readings.READINGS``."""


def _scenes() -> Sequence[str]:
    from dyncatch.sim.scenes import SCENES

    return tuple(SCENES)


SceneName = Annotated[
    str,
    PrimitiveConstructorSpec(
        nargs=1,
        metavar="SCENE",
        instance_from_str=lambda args: args[0],
        is_instance=lambda x: isinstance(x, str),
        str_from_instance=lambda x: [x],
        choices=LiveChoices(_scenes),
    ),
    # tyro does not prefix an alias, so every command holding one world (all of them) reads
    # ``--scene`` as well as ``--world.scene.name``.
    tyro.conf.arg(aliases=("--scene",)),
]
"""A key of ``dyncatch.sim.scenes.SCENES``; ``--scene`` on the command line."""


def _eval_backends() -> Sequence[str]:
    from dyncatch.evaluation.backends import EVAL_BACKENDS

    return tuple(EVAL_BACKENDS)


EvalBackendName = live_name(_eval_backends, "BACKEND")
"""A key of ``dyncatch.evaluation.backends.EVAL_BACKENDS``."""
