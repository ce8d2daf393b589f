"""Network inputs s_phi (eq. 3) from what the robot has seen, one function per (kind, frame).

A ``History`` is the current frame's s_phi before encoding: target sightings at t and t-1,
the robot poses at those captures and the robot's velocity now. Every encoder returns the
input vector and the yaw (rad) by which the network's output is rotated into the world
(0 for world-frame outputs), so ``predict`` always returns a world-frame velocity.
"""

from __future__ import annotations

from collections.abc import Callable

import jax
import jax.numpy as jnp
from flax import struct

from dyncatch.sim.geometry import rotate, world_to_body
from dyncatch.sim.state import EnvState


@struct.dataclass
class History:
    """s_phi,t of eq. 3 (add leading axes for batches)."""

    target_xy_m: jax.Array
    """Target sighting p_t in the world, (2,)."""
    prev_target_xy_m: jax.Array
    """The sighting before, p_{t-1}, (2,)."""
    robot_pose: jax.Array
    """Robot (x, y, yaw) at the capture of p_t, (3,)."""
    prev_robot_pose: jax.Array
    """Robot (x, y, yaw) at the capture of p_{t-1}, (3,)."""
    robot_vel_body_mps: jax.Array
    """Robot velocity (forward, left) now, in its own frame, (2,)."""
    robot_yaw_rate_rps: jax.Array
    """Robot yaw rate now, ()."""


def history_from_state(state: EnvState) -> History:
    """The history a policy has at this control step (valid where ``state.sensor.consecutive``)."""
    s = state.sensor
    return History(
        target_xy_m=s.obs_xy_m,
        prev_target_xy_m=s.prev_obs_xy_m,
        robot_pose=s.robot_pose,
        prev_robot_pose=s.prev_robot_pose,
        robot_vel_body_mps=state.robot.vel_body_mps,
        robot_yaw_rate_rps=state.robot.yaw_rate_rps,
    )


Encoder = Callable[[History, float, float], tuple[jax.Array, jax.Array]]
"""(history, arena_size_m, frame_dt_s) -> (inputs (D,), output yaw_rad ())."""


def _target_velocity(h: History, dt_s: float) -> jax.Array:
    return (h.target_xy_m - h.prev_target_xy_m) / dt_s


def vanilla_world(h: History, size_m: float, dt_s: float) -> tuple[jax.Array, jax.Array]:
    """Sightings in the simulator's stored frame (world axes, origin at the robot now)."""
    x = jnp.concatenate(
        [h.target_xy_m / size_m, h.prev_target_xy_m / size_m, _target_velocity(h, dt_s)]
    )
    return x, jnp.zeros(())


def vanilla_egocentric(h: History, size_m: float, dt_s: float) -> tuple[jax.Array, jax.Array]:
    """The target's last displacement in the camera's frame at its capture (so the input is
    the same however the world is rotated); no robot state beyond the camera's heading."""
    yaw = h.robot_pose[2]
    return world_to_body(_target_velocity(h, dt_s), yaw), yaw


def _robot_world(h: History, size_m: float) -> jax.Array:
    yaw, prev_yaw = h.robot_pose[2], h.prev_robot_pose[2]
    return jnp.concatenate(
        [
            h.robot_pose[:2] / size_m,
            jnp.stack([jnp.cos(yaw), jnp.sin(yaw)]),
            h.prev_robot_pose[:2] / size_m,
            jnp.stack([jnp.cos(prev_yaw), jnp.sin(prev_yaw)]),
            rotate(h.robot_vel_body_mps, yaw),
            h.robot_yaw_rate_rps[None],
        ]
    )


def self_aware_world(h: History, size_m: float, dt_s: float) -> tuple[jax.Array, jax.Array]:
    x, yaw_out = vanilla_world(h, size_m, dt_s)
    return jnp.concatenate([x, _robot_world(h, size_m)]), yaw_out


def self_aware_egocentric(h: History, size_m: float, dt_s: float) -> tuple[jax.Array, jax.Array]:
    """Everything in the robot's frame at t (nothing absolute: the same input however the world
    is placed); the reactive rule (eq. 12) reads off it directly."""
    xy, yaw = h.robot_pose[:2], h.robot_pose[2]
    rel = world_to_body(h.target_xy_m - xy, yaw)
    prev_rel = world_to_body(h.prev_target_xy_m - xy, yaw)
    prev_robot = world_to_body(h.prev_robot_pose[:2] - xy, yaw)
    dyaw = h.prev_robot_pose[2] - yaw
    dist = jnp.sqrt(jnp.sum(rel * rel) + 1e-12)
    x = jnp.concatenate(
        [
            rel / size_m,
            prev_rel / size_m,
            (rel - prev_rel) / dt_s,
            rel / dist,
            dist[None] / size_m,
            prev_robot / size_m,
            jnp.stack([jnp.cos(dyaw), jnp.sin(dyaw)]),
            h.robot_vel_body_mps,
            h.robot_yaw_rate_rps[None],
        ]
    )
    return x, yaw


def self_aware_relative(h: History, size_m: float, dt_s: float) -> tuple[jax.Array, jax.Array]:
    """World axes, robot quantities relative to the target: eq. 12 reads atan2(d) off them."""
    x, yaw_out = vanilla_world(h, size_m, dt_s)
    xy, yaw = h.robot_pose[:2], h.robot_pose[2]
    d = h.target_xy_m - xy
    dist = jnp.sqrt(jnp.sum(d * d) + 1e-12)
    prev_yaw = h.prev_robot_pose[2]
    robot = jnp.concatenate(
        [
            d / size_m,
            d / dist,
            dist[None] / size_m,
            (h.prev_target_xy_m - h.prev_robot_pose[:2]) / size_m,
            jnp.stack([jnp.cos(yaw), jnp.sin(yaw), jnp.cos(prev_yaw), jnp.sin(prev_yaw)]),
            rotate(h.robot_vel_body_mps, yaw),
            h.robot_yaw_rate_rps[None],
        ]
    )
    return jnp.concatenate([x, robot]), yaw_out


FEATURES: dict[str, dict[str, Encoder]] = {
    "vanilla": {
        "world": vanilla_world,
        "egocentric": vanilla_egocentric,
        "relative": vanilla_world,
    },
    "self_aware": {
        "world": self_aware_world,
        "egocentric": self_aware_egocentric,
        "relative": self_aware_relative,
    },
}
"""kind -> frame -> encoder."""


def get_encoder(kind: str, frame: str) -> Encoder:
    if kind not in FEATURES:
        raise ValueError(f"unknown predictor kind {kind!r}: choose one of {', '.join(FEATURES)}")
    if frame not in FEATURES[kind]:
        known = ", ".join(FEATURES[kind])
        raise ValueError(f"unknown predictor frame {frame!r}: choose one of {known}")
    return FEATURES[kind][frame]


def dummy_history() -> History:
    z2, z3 = jnp.zeros(2), jnp.zeros(3)
    return History(z2, z2, z3, z3, z2, jnp.zeros(()))
