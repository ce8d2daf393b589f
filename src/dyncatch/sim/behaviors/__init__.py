"""Target behaviours by name. A new behaviour is one function and one line here."""

from __future__ import annotations

from dyncatch.sim.behaviors.base import MEMORY_SIZE, Behavior
from dyncatch.sim.behaviors.bounce import BOUNCE
from dyncatch.sim.behaviors.circle import CIRCLE
from dyncatch.sim.behaviors.reactive import RANDOM_REACTIVE, REACTIVE

BEHAVIORS: dict[str, Behavior] = {
    "circle": CIRCLE,
    "bounce": BOUNCE,
    "reactive": REACTIVE,
    "random_reactive": RANDOM_REACTIVE,
}


def get_behavior(name: str) -> Behavior:
    try:
        return BEHAVIORS[name]
    except KeyError:
        known = ", ".join(sorted(BEHAVIORS))
        raise ValueError(f"unknown target behavior {name!r}: choose one of {known}") from None


__all__ = ["BEHAVIORS", "MEMORY_SIZE", "Behavior", "get_behavior"]
