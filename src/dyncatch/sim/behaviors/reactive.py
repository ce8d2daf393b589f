"""The evasive policy of eq. 11-12, and its variant with random heading changes.

theta* = atan2(d) + gamma                       if |d| >  r_ev
theta* = atan2(d) + sign(beta) * alpha + gamma  if |d| <= r_ev

with d = x_obj - x_rob and gamma ~ U(-gamma_max, gamma_max). We read beta, "the yaw angle
difference", as the bearing of the target in the robot's frame: wrap(atan2(d) - yaw_rob).
A target left of the robot's heading (beta > 0) dodges further left, so it always breaks
away from the line the robot is running along.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from dyncatch.sim.behaviors.base import Behavior
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.geometry import wrap_angle
from dyncatch.sim.state import RobotState, TargetState


def reactive_heading(
    target: TargetState, robot: RobotState, cfg: WorldCfg, key: jax.Array
) -> tuple[jax.Array, jax.Array]:
    d = target.xy_m - robot.xy_m
    flee = jnp.arctan2(d[1], d[0])
    beta = wrap_angle(flee - robot.yaw_rad)
    tc = cfg.target
    gamma = jax.random.uniform(key, (), minval=-tc.gamma_max_rad, maxval=tc.gamma_max_rad)
    close = jnp.sum(d * d) <= tc.evade_radius_m**2
    dodge = jnp.where(close, jnp.sign(beta) * tc.evade_angle_rad, 0.0)
    return flee + dodge + gamma, target.memory


def random_reactive_heading(
    target: TargetState, robot: RobotState, cfg: WorldCfg, key: jax.Array
) -> tuple[jax.Array, jax.Array]:
    """memory = [offset_rad, time to the next change (s), offset time left (s), unused]."""
    k_react, k_offset, k_interval = jax.random.split(key, 3)
    heading, _ = reactive_heading(target, robot, cfg, k_react)
    tc = cfg.target
    dt = cfg.episode.dt_s
    offset, next_in, hold_left = target.memory[0], target.memory[1] - dt, target.memory[2] - dt
    change = next_in <= 0.0
    new_offset = jax.random.uniform(
        k_offset, (), minval=-tc.random_turn_max_rad, maxval=tc.random_turn_max_rad
    )
    interval = tc.random_turn_mean_interval_s * jax.random.exponential(k_interval, ())
    offset = jnp.where(change, new_offset, offset)
    next_in = jnp.where(change, interval, next_in)
    hold_left = jnp.where(change, tc.random_turn_hold_s, hold_left)
    applied = jnp.where(hold_left > 0.0, offset, 0.0)
    memory = jnp.stack([offset, next_in, hold_left, target.memory[3]])
    return heading + applied, memory


REACTIVE = Behavior(
    desired_heading=reactive_heading,
    doc="flees the robot (eq. 11-12) and dodges sideways when it comes within r_ev",
)

RANDOM_REACTIVE = Behavior(
    desired_heading=random_reactive_heading,
    doc="reactive, plus random heading offsets at random (exponential) intervals",
)
