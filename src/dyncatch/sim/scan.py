"""The range scan s_env (eq. 3): distances from the base centre to the walls along N rays."""

from __future__ import annotations

import jax
import jax.numpy as jnp

from dyncatch.sim.config import WorldCfg
from dyncatch.sim.geometry import unit
from dyncatch.sim.scenes import get_scene


def ray_angles_rad(yaw_rad: jax.Array, num_rays: int) -> jax.Array:
    """World angles of the rays, (num_rays,): evenly spread, the first along the heading."""
    return yaw_rad + 2.0 * jnp.pi * jnp.arange(num_rays) / num_rays


def square_exit_m(xy_m: jax.Array, dirs: jax.Array, size_m: jax.Array) -> jax.Array:
    """Distance from a point inside the square [0, size]^2 to its boundary along unit
    directions ``dirs`` (N, 2), (N,)."""
    big = jnp.float32(3.0e38)

    def axis(p, u):
        safe = jnp.where(u == 0.0, 1.0, u)
        t = jnp.where(u > 0.0, (size_m - p) / safe, -p / safe)
        return jnp.where(u == 0.0, big, t)

    return jnp.minimum(axis(xy_m[0], dirs[:, 0]), axis(xy_m[1], dirs[:, 1]))


def range_scan(world_xy_m: jax.Array, yaw_rad: jax.Array, cfg: WorldCfg) -> jax.Array:
    """s_env for a base at world position ``world_xy_m`` (2,) facing ``yaw_rad``,
    (scene.scan_rays,) m, capped at ``scene.scan_range_m``; all caps where nothing is hit."""
    n, cap = cfg.scene.scan_rays, cfg.scene.scan_range_m
    if not get_scene(cfg.scene.name).walls:
        return jnp.full((n,), cap, jnp.float32)
    dirs = unit(ray_angles_rad(yaw_rad, n))
    return jnp.clip(square_exit_m(world_xy_m, dirs, cfg.arena.size_m), 0.0, cap)
