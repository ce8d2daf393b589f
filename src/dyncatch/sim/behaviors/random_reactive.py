"""Reactive (eq. 11-12) plus random heading offsets held for a while at random intervals."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import jax
import jax.numpy as jnp
from flax import struct

from dyncatch.sim.behaviors.base import Behavior, uniform_init
from dyncatch.sim.behaviors.reactive import (
    GammaState,
    ReactiveCfg,
    initial_gamma,
    reactive_turn,
    reactive_validate,
)
from dyncatch.sim.state import RobotState, TargetState

if TYPE_CHECKING:
    from dyncatch.sim.config import WorldCfg


@struct.dataclass
class RandomReactiveCfg(ReactiveCfg):
    """Reactive's parameters (inherited) and the random turns'."""

    random_turn_max_rad: float = math.radians(90.0)
    """random_reactive: heading offsets are drawn from U(-max, max)."""
    random_turn_mean_interval_s: float = 1.0
    """random_reactive: mean time between offset changes (exponential intervals)."""
    random_turn_hold_s: float = 0.5
    """random_reactive: how long an offset lasts once drawn."""


@struct.dataclass
class RandomReactiveState:
    offset_rad: jax.Array
    """The last offset drawn, (); added to reactive's heading while ``hold_left_s > 0``."""
    next_change_in_s: jax.Array
    """Time until the next offset is drawn, (); <= 0 draws one at the next step."""
    hold_left_s: jax.Array
    """Time the current offset still applies, ()."""
    gamma: GammaState
    """Reactive's gamma (``target.gamma_hold_s``)."""


def random_reactive_init(
    key: jax.Array, cfg: WorldCfg
) -> tuple[jax.Array, jax.Array, RandomReactiveState]:
    """Placed as reactive; no offset yet, the first one is drawn at the first step."""
    xy, heading, _ = uniform_init(key, cfg)
    zero = jnp.zeros(())
    return xy, heading, RandomReactiveState(zero, zero, zero, initial_gamma())


def random_reactive_heading(
    target: TargetState, robot: RobotState, cfg: WorldCfg, key: jax.Array
) -> tuple[jax.Array, RandomReactiveState]:
    k_react, k_offset, k_interval = jax.random.split(key, 3)
    state: RandomReactiveState = target.behavior_state
    heading, gamma = reactive_turn(target, robot, state.gamma, cfg, k_react)
    tc = cfg.target
    dt = cfg.episode.dt_s
    next_in, hold_left = state.next_change_in_s - dt, state.hold_left_s - dt
    change = next_in <= 0.0
    new_offset = jax.random.uniform(
        k_offset, (), minval=-tc.random_turn_max_rad, maxval=tc.random_turn_max_rad
    )
    interval = tc.random_turn_mean_interval_s * jax.random.exponential(k_interval, ())
    offset = jnp.where(change, new_offset, state.offset_rad)
    next_in = jnp.where(change, interval, next_in)
    hold_left = jnp.where(change, tc.random_turn_hold_s, hold_left)
    applied = jnp.where(hold_left > 0.0, offset, 0.0)
    return heading + applied, RandomReactiveState(offset, next_in, hold_left, gamma)


RANDOM_REACTIVE = Behavior(
    desired_heading=random_reactive_heading,
    cfg_cls=RandomReactiveCfg,
    init_state=random_reactive_init,
    validate=reactive_validate,
    doc="reactive, plus random heading offsets at random (exponential) intervals",
)
