"""The range scan s_env (eq. 3): distances from the base centre to the walls and obstacles
along N rays, and the robot's clearance to the nearest of them (eq. 10's d_rob,obst)."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from dyncatch.sim.config import WorldCfg
from dyncatch.sim.geometry import fan
from dyncatch.sim.obstacles import Obstacles, nearest_m, ray_distances
from dyncatch.sim.scenes import get_scene


def ray_offsets_rad(num_rays: int) -> np.ndarray:
    """The rays' angles from the heading, (num_rays,): evenly spread, the first along it."""
    return 2.0 * np.pi * np.arange(num_rays) / num_rays


def square_exit_m(xy_m: jax.Array, dirs: jax.Array, size_m: jax.Array) -> jax.Array:
    """Distance from a point inside the square [0, size]^2 to its boundary along unit
    directions ``dirs`` (N, 2), (N,)."""
    big = jnp.float32(3.0e38)

    def axis(p, u):
        safe = jnp.where(u == 0.0, 1.0, u)
        t = jnp.where(u > 0.0, (size_m - p) / safe, -p / safe)
        return jnp.where(u == 0.0, big, t)

    return jnp.minimum(axis(xy_m[0], dirs[:, 0]), axis(xy_m[1], dirs[:, 1]))


def range_scan(
    world_xy_m: jax.Array,
    yaw_rad: jax.Array,
    cfg: WorldCfg,
    obstacles: Obstacles | None = None,
    local_xy_m: jax.Array | None = None,
) -> jax.Array:
    """s_env for a base at world position ``world_xy_m`` (2,) facing ``yaw_rad``,
    (scene.scan_rays,) m, capped at ``scene.scan_range_m``; all caps where nothing is hit.
    ``obstacles`` are read from the base's position in their frame, ``local_xy_m`` (2,)."""
    n, cap = cfg.scene.scan_rays, cfg.scene.scan_range_m
    scene = get_scene(cfg.scene.name)
    if not scene.walls and obstacles is None:
        return jnp.full((n,), cap, jnp.float32)
    dirs = fan(yaw_rad, ray_offsets_rad(n))
    dist = jnp.full((n,), jnp.inf, jnp.float32)
    if scene.walls:
        dist = square_exit_m(world_xy_m, dirs, cfg.arena.size_m)
    if obstacles is not None:
        dist = jnp.minimum(dist, ray_distances(obstacles, local_xy_m, dirs))
    return jnp.clip(dist, 0.0, cap)


def wall_clearance_m(world_xy_m: jax.Array, cfg: WorldCfg) -> jax.Array:
    """() distance from a point to the nearest wall, +inf in a scene without walls."""
    if not get_scene(cfg.scene.name).walls:
        return jnp.full((), jnp.inf, jnp.float32)
    return jnp.min(jnp.concatenate([world_xy_m, cfg.arena.size_m - world_xy_m]))


def robot_clearance_m(state, cfg: WorldCfg) -> jax.Array:
    """() gap between the robot's footprint circle and the nearest wall or obstacle (+inf
    where there is none): d_rob,obst of eq. 10, which the collision-avoidance blend's weights
    read. ``state`` is an ``EnvState``."""
    robot, r = state.robot, cfg.base.radius_m
    walls = wall_clearance_m(robot.xy_m + state.origin_xy_m, cfg) - r
    return jnp.minimum(walls, nearest_m(state.obstacles, robot.xy_m, r))
