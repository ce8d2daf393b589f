"""Target behaviours by name, and ``TargetCfg`` composed from their config classes.

A new behaviour is one module (a ``Behavior`` with its config class and state) and one line
in ``BEHAVIORS``; its fields then appear in ``TargetCfg``, on the command line as
``--world.target.<field>`` and in checkpoint headers. ``register_behavior`` adds one at run
time (tests, plugins) if its fields are already part of ``TargetCfg``.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

from dyncatch.sim.behaviors.base import BEHAVIORS, Behavior, BehaviorName, NoState, TargetBodyCfg
from dyncatch.sim.behaviors.bounce import BOUNCE
from dyncatch.sim.behaviors.circle import CIRCLE, CircleCfg, CircleState
from dyncatch.sim.behaviors.compose import compose_target_cfg, missing_fields
from dyncatch.sim.behaviors.league import LEAGUE, LeagueCfg, LeagueState
from dyncatch.sim.behaviors.learned import COMMANDED, LEARNED, EvaderState, LearnedCfg
from dyncatch.sim.behaviors.random_reactive import (
    RANDOM_REACTIVE,
    RandomReactiveCfg,
    RandomReactiveState,
)
from dyncatch.sim.behaviors.reactive import REACTIVE, GammaState, ReactiveCfg

BEHAVIORS.update(
    {
        "circle": CIRCLE,
        "bounce": BOUNCE,
        "reactive": REACTIVE,
        "random_reactive": RANDOM_REACTIVE,
        "learned": LEARNED,
        "commanded": COMMANDED,
        "league": LEAGUE,
    }
)

TargetCfg = compose_target_cfg(
    BEHAVIORS.values(), doc="The planar target body and its behaviour parameters."
)

_BUILT_IN = frozenset(BEHAVIORS)


def get_behavior(name: str) -> Behavior:
    try:
        return BEHAVIORS[name]
    except KeyError:
        known = ", ".join(sorted(BEHAVIORS))
        raise ValueError(f"unknown target behavior {name!r}: choose one of {known}") from None


def scripted_behaviors() -> tuple[str, ...]:
    """The registered behaviours that run from their config alone (``Behavior.scripted``),
    in registration order, read when called: what "every behaviour" means for a listing."""
    return tuple(name for name, b in BEHAVIORS.items() if b.scripted)


def register_behavior(name: str, behavior: Behavior, replace: bool = False) -> None:
    """Add ``behavior`` to ``BEHAVIORS`` at run time.

    ``TargetCfg`` was composed at import, so the behaviour's ``cfg_cls`` may only declare
    fields it already has, with the same defaults (a parameterless behaviour always fits).
    Raises ValueError for a taken name (unless ``replace``) or a field ``TargetCfg`` lacks.
    """
    if name in BEHAVIORS and not replace:
        raise ValueError(f"behavior {name!r} is already registered; pass replace=True")
    missing = missing_fields(behavior.cfg_cls, TargetCfg)
    if missing:
        raise ValueError(
            f"behavior {name!r} declares {', '.join(missing)}: TargetCfg is composed at import, "
            "so add its module to BEHAVIORS in dyncatch/sim/behaviors/__init__.py instead of "
            "registering it at run time, or read only existing fields"
        )
    BEHAVIORS[name] = behavior


def unregister_behavior(name: str) -> None:
    """Remove a behaviour added with ``register_behavior`` (built-in ones stay)."""
    if name in _BUILT_IN:
        raise ValueError(f"behavior {name!r} is built in; it cannot be unregistered")
    if name not in BEHAVIORS:
        raise ValueError(f"behavior {name!r} is not registered")
    del BEHAVIORS[name]


@contextmanager
def registered_behavior(name: str, behavior: Behavior, replace: bool = False) -> Iterator[None]:
    """``register_behavior`` for the ``with`` block; ``BEHAVIORS`` is restored afterwards."""
    saved = dict(BEHAVIORS)
    register_behavior(name, behavior, replace=replace)
    try:
        yield
    finally:
        BEHAVIORS.clear()
        BEHAVIORS.update(saved)


__all__ = [
    "BEHAVIORS",
    "Behavior",
    "BehaviorName",
    "CircleCfg",
    "CircleState",
    "EvaderState",
    "GammaState",
    "LeagueCfg",
    "LeagueState",
    "LearnedCfg",
    "NoState",
    "RandomReactiveCfg",
    "RandomReactiveState",
    "ReactiveCfg",
    "TargetBodyCfg",
    "TargetCfg",
    "get_behavior",
    "register_behavior",
    "registered_behavior",
    "scripted_behaviors",
    "unregister_behavior",
]
