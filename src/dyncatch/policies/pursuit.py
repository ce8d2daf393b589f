"""A scripted pure-pursuit policy toward the last observed target position.

It never sees the true target: it steers at the held sighting, runs at full speed when
facing it, and spins in place to search once it stands on a stale sighting (or has never
seen the target). Usable anywhere a policy is: ``pursuit_policy(cfg)(obs, key) -> action``.
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
from flax import struct

from dyncatch.sim.config import WorldCfg
from dyncatch.sim.state import Obs


@struct.dataclass
class PursuitCfg:
    yaw_gain_per_s: float = 4.0
    """Yaw-rate command per radian of bearing to the sighting."""
    search_yaw_rate_rps: float = 2.0
    """Spin rate while searching."""
    arrive_radius_m: float = 0.5
    """Standing this close to a sighting that is not fresh, the pursuer searches."""


def drive_toward(
    rel_body_m: jax.Array, searching: jax.Array, world: WorldCfg, cfg: PursuitCfg
) -> jax.Array:
    """Command (3,) running at full speed toward a point given in the base frame (2,),
    turning to face it; or spinning in place where ``searching``."""
    bearing_rad = jnp.arctan2(rel_body_m[1], rel_body_m[0])
    base = world.base
    yaw_rate = jnp.clip(
        cfg.yaw_gain_per_s * bearing_rad, -base.max_yaw_rate_rps, base.max_yaw_rate_rps
    )
    speed = base.max_forward_mps
    vx = jnp.clip(speed * jnp.cos(bearing_rad), -base.max_backward_mps, base.max_forward_mps)
    vy = jnp.clip(speed * jnp.sin(bearing_rad), -base.max_lateral_mps, base.max_lateral_mps)
    chase = jnp.stack([vx, vy, yaw_rate])
    search = jnp.stack([0.0, 0.0, cfg.search_yaw_rate_rps])
    return jnp.where(searching, search, chase)


def pursuit_action(obs: Obs, world: WorldCfg, cfg: PursuitCfg) -> jax.Array:
    """Base command (3,) toward the held sighting; search once standing on a stale one."""
    rel = obs.target_obs_body_m
    searching = (jnp.linalg.norm(rel) < cfg.arrive_radius_m) & (obs.visible < 0.5)
    return drive_toward(rel, searching, world, cfg)


@dataclasses.dataclass(frozen=True)
class PursuitPolicy:
    """``(obs, key) -> action``; a frozen dataclass, so equal configs share compiled code."""

    world: WorldCfg
    cfg: PursuitCfg = PursuitCfg()

    def __call__(self, obs: Obs, key: jax.Array) -> jax.Array:
        del key
        return pursuit_action(obs, self.world, self.cfg)


def pursuit_policy(world: WorldCfg, cfg: PursuitCfg | None = None) -> PursuitPolicy:
    return PursuitPolicy(world, cfg or PursuitCfg())
