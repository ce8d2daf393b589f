"""The tracker's carried state: its last sightings, kept in the frame of the newest capture.

The simulator stores every position relative to the robot now (``sim.frame``), and its
sensor keeps the newest sighting and the robot's pose at that capture in the same frame.
The ``Memory`` holds the last ``K`` sightings and the robot poses at their captures in the
*capture frame* of the newest one (the robot's body frame when that frame was taken), so
nothing in it moves between sightings: only a new sighting re-expresses it, through the
previous capture pose the sensor still holds. Nothing absolute is stored.

A new sighting is recognised by the sensor's ``time_since_seen_s`` dropping (it restarts at
each delivered sighting), as the classical intercept baseline does.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
from flax import struct

from dyncatch.sim.geometry import rotate, world_to_body, wrap_angle
from dyncatch.sim.state import EnvState


@struct.dataclass
class Memory:
    """The last ``K`` sightings, newest first (add leading axes for batches)."""

    sight_m: jax.Array
    """Sighted target positions in the newest capture frame, (K, 2)."""
    robot_pose: jax.Array
    """Robot (x, y, yaw) at each capture in the newest capture frame, (K, 3); row 0 is 0."""
    age_s: jax.Array
    """How long before the newest capture each was captured, (K,); row 0 is 0."""
    valid: jax.Array
    """Which rows hold a sighting, (K,) bool."""
    last_tss_s: jax.Array
    """The sensor's ``time_since_seen_s`` at the last ingest, () (inf before the first)."""


def blank_memory(size: int) -> Memory:
    """No sighting yet: the state at every episode start."""
    return Memory(
        sight_m=jnp.zeros((size, 2)),
        robot_pose=jnp.zeros((size, 3)),
        age_s=jnp.zeros(size),
        valid=jnp.zeros(size, bool),
        last_tss_s=jnp.full((), jnp.inf),
    )


def capture_frame_point(state: EnvState, xy_m: jax.Array) -> jax.Array:
    """A stored position, (..., 2), in the newest capture frame."""
    pose = state.sensor.robot_pose
    return world_to_body(xy_m - pose[:2], pose[2])


def ingest(memory: Memory, state: EnvState, dt_s: float) -> Memory:
    """``memory`` after the control step that produced ``state`` (call once per step).

    ``dt_s`` is the control period: a sighting captured ``tss`` ago now was captured
    ``tss + dt_s`` before the next step.
    """
    s = state.sensor
    new = s.ever_seen & (s.time_since_seen_s < memory.last_tss_s)
    pose, old = s.robot_pose, s.prev_robot_pose

    def to_new_frame(xy_m: jax.Array) -> jax.Array:
        # After a hit the sensor's prev_robot_pose is the previous capture's pose.
        return world_to_body(old[:2] + rotate(xy_m, old[2]) - pose[:2], pose[2])

    robot_xy = to_new_frame(memory.robot_pose[:, :2])
    robot_yaw = wrap_angle(memory.robot_pose[:, 2] + old[2] - pose[2])
    gap_s = jnp.where(memory.valid[0], memory.last_tss_s + dt_s - s.time_since_seen_s, 0.0)
    rolled = Memory(
        sight_m=jnp.concatenate(
            [capture_frame_point(state, s.obs_xy_m)[None], to_new_frame(memory.sight_m)[:-1]]
        ),
        robot_pose=jnp.concatenate(
            [jnp.zeros((1, 3)), jnp.concatenate([robot_xy, robot_yaw[:, None]], -1)[:-1]]
        ),
        age_s=jnp.concatenate(
            [jnp.zeros(1), jnp.where(memory.valid, memory.age_s + gap_s, 0.0)[:-1]]
        ),
        valid=jnp.concatenate([jnp.ones(1, bool), memory.valid[:-1]]),
        last_tss_s=memory.last_tss_s,
    )
    memory = jax.tree.map(lambda a, b: jnp.where(new, a, b), rolled, memory)
    return memory.replace(last_tss_s=s.time_since_seen_s)
