"""The onboard camera: 2 Hz sample-and-hold sightings inside a field-of-view cone.

A frame is captured every ``round(control_hz / rate_hz)`` control steps, starting at reset.
It sees the target if the target's bearing lies within half the field of view of the base
heading, it is within range and, among obstacles, in the line of sight (an occluded target is
not detected); with latency, the frame is delivered ``latency`` later.
Only delivered frames change what the policy observes.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from dyncatch.sim.config import WorldCfg
from dyncatch.sim.geometry import bearing
from dyncatch.sim.state import RobotState, SensorState, TargetState


def period_steps(cfg: WorldCfg) -> jax.Array:
    """Control steps between camera frames (25 at 50 Hz and 2 Hz)."""
    return jnp.maximum(jnp.round(cfg.episode.control_hz / cfg.sensor.rate_hz), 1).astype(jnp.int32)


def takes_frame(step: jax.Array, cfg: WorldCfg) -> jax.Array:
    """() bool: the camera takes a frame at control step ``step`` (delivered later)."""
    return step % period_steps(cfg) == 0


def latency_steps(cfg: WorldCfg) -> jax.Array:
    return jnp.round(cfg.sensor.latency_s * cfg.episode.control_hz).astype(jnp.int32)


def in_view(robot: RobotState, target_xy_m: jax.Array, cfg: WorldCfg) -> jax.Array:
    """() bool: the point lies inside the camera's cone and range."""
    d = target_xy_m - robot.xy_m
    within_range = jnp.sum(d * d) <= cfg.sensor.range_m**2
    return within_range & (
        jnp.abs(bearing(robot.xy_m, robot.yaw_rad, target_xy_m)) <= 0.5 * cfg.sensor.fov_rad
    )


def pose(robot: RobotState) -> jax.Array:
    return jnp.concatenate([robot.xy_m, robot.yaw_rad[None]])


def initial_sensor(robot: RobotState) -> SensorState:
    """Before any frame: nothing seen; the held position is the robot's own (no information)."""
    p = pose(robot)
    false = jnp.zeros((), bool)
    return SensorState(
        obs_xy_m=robot.xy_m,
        prev_obs_xy_m=robot.xy_m,
        robot_pose=p,
        prev_robot_pose=p,
        visible=false,
        consecutive=false,
        ever_seen=false,
        time_since_seen_s=jnp.zeros(()),
        pending_xy_m=robot.xy_m,
        pending_seen=false,
        pending_robot_pose=p,
    )


def sensor_tick(
    sensor: SensorState,
    robot: RobotState,
    target: TargetState,
    step: jax.Array,
    noise: jax.Array,
    cfg: WorldCfg,
    line_of_sight: jax.Array | None = None,
) -> SensorState:
    """Update the sensor at control step ``step``, after the world moved.

    ``noise`` is (2,) standard normal, scaled by ``sensor.noise_m``; ``line_of_sight`` ()
    bool, where given, is whether no obstacle hides the target (``sim.obstacles``).
    """
    period = period_steps(cfg)
    lag = latency_steps(cfg)
    capture = takes_frame(step, cfg)
    seen_now = in_view(robot, target.xy_m, cfg)
    if line_of_sight is not None:
        seen_now = seen_now & line_of_sight
    sensor = sensor.replace(
        pending_xy_m=jnp.where(
            capture, target.xy_m + cfg.sensor.noise_m * noise, sensor.pending_xy_m
        ),
        pending_seen=jnp.where(capture, seen_now, sensor.pending_seen),
        pending_robot_pose=jnp.where(capture, pose(robot), sensor.pending_robot_pose),
    )
    deliver = (step >= lag) & ((step - lag) % period == 0)
    hit = deliver & sensor.pending_seen
    age = sensor.time_since_seen_s + cfg.episode.dt_s
    return sensor.replace(
        obs_xy_m=jnp.where(hit, sensor.pending_xy_m, sensor.obs_xy_m),
        prev_obs_xy_m=jnp.where(hit, sensor.obs_xy_m, sensor.prev_obs_xy_m),
        robot_pose=jnp.where(hit, sensor.pending_robot_pose, sensor.robot_pose),
        prev_robot_pose=jnp.where(hit, sensor.robot_pose, sensor.prev_robot_pose),
        visible=jnp.where(deliver, sensor.pending_seen, sensor.visible),
        consecutive=jnp.where(deliver, sensor.pending_seen & sensor.visible, sensor.consecutive),
        ever_seen=sensor.ever_seen | hit,
        time_since_seen_s=jnp.where(hit, lag * cfg.episode.dt_s, age),
    )
