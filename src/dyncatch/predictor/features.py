"""Network inputs s_phi (eq. 3) from what the robot has seen, one function per (kind, frame).

A ``History`` is the current frame's s_phi before encoding: target sightings at t and t-1,
the robot poses at those captures and the robot's velocity now. Every encoder returns the
input vector and the yaw (rad) by which the network's output is rotated into the world
(0 for world-frame outputs), so ``predict`` always returns a world-frame velocity. Encoders
name the parts of their input vector (``Encoder.layout``), so an exported predictor's input
layout is read off the code that computes it.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

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


Parts = dict[str, jax.Array]
"""Named pieces of an encoder's input vector, concatenated in insertion order."""


@dataclass(frozen=True)
class Encoder:
    """``(history, arena_size_m, frame_dt_s) -> (inputs (D,), output yaw_rad ())``.

    Built from a function that returns the inputs as named parts, so the input layout (what
    a robot must compute to run an exported predictor) is read off the code that computes it.
    Every part's name is documented in ``FEATURE_DOCS``.
    """

    parts: Callable[[History, float, float], tuple[Parts, jax.Array]]
    yaw_out: str = "0 (the network's output is in world axes)"
    """What the returned output yaw is."""

    def __call__(self, h: History, size_m: float, dt_s: float) -> tuple[jax.Array, jax.Array]:
        parts, yaw_out = self.parts(h, size_m, dt_s)
        return jnp.concatenate(list(parts.values())), yaw_out

    def layout(self) -> tuple[tuple[str, int], ...]:
        """(name, size) of each part of the input vector, in order."""
        parts, _ = self.parts(dummy_history(), 1.0, 1.0)  # sizes only: any scale will do
        return tuple((name, int(v.shape[0])) for name, v in parts.items())


def _target_velocity(h: History, dt_s: float) -> jax.Array:
    return (h.target_xy_m - h.prev_target_xy_m) / dt_s


def _vanilla_world(h: History, size_m: float, dt_s: float) -> tuple[Parts, jax.Array]:
    """Sightings in the simulator's stored frame (world axes, origin at the robot now)."""
    parts = {
        "target_xy_frac": h.target_xy_m / size_m,
        "prev_target_xy_frac": h.prev_target_xy_m / size_m,
        "target_vel_mps": _target_velocity(h, dt_s),
    }
    return parts, jnp.zeros(())


def _vanilla_egocentric(h: History, size_m: float, dt_s: float) -> tuple[Parts, jax.Array]:
    """The target's last displacement in the camera's frame at its capture (so the input is
    the same however the world is rotated); no robot state beyond the camera's heading."""
    yaw = h.robot_pose[2]
    return {"target_vel_body_mps": world_to_body(_target_velocity(h, dt_s), yaw)}, yaw


def _robot_world(h: History, size_m: float) -> Parts:
    yaw, prev_yaw = h.robot_pose[2], h.prev_robot_pose[2]
    return {
        "robot_xy_frac": h.robot_pose[:2] / size_m,
        "robot_yaw_cos_sin": jnp.stack([jnp.cos(yaw), jnp.sin(yaw)]),
        "prev_robot_xy_frac": h.prev_robot_pose[:2] / size_m,
        "prev_robot_yaw_cos_sin": jnp.stack([jnp.cos(prev_yaw), jnp.sin(prev_yaw)]),
        "robot_vel_world_mps": rotate(h.robot_vel_body_mps, yaw),
        "robot_yaw_rate_rps": h.robot_yaw_rate_rps[None],
    }


def _self_aware_world(h: History, size_m: float, dt_s: float) -> tuple[Parts, jax.Array]:
    parts, yaw_out = _vanilla_world(h, size_m, dt_s)
    return {**parts, **_robot_world(h, size_m)}, yaw_out


def _self_aware_egocentric(h: History, size_m: float, dt_s: float) -> tuple[Parts, jax.Array]:
    """Everything in the robot's frame at t (nothing absolute: the same input however the world
    is placed); the reactive rule (eq. 12) reads off it directly."""
    xy, yaw = h.robot_pose[:2], h.robot_pose[2]
    rel = world_to_body(h.target_xy_m - xy, yaw)
    prev_rel = world_to_body(h.prev_target_xy_m - xy, yaw)
    prev_robot = world_to_body(h.prev_robot_pose[:2] - xy, yaw)
    dyaw = h.prev_robot_pose[2] - yaw
    dist = jnp.sqrt(jnp.sum(rel * rel) + 1e-12)
    parts = {
        "target_body_frac": rel / size_m,
        "prev_target_body_frac": prev_rel / size_m,
        "target_vel_body_mps": (rel - prev_rel) / dt_s,
        "target_dir_body_unit": rel / dist,
        "target_dist_frac": dist[None] / size_m,
        "prev_robot_body_frac": prev_robot / size_m,
        "prev_robot_dyaw_cos_sin": jnp.stack([jnp.cos(dyaw), jnp.sin(dyaw)]),
        "robot_vel_body_mps": h.robot_vel_body_mps,
        "robot_yaw_rate_rps": h.robot_yaw_rate_rps[None],
    }
    return parts, yaw


def _self_aware_relative(h: History, size_m: float, dt_s: float) -> tuple[Parts, jax.Array]:
    """World axes, robot quantities relative to the target: eq. 12 reads atan2(d) off them."""
    parts, yaw_out = _vanilla_world(h, size_m, dt_s)
    xy, yaw = h.robot_pose[:2], h.robot_pose[2]
    d = h.target_xy_m - xy
    dist = jnp.sqrt(jnp.sum(d * d) + 1e-12)
    prev_yaw = h.prev_robot_pose[2]
    robot = {
        "target_rel_frac": d / size_m,
        "target_dir_unit": d / dist,
        "target_dist_frac": dist[None] / size_m,
        "prev_target_rel_frac": (h.prev_target_xy_m - h.prev_robot_pose[:2]) / size_m,
        "robot_yaw_cos_sin": jnp.stack([jnp.cos(yaw), jnp.sin(yaw)]),
        "prev_robot_yaw_cos_sin": jnp.stack([jnp.cos(prev_yaw), jnp.sin(prev_yaw)]),
        "robot_vel_world_mps": rotate(h.robot_vel_body_mps, yaw),
        "robot_yaw_rate_rps": h.robot_yaw_rate_rps[None],
    }
    return {**parts, **robot}, yaw_out


vanilla_world = Encoder(_vanilla_world)
vanilla_egocentric = Encoder(_vanilla_egocentric, "the robot yaw at the capture of p_t")
self_aware_world = Encoder(_self_aware_world)
self_aware_egocentric = Encoder(_self_aware_egocentric, "the robot yaw at the capture of p_t")
self_aware_relative = Encoder(_self_aware_relative)

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

FEATURE_DOCS: dict[str, str] = {
    "target_xy_frac": "last sighting p_t, world axes, origin at the robot now, over the side",
    "prev_target_xy_frac": "the sighting before, p_{t-1}, the same frame, over the side",
    "target_vel_mps": "(p_t - p_{t-1}) / frame_dt_s, world axes",
    "robot_xy_frac": "robot position at the capture of p_t, the same frame, over the side",
    "robot_yaw_cos_sin": "cos and sin of the robot yaw at the capture of p_t",
    "prev_robot_xy_frac": "robot position at the capture of p_{t-1}, the same frame, over the side",
    "prev_robot_yaw_cos_sin": "cos and sin of the robot yaw at the capture of p_{t-1}",
    "robot_vel_world_mps": "robot velocity now, rotated into world axes by its yaw at p_t",
    "robot_yaw_rate_rps": "robot yaw rate now",
    "robot_vel_body_mps": "robot velocity now (forward, left) in its own frame",
    "target_body_frac": "p_t minus the robot position at p_t, robot frame at p_t, over the side",
    "prev_target_body_frac": "p_{t-1} minus the robot position at p_t, robot frame at p_t, "
    "over the side",
    "target_vel_body_mps": "(p_t - p_{t-1}) / frame_dt_s, robot frame at p_t",
    "target_dir_body_unit": "unit vector from the robot at p_t to p_t, robot frame at p_t",
    "target_dist_frac": "distance from the robot at p_t to p_t over the arena side",
    "prev_robot_body_frac": "robot position at p_{t-1} minus at p_t, robot frame at p_t, "
    "over the side",
    "prev_robot_dyaw_cos_sin": "cos and sin of (robot yaw at p_{t-1} - robot yaw at p_t)",
    "target_rel_frac": "p_t minus the robot position at p_t, world axes, over the arena side",
    "target_dir_unit": "unit vector from the robot at p_t to p_t, world axes",
    "prev_target_rel_frac": "p_{t-1} minus the robot position at p_{t-1}, world axes, over the "
    "arena side",
}
"""What each named input part means; every ``Encoder``'s parts are documented here."""


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
