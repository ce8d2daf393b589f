"""The bounds every observation of the JAX world provably lies in, field by field.

A bound is stated only where the simulator guarantees it for every action, every behaviour
and any number of steps; elsewhere the bound is infinite. What each finite bound rests on:

- ``scan_m`` in [0, scene.scan_range_m]: every ray's distance is clipped to it
  (``sim.scan.range_scan``), walls and obstacles alike.
- ``visible`` in {0, 1}: by construction.
- ``time_since_seen_s`` >= 0: the clock starts at -dt and the reset frame's tick adds dt (or
  sets ``lag * dt`` on a sighting), so it reads exactly 0 after reset and only grows from
  there. No upper bound is stated: it grows by dt a step until the next sighting.
- ``robot_vel_body_mps`` and ``robot_yaw_rate_rps`` within the command limits, if the
  physics sub-step is shorter than the tracking lag (``dt / substeps <= 0.999 lag_s``; the
  default is 0.005 s against 0.1 s) and the acceleration limits are >= 0: the velocity starts
  at 0, gait noise is clipped to the limits, and each sub-step moves it a fraction
  ``dt / lag <= 0.999`` of the way toward a clipped command, never past it (the 0.1 % leaves
  room for float32 rounding). With a longer sub-step the lag overshoots, so no bound. A
  terrain (rooms and woods, ``sim.terrain``) only lowers the limits and lengthens the lag
  (``validate_world`` refuses anything else), so the bound holds there too.
- ``target_obs_body_m``: none. Camera noise is Gaussian
  (``sensor.noise_m``) and a behaviour's ``init_state`` places the target, so a bound would
  be a promise made for behaviours registered later.
"""

from __future__ import annotations

import jax.numpy as jnp

from dyncatch.sim.base import command_high, command_low
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.state import Obs

LAG_MARGIN = 0.999
"""The velocity bound needs ``dt / substeps <= LAG_MARGIN * lag_s`` (room for rounding)."""


def velocity_bound_holds(cfg: WorldCfg):
    """() bool: the base velocity provably stays within the command limits in this world."""
    b, e = cfg.base, cfg.episode
    return (
        (e.dt_s / e.physics_substeps <= LAG_MARGIN * b.lag_s)
        & (jnp.asarray(b.max_lin_accel_mps2) >= 0)
        & (jnp.asarray(b.max_yaw_accel_rps2) >= 0)
    )


def obs_bounds(cfg: WorldCfg) -> tuple[Obs, Obs]:
    """(low, high): two ``Obs`` of float32 arrays, each field with its own shape (``Obs.flat``
    of each gives the (obs_dim(cfg),) vectors); -inf / +inf where no bound is proven. Jit-safe:
    ``cfg``'s numeric fields may be traced."""
    inf = jnp.float32(jnp.inf)
    n_rays = cfg.scene.scan_rays
    scan_cap = jnp.asarray(cfg.scene.scan_range_m, jnp.float32)
    vel_ok = velocity_bound_holds(cfg)
    cmd_low = jnp.where(vel_ok, command_low(cfg.base), -inf)
    cmd_high = jnp.where(vel_ok, command_high(cfg.base), inf)

    def full(shape, value):
        return jnp.full(shape, value, jnp.float32)

    low = Obs(
        robot_vel_body_mps=cmd_low[:2],
        robot_yaw_rate_rps=cmd_low[2],
        target_obs_body_m=full((2,), -inf),
        time_since_seen_s=full((), 0.0),
        visible=full((), 0.0),
        scan_m=full((n_rays,), 0.0),
        staleness=cfg.observation.staleness_inputs,
    )
    high = Obs(
        robot_vel_body_mps=cmd_high[:2],
        robot_yaw_rate_rps=cmd_high[2],
        target_obs_body_m=full((2,), inf),
        time_since_seen_s=full((), inf),
        visible=full((), 1.0),
        scan_m=jnp.full((n_rays,), scan_cap),
        staleness=cfg.observation.staleness_inputs,
    )
    return low, high
