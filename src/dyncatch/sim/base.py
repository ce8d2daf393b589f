"""Reduced-order legged base: a velocity-tracking gait controller seen from above.

The gait controller is modelled by what matters to the high-level policy: commanded
(vx, vy, yaw rate) are clipped to the base's limits and tracked with a first-order lag
under acceleration limits, plus small gait-induced velocity noise. Walls, where the scene
has them, and obstacles stop the base; a terrain (``sim.terrain``) changes the gait.
Velocities are in the base frame: x forward, y to the left.
"""

from __future__ import annotations

import math

import jax
import jax.numpy as jnp

from dyncatch.sim.config import ArenaCfg, BaseCfg
from dyncatch.sim.geometry import rotate, wrap_angle
from dyncatch.sim.obstacles import Obstacles, push_out
from dyncatch.sim.scene_cfg import TerrainCfg
from dyncatch.sim.state import RobotState
from dyncatch.sim.terrain import terrain_command


def command_low(cfg: BaseCfg) -> jax.Array:
    """Lower command bounds (vx, vy, yaw rate), (3,)."""
    return jnp.stack([-cfg.max_backward_mps, -cfg.max_lateral_mps, -cfg.max_yaw_rate_rps]).astype(
        jnp.float32
    )


def command_high(cfg: BaseCfg) -> jax.Array:
    """Upper command bounds (vx, vy, yaw rate), (3,)."""
    return jnp.stack([cfg.max_forward_mps, cfg.max_lateral_mps, cfg.max_yaw_rate_rps]).astype(
        jnp.float32
    )


def clip_command(command: jax.Array, cfg: BaseCfg) -> jax.Array:
    """Clip a (vx, vy, yaw rate) command, (..., 3), to the base's limits: each axis to its
    own, then (vx, vy) scaled back along its direction to ``max_speed_mps``. At the default
    inf the scaling is not compiled in: the program is the box's alone, so XLA fuses what
    follows exactly as it did before the limit existed (bit for bit, returns included)."""
    command = jnp.clip(command, command_low(cfg), command_high(cfg))
    if math.isinf(cfg.max_speed_mps):
        return command
    speed = jnp.linalg.norm(command[..., :2], axis=-1, keepdims=True)
    scale = jnp.minimum(1.0, cfg.max_speed_mps / jnp.maximum(speed, 1e-6))
    return jnp.concatenate([command[..., :2] * scale, command[..., 2:]], axis=-1).astype(
        command.dtype
    )


def add_gait_noise(
    robot: RobotState, noise: jax.Array, cfg: BaseCfg, terrain: TerrainCfg | None = None
) -> RobotState:
    """Perturb the base velocity by standard-normal ``noise`` (3,) scaled by the config (and
    the terrain's ``noise_scale``).

    The result stays inside the command limits: the gait cannot run faster than its top speed.
    """
    vel = jnp.concatenate([robot.vel_body_mps, robot.yaw_rate_rps[None]])
    scale = jnp.stack([cfg.gait_noise_mps, cfg.gait_noise_mps, cfg.gait_noise_yaw_rps])
    if terrain is not None:
        scale = scale * terrain.noise_scale
    vel = clip_command(vel + scale * noise, cfg)
    return robot.replace(vel_body_mps=vel[:2], yaw_rate_rps=vel[2])


def base_substep(
    robot: RobotState,
    command: jax.Array,
    cfg: BaseCfg,
    arena: ArenaCfg,
    origin_xy_m: jax.Array,
    dt_s: float,
    walls: bool,
    obstacles: Obstacles | None = None,
    terrain: TerrainCfg | None = None,
) -> RobotState:
    """Advance the base by one physics sub-step under a clipped ``command`` (3,); where the
    scene has walls (the square, placed in the local frame by ``origin_xy_m``) or
    ``obstacles`` they stop it, and a ``terrain`` limits and slows its gait."""
    lag_s = cfg.lag_s
    if terrain is not None:
        command = terrain_command(command, robot.yaw_rad, cfg, terrain)
        lag_s = lag_s * terrain.lag_scale
    lin_step = jnp.clip(
        (command[:2] - robot.vel_body_mps) * (dt_s / lag_s),
        -cfg.max_lin_accel_mps2 * dt_s,
        cfg.max_lin_accel_mps2 * dt_s,
    )
    yaw_step = jnp.clip(
        (command[2] - robot.yaw_rate_rps) * (dt_s / lag_s),
        -cfg.max_yaw_accel_rps2 * dt_s,
        cfg.max_yaw_accel_rps2 * dt_s,
    )
    vel_body = robot.vel_body_mps + lin_step
    yaw_rate = robot.yaw_rate_rps + yaw_step
    # Turning at speed: |v| |yaw rate| <= max_lateral_accel (no limit at the default inf).
    turn_max = cfg.max_lateral_accel_mps2 / jnp.maximum(jnp.linalg.norm(vel_body), 1e-6)
    yaw_rate = jnp.clip(yaw_rate, -turn_max, turn_max)

    xy = robot.xy_m + rotate(vel_body, robot.yaw_rad) * dt_s
    # A wall stops the body, not the gait: the tracked velocity (what the legs do, and what
    # the policy observes) stays within the command limits while the base slides along it.
    # Obstacles first: the layouts keep them farther from the walls than the footprint's
    # diameter, so the wall clip below never pushes the body back into one.
    if obstacles is not None:
        xy, _ = push_out(obstacles, xy, cfg.radius_m)
    if walls:
        xy = jnp.clip(xy, cfg.radius_m - origin_xy_m, arena.size_m - cfg.radius_m - origin_xy_m)
    return robot.replace(
        xy_m=xy,
        yaw_rad=wrap_angle(robot.yaw_rad + yaw_rate * dt_s),
        vel_body_mps=vel_body,
        yaw_rate_rps=yaw_rate,
    )
