"""``reset(options=...)`` of the Gymnasium adapters: one handler per option name.

Each handler maps the current world to the next one; the adapter validates the result and
keeps it for this and every later episode. A new option is one more entry in
``RESET_OPTIONS``; an option whose world would change the observation or action space is
refused by the adapter (such a world needs a new environment, as spaces are fixed).
"""

from __future__ import annotations

import numbers
from collections.abc import Callable, Mapping
from typing import Any

from dyncatch.sim.api import Environment
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.validate import ConfigError, validate_world

ResetOption = Callable[[WorldCfg, Any, WorldCfg], WorldCfg]
"""(current world, the option's value, the world the adapter was built with) -> next world."""


def _behavior(world: WorldCfg, value: Any, built: WorldCfg) -> WorldCfg:
    """A behaviour name (a key of ``dyncatch.sim.behaviors.BEHAVIORS``)."""
    del built
    if not isinstance(value, str):
        raise ValueError(f"reset option 'behavior' must be a behaviour name, got {value!r}")
    return world.with_behavior(value)


def _speed_mps(world: WorldCfg, value: Any, built: WorldCfg) -> WorldCfg:
    """A fixed target speed in m/s, or None for the speed range the adapter was built with."""
    if value is None:
        t = built.target
        return world.replace(
            target=world.target.replace(
                speed_min_mps=t.speed_min_mps, speed_max_mps=t.speed_max_mps
            )
        )
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise ValueError(f"reset option 'speed_mps' must be a speed in m/s or None, got {value!r}")
    return world.with_speed(float(value))


def _scene(world: WorldCfg, value: Any, built: WorldCfg) -> WorldCfg:
    """A scene name (a key of ``dyncatch.sim.scenes.SCENES``); the scan keeps its rays, so
    the observation space does not change."""
    del built
    if not isinstance(value, str):
        raise ValueError(f"reset option 'scene' must be a scene name, got {value!r}")
    return world.with_scene(value)


RESET_OPTIONS: dict[str, ResetOption] = {
    "scene": _scene,
    "behavior": _behavior,
    "speed_mps": _speed_mps,
}
"""Option name -> handler, applied in this order whatever the order of the given dict."""


def apply_reset_options(
    env: Environment, options: Mapping[str, Any] | None, built: WorldCfg
) -> Environment:
    """``env`` in the world the options ask for (``env`` itself if there are none).

    Raises ValueError naming the allowed keys for an unknown key, and ConfigError naming
    the option and the field for a value the world refuses (an unknown behaviour, a
    negative speed).
    """
    if not options:
        return env
    unknown = sorted(set(options) - set(RESET_OPTIONS))
    if unknown:
        raise ValueError(
            f"unknown reset option(s) {', '.join(map(repr, unknown))}; "
            f"allowed: {', '.join(map(repr, RESET_OPTIONS))}"
        )
    world = env.world
    for name, handler in RESET_OPTIONS.items():
        if name in options:
            world = handler(world, options[name], built)
    try:
        world = validate_world(world)
    except ConfigError as e:
        raise ConfigError(f"reset options {dict(options)!r}: {e}") from None
    return env.with_world(world)
