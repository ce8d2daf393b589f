"""The local frame: every stored position is relative to ``EnvState.origin_xy_m``.

After each reset and step the frame is moved to the robot (``recentre``): the robot's xy is
0, every other position is relative to it, and ``origin_xy_m`` holds the robot's position in
the scene frame. Physics, sensing, the catch test and the observations only ever use
positions relative to the robot, so they are as exact 10 km from the world origin as at it;
world-fixed features (the walls, the bounce target's square, the circle's centre) are placed
in the frame by subtracting ``origin_xy_m``; obstacles are stored in the frame and move with
it (a periodic layout's copies are kept within half a period of the robot). Behaviour states
keep world-fixed points in fields whose names end in ``xy_m``; ``recentre`` moves them with
the frame.

The scene frame sits at ``EnvState.anchor_xy_m`` in the world (0 after reset). Placing an
episode far out moves the anchor alone, so ``origin_xy_m`` (the odometry) stays as small and
as exact as at the origin; ``world_position_m`` adds the two on the host in float64.
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
import numpy as np

from dyncatch.sim.state import EnvState


def _shift_pose(pose: jax.Array, d: jax.Array) -> jax.Array:
    """(x, y, yaw) with its position moved by -d."""
    return jnp.concatenate([pose[:2] - d, pose[2:]])


def shift_xy_fields(tree, d: jax.Array):
    """A behaviour state with every ``*xy_m`` field moved by -d, in nested dataclasses and
    tuples too (a ``league`` target holds its members' states), others kept."""
    if isinstance(tree, tuple):
        return tuple(shift_xy_fields(t, d) for t in tree)
    if not dataclasses.is_dataclass(tree):
        return tree
    moved = {
        f.name: (
            getattr(tree, f.name) - d
            if f.name.endswith("xy_m")
            else shift_xy_fields(getattr(tree, f.name), d)
        )
        for f in dataclasses.fields(tree)
        if f.name.endswith("xy_m")
        or isinstance(getattr(tree, f.name), tuple)
        or dataclasses.is_dataclass(getattr(tree, f.name))
    }
    return tree.replace(**moved) if moved else tree


def shift(state: EnvState, d_m: jax.Array) -> EnvState:
    """The same state in a frame moved by ``d_m`` (2,): every stored position minus ``d_m``,
    ``origin_xy_m`` plus it. ``shift(state, -state.origin_xy_m)`` gives scene coordinates."""
    robot = state.robot.replace(
        xy_m=state.robot.xy_m - d_m,
        gripper_xyz_m=jnp.concatenate(
            [state.robot.gripper_xyz_m[:2] - d_m, state.robot.gripper_xyz_m[2:]]
        ),
    )
    target = state.target.replace(
        xy_m=state.target.xy_m - d_m,
        behavior_state=shift_xy_fields(state.target.behavior_state, d_m),
    )
    s = state.sensor
    sensor = s.replace(
        obs_xy_m=s.obs_xy_m - d_m,
        prev_obs_xy_m=s.prev_obs_xy_m - d_m,
        pending_xy_m=s.pending_xy_m - d_m,
        robot_pose=_shift_pose(s.robot_pose, d_m),
        prev_robot_pose=_shift_pose(s.prev_robot_pose, d_m),
        pending_robot_pose=_shift_pose(s.pending_robot_pose, d_m),
    )
    return state.replace(
        robot=robot,
        target=target,
        sensor=sensor,
        origin_xy_m=state.origin_xy_m + d_m,
        obstacles=state.obstacles.shifted(d_m),
    )


def recentre(state: EnvState) -> EnvState:
    """The same state in the frame centred on the robot (which then sits at xy = 0)."""
    moved = shift(state, state.robot.xy_m)
    # Exactly 0, not x - x rounded: the robot is the frame's origin.
    return moved.replace(robot=moved.robot.replace(xy_m=jnp.zeros_like(state.robot.xy_m)))


def in_scene_frame(state: EnvState) -> EnvState:
    """The same state with scene coordinates stored (``origin_xy_m`` = 0); ``recentre``
    brings it back. For placing bodies at scene positions (tests, scripted starts)."""
    return shift(state, -state.origin_xy_m)


def to_scene(state: EnvState, xy_m: jax.Array) -> jax.Array:
    """A stored (local) position, (..., 2), in the scene frame (the world frame moved by
    ``anchor_xy_m``; the same after reset). Walls and drawings live in this frame."""
    return xy_m + state.origin_xy_m


def odometry(state: EnvState) -> tuple[jax.Array, jax.Array]:
    """The robot's own pose in the scene frame, xy (2,) and yaw (): what its odometry knows
    (policies may read it; it says nothing about the target). Relative to the anchor, it is
    as exact with the scene 1000 km out as at the world origin."""
    return state.robot.xy_m + state.origin_xy_m, state.robot.yaw_rad


def world_position_m(state: EnvState) -> np.ndarray:
    """The robot's world position, (..., 2) float64 on the host: the anchor plus the frame,
    each a float32, summed without rounding away the frame's small part."""
    return np.asarray(state.anchor_xy_m, np.float64) + np.asarray(state.origin_xy_m, np.float64)
