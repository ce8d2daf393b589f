"""State and observation pytrees of one environment (add a leading axis for a batch)."""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import jax
import jax.numpy as jnp
from flax import struct

from dyncatch.sim.obstacles import Obstacles


@struct.dataclass
class RobotState:
    xy_m: jax.Array
    """Base centre in the world, (2,)."""
    yaw_rad: jax.Array
    """Base heading, ()."""
    vel_body_mps: jax.Array
    """Base velocity (forward, left) in the base frame, (2,)."""
    yaw_rate_rps: jax.Array
    """()."""
    arm_q_rad: jax.Array
    """Arm joint angles, (6,)."""
    gripper_xyz_m: jax.Array
    """Gripper point in the world, (3,)."""


@struct.dataclass
class TargetState:
    xy_m: jax.Array
    """Target centre on the plane, (2,)."""
    heading_rad: jax.Array
    """Direction of motion, ()."""
    speed_mps: jax.Array
    """Current speed, ()."""
    speed_cap_mps: jax.Array
    """This episode's speed cap, drawn at reset, ()."""
    behavior_state: Any
    """The behaviour's own state pytree (e.g. ``CircleState``), its ``init_state`` makes it;
    its structure depends on the behaviour, which is static per compiled world."""

    @property
    def vel_mps(self) -> jax.Array:
        return self.speed_mps * jnp.stack([jnp.cos(self.heading_rad), jnp.sin(self.heading_rad)])


@struct.dataclass
class SensorState:
    """What the camera has delivered so far (sample-and-hold) and what it is about to."""

    obs_xy_m: jax.Array
    """Last delivered target position, (2,) (the robot's own position before any sighting)."""
    prev_obs_xy_m: jax.Array
    """The delivery before it, (2,)."""
    robot_pose: jax.Array
    """Robot (x, y, yaw) when obs_xy_m was captured, (3,)."""
    prev_robot_pose: jax.Array
    """Robot (x, y, yaw) when prev_obs_xy_m was captured, (3,)."""
    visible: jax.Array
    """The last camera frame delivered saw the target, () bool."""
    consecutive: jax.Array
    """The last two camera frames both saw the target, () bool."""
    ever_seen: jax.Array
    """() bool."""
    time_since_seen_s: jax.Array
    """Time since the capture of the last sighting (episode time if never seen), ()."""
    pending_xy_m: jax.Array
    """Captured, not yet delivered (latency), (2,)."""
    pending_seen: jax.Array
    """() bool."""
    pending_robot_pose: jax.Array
    """(3,)."""


@struct.dataclass
class EnvState:
    robot: RobotState
    target: TargetState
    sensor: SensorState
    step: jax.Array
    """Control steps since reset, () int32."""
    key: jax.Array
    """This environment's PRNG key."""
    success: jax.Array
    """The catch happened on the last step, () bool."""
    distance_m: jax.Array
    """Planar robot-target distance after the last step (for eq. 6), ()."""
    origin_xy_m: jax.Array
    """Position of the frame every position above is stored in, in the scene frame, (2,).
    After each reset and step the frame is re-centred on the robot (its xy is then 0), so a
    catch far from the world origin is judged as exactly as one at it. The scene frame holds
    the world-fixed features (the walls' square, ``ArenaCfg``) and the robot's odometry."""
    anchor_xy_m: jax.Array
    """World position of the scene frame's origin, (2,); 0 after reset, never moved by a step.
    An episode placed far out moves this alone: the robot's world position is
    ``anchor_xy_m + origin_xy_m`` (``frame.world_position_m``), two float32 summed exactly on
    the host, so it keeps the precision it has at the origin (a single float32 would round
    to 6 cm at 1000 km)."""
    obstacles: Obstacles
    """This episode's obstacles in the same frame (K = 0 where the scene has none; K is
    fixed per scene, so batches stack)."""


SCAN_RAYS = "scan_rays"
"""Stands in an ``Obs`` field's shape for the world's ray count, ``SceneCfg.scan_rays``."""


def obs_field(shape: tuple[int | str, ...], staleness: bool = False):
    """An ``Obs`` field of per-environment ``shape`` (``SCAN_RAYS`` for the world's ray
    count); it takes prod(shape) slots of ``flat`` (none where it is a ``staleness`` input
    and the observation drops those, ``ObservationCfg.staleness_inputs``)."""
    return struct.field(metadata={"shape": shape, "staleness": staleness})


@struct.dataclass
class Obs:
    """What a policy may see, all egocentric: nothing absolute (no world position or heading),
    so a policy is the same wherever and however the world is placed. ``flat`` is the
    network view, (..., obs_dim(world)) (``dyncatch.sim.api``), fields in order."""

    robot_vel_body_mps: jax.Array = obs_field((2,))
    """Base velocity (forward, left) in its own frame, (2,)."""
    robot_yaw_rate_rps: jax.Array = obs_field(())
    """Base yaw rate, ()."""
    target_obs_body_m: jax.Array = obs_field((2,))
    """Last observed target position in the current base frame, (2,); before any sighting
    the held point is the robot's start position (zeros until it moves)."""
    time_since_seen_s: jax.Array = obs_field((), staleness=True)
    """Time since the capture of the last sighting (episode time if never seen), ()."""
    visible: jax.Array = obs_field((), staleness=True)
    """1.0 if the last camera frame saw the target."""
    scan_m: jax.Array = obs_field((SCAN_RAYS,))
    """s_env (eq. 3): range scan, the distance along each ray from the base centre to the
    nearest wall or obstacle, capped at ``scene.scan_range_m`` (the cap where nothing is hit),
    (scene.scan_rays,)."""
    staleness: bool = struct.field(pytree_node=False, kw_only=True)
    """Whether ``flat`` carries the staleness inputs (``time_since_seen_s``, ``visible``):
    the world's ``observation.staleness_inputs`` (no default here: the world's is the one).
    The fields are there either way."""

    @staticmethod
    def _in_flat(f: dataclasses.Field, staleness: bool) -> bool:
        return "shape" in f.metadata and (staleness or not f.metadata["staleness"])

    @classmethod
    def layout(cls, scan_rays: int, staleness: bool) -> tuple[tuple[str, int], ...]:
        """(field name, number of slots in ``flat``) of every field in ``flat``, in its
        order, for a scan of ``scan_rays`` rays (the world's ``scene.scan_rays``) and with or
        without the staleness inputs (the world's ``observation.staleness_inputs``)."""
        return tuple(
            (f.name, math.prod(scan_rays if d == SCAN_RAYS else d for d in f.metadata["shape"]))
            for f in dataclasses.fields(cls)
            if cls._in_flat(f, staleness)
        )

    @property
    def flat(self) -> jax.Array:
        """The fields flattened and concatenated in declaration order, (..., D) (without the
        staleness inputs where ``staleness`` is False)."""
        parts = []
        for f in dataclasses.fields(self):
            if not self._in_flat(f, self.staleness):
                continue
            x, shape = getattr(self, f.name), f.metadata["shape"]
            batch = x.shape[: x.ndim - len(shape)]
            parts.append(x.reshape(*batch, -1) if shape else x.reshape(*batch, 1))
        return jnp.concatenate(parts, axis=-1)


ACTION_DIM = 3
"""Base command (vx, vy, yaw rate)."""
