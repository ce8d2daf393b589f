"""Terrain in the reduced-order base: what rough ground and stairs do to the gait.

A terrain (``TerrainCfg``) scales the gait's command limits, its velocity noise and its
tracking lag; stairs also slow the velocity component across their steps (world x), so the
effect depends on the heading. The action space does not change: the policy's command is
clipped to the flat-ground limits as everywhere, then the terrain's limits act inside the
step. On flat ground (``None``) none of this runs.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import jax
import jax.numpy as jnp

from dyncatch.sim.geometry import rotate
from dyncatch.sim.scene_cfg import TerrainCfg

if TYPE_CHECKING:
    # For annotations only: config.py imports scenes.py, which imports this module.
    from dyncatch.sim.config import BaseCfg


def terrain_command(
    command: jax.Array, yaw_rad: jax.Array, base: BaseCfg, terrain: TerrainCfg
) -> jax.Array:
    """The command (vx, vy, yaw rate) (3,) the gait can follow on this terrain, facing
    ``yaw_rad``: clipped to the scaled limits, its world-x component scaled by
    ``climb_speed_scale``, and clipped again (the scaling turns the vector, which can move a
    body component past its limit: facing 30 deg, (1.6, -0.8) m/s becomes (.., -1.05))."""
    lin, yaw = terrain.speed_scale, terrain.yaw_rate_scale
    scale = jnp.stack([lin, lin, yaw])
    lo = jnp.stack([-base.max_backward_mps, -base.max_lateral_mps, -base.max_yaw_rate_rps])
    hi = jnp.stack([base.max_forward_mps, base.max_lateral_mps, base.max_yaw_rate_rps])
    command = jnp.clip(command, scale * lo, scale * hi)
    world = rotate(command[:2], yaw_rad)
    world = world * jnp.stack([terrain.climb_speed_scale, 1.0])
    command = jnp.concatenate([rotate(world, -yaw_rad), command[2:]])
    return jnp.clip(command, scale * lo, scale * hi)


def terrain_checks(terrain: TerrainCfg, field: str) -> list[tuple[bool, str, str]]:
    """A terrain only slows the gait: speed factors in [0, 1], noise >= 0, lag >= 1 (so the
    observation's velocity bounds, ``sim.obs_bounds``, still hold)."""
    speeds = (terrain.speed_scale, terrain.yaw_rate_scale, terrain.climb_speed_scale)
    return [
        (all(0 <= x <= 1 for x in speeds), field, "speed factors must lie in [0, 1]"),
        (terrain.noise_scale >= 0, f"{field}.noise_scale", "must be >= 0"),
        (terrain.lag_scale >= 1, f"{field}.lag_scale", "must be >= 1"),
    ]
