"""The target's body: turn toward the behaviour's heading, move at the cap, meet the walls
and the obstacles."""

from __future__ import annotations

import jax
import jax.numpy as jnp

from dyncatch.sim.config import ArenaCfg, TargetCfg
from dyncatch.sim.geometry import wrap_angle
from dyncatch.sim.obstacles import Obstacles, push_out, reflect_heading
from dyncatch.sim.state import TargetState


def steer(
    target: TargetState,
    desired_heading_rad: jax.Array,
    cfg: TargetCfg,
    dt_s: float,
    speed_share: jax.Array | None = None,
):
    """Turn toward the desired heading by at most the turn-rate limit; run at the speed cap,
    or at ``speed_share`` (clipped to [0, 1]) of it where given (``Behavior.speed_share``)."""
    max_turn = cfg.max_turn_rate_rps * dt_s
    turn = jnp.clip(wrap_angle(desired_heading_rad - target.heading_rad), -max_turn, max_turn)
    speed = target.speed_cap_mps
    if speed_share is not None:
        speed = speed * jnp.clip(speed_share, 0.0, 1.0)
    return target.replace(heading_rad=wrap_angle(target.heading_rad + turn), speed_mps=speed)


def move(
    target: TargetState,
    cfg: TargetCfg,
    arena: ArenaCfg,
    origin_xy_m: jax.Array,
    dt_s: float,
    reflect: bool,
    walls: bool,
    obstacles: Obstacles | None = None,
) -> TargetState:
    """Integrate one sub-step. The square's sides (placed in the local frame by
    ``origin_xy_m``) mirror a reflecting target in every scene; other targets only meet
    them where they are walls, and then slide along them. ``obstacles`` stop every target:
    it slides along them, and a reflecting one's heading is mirrored off them."""
    target = _meet_square(target, cfg, arena, origin_xy_m, dt_s, reflect, walls)
    if obstacles is None:
        return target
    # Last, so nothing moves the body back in: in rooms the obstacles keep clear of the walls
    # (the clip cannot undo this), in the woods the bounce square is only virtual.
    xy, touched = push_out(obstacles, target.xy_m, cfg.radius_m)
    heading = reflect_heading(target.heading_rad, touched) if reflect else target.heading_rad
    return target.replace(xy_m=xy, heading_rad=heading)


def _meet_square(target, cfg, arena, origin_xy_m, dt_s, reflect, walls) -> TargetState:
    c, s = jnp.cos(target.heading_rad), jnp.sin(target.heading_rad)
    xy = target.xy_m + target.speed_mps * dt_s * jnp.stack([c, s])
    lo = cfg.radius_m - origin_xy_m
    hi = arena.size_m - cfg.radius_m - origin_xy_m
    if not reflect:
        return target.replace(xy_m=jnp.clip(xy, lo, hi) if walls else xy)
    below, above = xy < lo, xy > hi
    xy = jnp.where(below, 2 * lo - xy, jnp.where(above, 2 * hi - xy, xy))
    xy = jnp.clip(xy, lo, hi)
    flip = below | above
    centre = 0.5 * (lo + hi)
    vx = jnp.where(flip[0], -jnp.abs(c) * jnp.sign(xy[0] - centre[0]), c)
    vy = jnp.where(flip[1], -jnp.abs(s) * jnp.sign(xy[1] - centre[1]), s)
    return target.replace(xy_m=xy, heading_rad=jnp.arctan2(vy, vx))
