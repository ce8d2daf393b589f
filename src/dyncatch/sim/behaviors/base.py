"""What a target behaviour is, and the shared helpers behaviours build on."""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import jax
import jax.numpy as jnp

from dyncatch.sim.config import WorldCfg
from dyncatch.sim.state import RobotState, TargetState

MEMORY_SIZE = 4

DesiredHeadingFn = Callable[
    [TargetState, RobotState, WorldCfg, jax.Array], tuple[jax.Array, jax.Array]
]
"""(target, robot, cfg, key) -> (desired heading (), new memory (MEMORY_SIZE,))."""

ResetFn = Callable[[jax.Array, WorldCfg], tuple[jax.Array, jax.Array, jax.Array]]
"""(key, cfg) -> (xy (2,), heading (), memory (MEMORY_SIZE,))."""


def uniform_reset(key: jax.Array, cfg: WorldCfg) -> tuple[jax.Array, jax.Array, jax.Array]:
    """Anywhere at least 1 m from the walls, any heading, empty memory."""
    k_xy, k_h = jax.random.split(key)
    margin = 1.0
    xy = jax.random.uniform(k_xy, (2,), minval=margin, maxval=cfg.arena.size_m - margin)
    heading = jax.random.uniform(k_h, (), minval=-jnp.pi, maxval=jnp.pi)
    return xy, heading, jnp.zeros(MEMORY_SIZE)


@dataclass(frozen=True)
class Behavior:
    """A target behaviour: one pure policy and how the body meets walls.

    ``desired_heading`` is eq. 1's pi_obj: it sees the target, the robot (reactive targets
    react to it), the world config and a key. The body then turns toward the heading under
    the turn-rate limit and moves at the episode's speed cap.
    """

    desired_heading: DesiredHeadingFn
    reflects_off_walls: bool = False
    """True: hitting a wall mirrors the heading (a bounce); False: the body slides along it."""
    reset: ResetFn = uniform_reset
    doc: str = ""
