"""The evasive policy of eq. 11-12.

theta* = atan2(d) + gamma                       if |d| >  r_ev
theta* = atan2(d) + sign(beta) * alpha + gamma  if |d| <= r_ev

with d = x_obj - x_rob and gamma ~ U(-gamma_max, gamma_max). The paper calls beta "the yaw
angle difference" and gives gamma no rate; both are readings (``ReactiveCfg``). By default
beta is the bearing of the target in the robot's frame, wrap(atan2(d) - yaw_rob): a target
left of the robot's heading (beta > 0) dodges further left, so it always breaks away from the
line the robot is running along; and gamma is drawn afresh every control step.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Literal

import jax
import jax.numpy as jnp
from flax import struct

from dyncatch.sim.behaviors.base import Behavior, Check, uniform_init
from dyncatch.sim.fields import static
from dyncatch.sim.geometry import wrap_angle
from dyncatch.sim.state import RobotState, TargetState

if TYPE_CHECKING:
    from dyncatch.sim.config import WorldCfg

BetaReading = Literal["bearing", "heading_difference"]


@struct.dataclass
class ReactiveCfg:
    evade_radius_m: float = 3.0
    """r_ev of eq. 12: closer than this, the target dodges sideways."""
    evade_angle_rad: float = math.radians(60.0)
    """alpha of eq. 12: the dodge angle added to the flee direction."""
    gamma_max_rad: float = math.radians(22.5)
    """gamma ~ U(-gamma_max, gamma_max) of eq. 12."""
    gamma_hold_s: float = 0.0
    """How long a drawn gamma is kept (rounded to whole control steps, at least one): 0, the
    default, draws it every control step; 0.5 holds it for a camera period (reading
    ``gamma_held``). The paper gives gamma no rate."""
    beta_reading: BetaReading = static("bearing")
    """Reading of eq. 12's beta, "the yaw angle difference": ``bearing`` (the default), the
    target's bearing from the robot's heading, wrap(atan2(d) - yaw_rob);
    ``heading_difference`` (reading ``beta_heading``), the target's heading of motion less
    the robot's, wrap(heading_obj - yaw_rob)."""


@struct.dataclass
class GammaState:
    """The gamma in use and how long it lasts (a reactive target's behaviour state)."""

    gamma_rad: jax.Array
    """The gamma added to the flee direction, ()."""
    left_steps: jax.Array
    """Control steps it still applies, () int32; a new one is drawn at a step where this
    reaches 0."""


def initial_gamma() -> GammaState:
    """No gamma yet: the first is drawn at the first step."""
    return GammaState(jnp.zeros(()), jnp.zeros((), jnp.int32))


def reactive_init(key: jax.Array, cfg: WorldCfg) -> tuple[jax.Array, jax.Array, GammaState]:
    xy, heading, _ = uniform_init(key, cfg)
    return xy, heading, initial_gamma()


def held_gamma(state: GammaState, cfg: WorldCfg, key: jax.Array) -> GammaState:
    """The gamma of this step: a fresh U(-gamma_max, gamma_max) draw from ``key`` where the
    last one has run out (every step when ``gamma_hold_s`` is under one step), else kept."""
    tc = cfg.target
    fresh = jax.random.uniform(key, (), minval=-tc.gamma_max_rad, maxval=tc.gamma_max_rad)
    hold = jnp.maximum(jnp.round(tc.gamma_hold_s / cfg.episode.dt_s), 1).astype(jnp.int32)
    left = state.left_steps - 1
    redraw = left <= 0
    return GammaState(
        gamma_rad=jnp.where(redraw, fresh, state.gamma_rad),
        left_steps=jnp.where(redraw, hold, left),
    )


def beta_rad(target: TargetState, robot: RobotState, flee_rad: jax.Array, cfg: WorldCfg):
    """Eq. 12's beta, () rad, as ``target.beta_reading`` reads it (``flee_rad`` is atan2(d))."""
    if cfg.target.beta_reading == "heading_difference":
        return wrap_angle(target.heading_rad - robot.yaw_rad)
    return wrap_angle(flee_rad - robot.yaw_rad)


def flee_and_dodge(target: TargetState, robot: RobotState, cfg: WorldCfg) -> jax.Array:
    """Eq. 11-12 without gamma, () rad: flee the robot, dodging sideways by alpha within
    r_ev."""
    d = target.xy_m - robot.xy_m
    flee = jnp.arctan2(d[1], d[0])
    beta = beta_rad(target, robot, flee, cfg)
    tc = cfg.target
    close = jnp.sum(d * d) <= tc.evade_radius_m**2
    dodge = jnp.where(close, jnp.sign(beta) * tc.evade_angle_rad, 0.0)
    return flee + dodge


def reactive_turn(
    target: TargetState, robot: RobotState, gamma: GammaState, cfg: WorldCfg, key: jax.Array
) -> tuple[jax.Array, GammaState]:
    """Flee the robot, dodging sideways by alpha within r_ev, plus gamma (held as
    ``gamma_hold_s`` says): (desired heading (), the gamma state after this step)."""
    gamma = held_gamma(gamma, cfg, key)
    return flee_and_dodge(target, robot, cfg) + gamma.gamma_rad, gamma


def reactive_heading(
    target: TargetState, robot: RobotState, cfg: WorldCfg, key: jax.Array
) -> tuple[jax.Array, GammaState]:
    """``reactive_turn`` with the target's own behaviour state (a ``GammaState``)."""
    return reactive_turn(target, robot, target.behavior_state, cfg, key)


def reactive_validate(cfg: WorldCfg) -> list[Check]:
    tc = cfg.target
    return [
        (tc.evade_radius_m >= 0, "target.evade_radius_m", "must be >= 0"),
        (tc.gamma_hold_s >= 0, "target.gamma_hold_s", "must be >= 0 (0 draws every step)"),
        (
            tc.beta_reading in ("bearing", "heading_difference"),
            "target.beta_reading",
            "must be bearing or heading_difference",
        ),
    ]


REACTIVE = Behavior(
    desired_heading=reactive_heading,
    cfg_cls=ReactiveCfg,
    init_state=reactive_init,
    validate=reactive_validate,
    doc="flees the robot (eq. 11-12) and dodges sideways when it comes within r_ev",
)
