"""The fixed path: a circle of ``circle_radius_m`` (paper: 5 m) around the arena centre."""

from __future__ import annotations

import jax
import jax.numpy as jnp

from dyncatch.sim.behaviors.base import MEMORY_SIZE, Behavior
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.state import RobotState, TargetState

# How strongly the heading leans toward the circle when off it (rad per metre of error).
_RADIAL_GAIN_RAD_PER_M = 1.0


def _centre(cfg: WorldCfg) -> jax.Array:
    return jnp.full((2,), 0.5 * cfg.arena.size_m)


def circle_heading(
    target: TargetState, robot: RobotState, cfg: WorldCfg, key: jax.Array
) -> tuple[jax.Array, jax.Array]:
    """memory[0] is the direction of travel: +1 counter-clockwise, -1 clockwise."""
    del robot, key
    direction = target.memory[0]
    rel = target.xy_m - _centre(cfg)
    radial = jnp.arctan2(rel[1], rel[0])
    radius_err = jnp.linalg.norm(rel) - cfg.target.circle_radius_m
    lean = jnp.clip(_RADIAL_GAIN_RAD_PER_M * radius_err, -0.5 * jnp.pi, 0.5 * jnp.pi)
    heading = radial + direction * (0.5 * jnp.pi + lean)
    return heading, target.memory


def circle_reset(key: jax.Array, cfg: WorldCfg) -> tuple[jax.Array, jax.Array, jax.Array]:
    k_phase, k_dir = jax.random.split(key)
    phase = jax.random.uniform(k_phase, (), minval=-jnp.pi, maxval=jnp.pi)
    direction = jnp.where(jax.random.bernoulli(k_dir), 1.0, -1.0)
    xy = _centre(cfg) + cfg.target.circle_radius_m * jnp.stack([jnp.cos(phase), jnp.sin(phase)])
    memory = jnp.zeros(MEMORY_SIZE).at[0].set(direction)
    return xy, phase + direction * 0.5 * jnp.pi, memory


CIRCLE = Behavior(
    desired_heading=circle_heading,
    reset=circle_reset,
    doc="a fixed 5 m-radius circle around the arena centre, either direction",
)
