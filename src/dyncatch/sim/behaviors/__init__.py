"""Target behaviours by name, and ``TargetCfg`` composed from their config classes.

A new behaviour is one module (a ``Behavior`` with its config class and state) and one line
in ``BEHAVIORS``; its fields then appear in ``TargetCfg``, on the command line as
``--world.target.<field>`` and in checkpoint headers.
"""

from __future__ import annotations

from dyncatch.sim.behaviors.base import Behavior, NoState, TargetBodyCfg
from dyncatch.sim.behaviors.bounce import BOUNCE
from dyncatch.sim.behaviors.circle import CIRCLE, CircleCfg, CircleState
from dyncatch.sim.behaviors.compose import compose_target_cfg
from dyncatch.sim.behaviors.random_reactive import (
    RANDOM_REACTIVE,
    RandomReactiveCfg,
    RandomReactiveState,
)
from dyncatch.sim.behaviors.reactive import REACTIVE, ReactiveCfg

BEHAVIORS: dict[str, Behavior] = {
    "circle": CIRCLE,
    "bounce": BOUNCE,
    "reactive": REACTIVE,
    "random_reactive": RANDOM_REACTIVE,
}

TargetCfg = compose_target_cfg(
    BEHAVIORS.values(), doc="The planar target body and its behaviour parameters."
)


def get_behavior(name: str) -> Behavior:
    try:
        return BEHAVIORS[name]
    except KeyError:
        known = ", ".join(sorted(BEHAVIORS))
        raise ValueError(f"unknown target behavior {name!r}: choose one of {known}") from None


__all__ = [
    "BEHAVIORS",
    "Behavior",
    "CircleCfg",
    "CircleState",
    "NoState",
    "RandomReactiveCfg",
    "RandomReactiveState",
    "ReactiveCfg",
    "TargetBodyCfg",
    "TargetCfg",
    "get_behavior",
]
