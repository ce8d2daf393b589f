"""The fixed path: a circle of ``circle_radius_m`` (paper: 5 m) around the arena centre."""

from __future__ import annotations

from typing import TYPE_CHECKING

import jax
import jax.numpy as jnp
from flax import struct

from dyncatch.sim.behaviors.base import Behavior, Check
from dyncatch.sim.state import RobotState, TargetState

if TYPE_CHECKING:
    from dyncatch.sim.config import WorldCfg

# How strongly the heading leans toward the circle when off it (rad per metre of error).
_RADIAL_GAIN_RAD_PER_M = 1.0


@struct.dataclass
class CircleCfg:
    circle_radius_m: float = 5.0
    """Radius of the circle path (paper: 5 m), centred in the arena."""


@struct.dataclass
class CircleState:
    direction: jax.Array
    """Direction of travel, (): +1.0 counter-clockwise, -1.0 clockwise; drawn at reset."""
    centre_xy_m: jax.Array
    """The circle's centre (the square's centre) in the local frame, (2,); it moves with
    the frame (``sim.frame.recentre``)."""


def _centre(cfg: WorldCfg) -> jax.Array:
    """The square's centre in world coordinates (the frame at reset)."""
    return jnp.full((2,), 0.5 * cfg.arena.size_m)


def circle_heading(
    target: TargetState, robot: RobotState, cfg: WorldCfg, key: jax.Array
) -> tuple[jax.Array, CircleState]:
    """Tangent to the circle, leaning toward it when off it (the state is kept)."""
    del robot, key
    state: CircleState = target.behavior_state
    rel = target.xy_m - state.centre_xy_m
    radial = jnp.arctan2(rel[1], rel[0])
    radius_err = jnp.linalg.norm(rel) - cfg.target.circle_radius_m
    lean = jnp.clip(_RADIAL_GAIN_RAD_PER_M * radius_err, -0.5 * jnp.pi, 0.5 * jnp.pi)
    heading = radial + state.direction * (0.5 * jnp.pi + lean)
    return heading, state


def circle_init(key: jax.Array, cfg: WorldCfg) -> tuple[jax.Array, jax.Array, CircleState]:
    """On the circle at a random phase, heading along it in a random direction."""
    k_phase, k_dir = jax.random.split(key)
    phase = jax.random.uniform(k_phase, (), minval=-jnp.pi, maxval=jnp.pi)
    direction = jnp.where(jax.random.bernoulli(k_dir), 1.0, -1.0)
    xy = _centre(cfg) + cfg.target.circle_radius_m * jnp.stack([jnp.cos(phase), jnp.sin(phase)])
    state = CircleState(direction=direction, centre_xy_m=_centre(cfg))
    return xy, phase + direction * 0.5 * jnp.pi, state


def circle_validate(cfg: WorldCfg) -> list[Check]:
    t = cfg.target
    return [
        (
            2 * t.circle_radius_m < cfg.arena.size_m - 2 * t.radius_m,
            "target.circle_radius_m",
            "the circle must fit inside the arena",
        ),
    ]


CIRCLE = Behavior(
    desired_heading=circle_heading,
    cfg_cls=CircleCfg,
    init_state=circle_init,
    validate=circle_validate,
    doc="a fixed 5 m-radius circle around the arena centre, either direction",
)
