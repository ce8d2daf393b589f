"""The evasive policy of eq. 11-12.

theta* = atan2(d) + gamma                       if |d| >  r_ev
theta* = atan2(d) + sign(beta) * alpha + gamma  if |d| <= r_ev

with d = x_obj - x_rob and gamma ~ U(-gamma_max, gamma_max). We read beta, "the yaw angle
difference", as the bearing of the target in the robot's frame: wrap(atan2(d) - yaw_rob).
A target left of the robot's heading (beta > 0) dodges further left, so it always breaks
away from the line the robot is running along.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import jax
import jax.numpy as jnp
from flax import struct

from dyncatch.sim.behaviors.base import Behavior, Check, NoState
from dyncatch.sim.geometry import wrap_angle
from dyncatch.sim.state import RobotState, TargetState

if TYPE_CHECKING:
    from dyncatch.sim.config import WorldCfg


@struct.dataclass
class ReactiveCfg:
    evade_radius_m: float = 3.0
    """r_ev of eq. 12: closer than this, the target dodges sideways."""
    evade_angle_rad: float = math.radians(60.0)
    """alpha of eq. 12: the dodge angle added to the flee direction."""
    gamma_max_rad: float = math.radians(22.5)
    """gamma ~ U(-gamma_max, gamma_max) of eq. 12, drawn every control step."""


def reactive_heading(
    target: TargetState, robot: RobotState, cfg: WorldCfg, key: jax.Array
) -> tuple[jax.Array, NoState]:
    """Flee the robot, dodging sideways by alpha within r_ev, plus gamma (the state is kept)."""
    d = target.xy_m - robot.xy_m
    flee = jnp.arctan2(d[1], d[0])
    beta = wrap_angle(flee - robot.yaw_rad)
    tc = cfg.target
    gamma = jax.random.uniform(key, (), minval=-tc.gamma_max_rad, maxval=tc.gamma_max_rad)
    close = jnp.sum(d * d) <= tc.evade_radius_m**2
    dodge = jnp.where(close, jnp.sign(beta) * tc.evade_angle_rad, 0.0)
    return flee + dodge + gamma, target.behavior_state


def reactive_validate(cfg: WorldCfg) -> list[Check]:
    return [(cfg.target.evade_radius_m >= 0, "target.evade_radius_m", "must be >= 0")]


REACTIVE = Behavior(
    desired_heading=reactive_heading,
    cfg_cls=ReactiveCfg,
    validate=reactive_validate,
    doc="flees the robot (eq. 11-12) and dodges sideways when it comes within r_ev",
)
