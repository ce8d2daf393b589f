"""A classical baseline (the paper's Fig. 2, method 1): a constant-velocity Kalman filter
on the 2 Hz sightings, and a planner that runs for the interception point.

The filter runs in the scene frame: each sighting is the observation's egocentric sighting
placed by the robot's own odometry pose (``sim.frame.odometry``), which is as exact with the
scene placed 1000 km out as at the world origin. It treats x and y alike
(same dynamics and noise), so one 2x2 covariance over
(position, velocity) serves both axes. A new sighting is recognised by the observation's
``time_since_seen_s`` dropping; latency is ignored (it is zero by default). The planner
solves |p + v t - r| = s t for the earliest t (s: the base's top speed), caps t at a horizon,
and drives at p + v t. With no estimate yet, or a stale one, it falls back to pure pursuit.
"""

from __future__ import annotations

import dataclasses

import jax
import jax.numpy as jnp
from flax import struct

from dyncatch.policies.pursuit import PursuitCfg, drive_toward, pursuit_action
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.frame import odometry
from dyncatch.sim.geometry import rotate, world_to_body
from dyncatch.sim.scenes import get_scene
from dyncatch.sim.state import EnvState, Obs


@struct.dataclass
class InterceptCfg:
    accel_noise_mps2: float = 3.0
    """Process noise: std of the target's unmodelled acceleration."""
    meas_noise_m: float = 0.05
    """Std of a sighting's position error."""
    init_vel_std_mps: float = 1.5
    """Velocity uncertainty at the first sighting."""
    horizon_s: float = 2.0
    """Longest look-ahead of the interception point."""
    stale_after_s: float = 1.5
    """Without a sighting for this long, fall back to pure pursuit of the last one."""


@struct.dataclass
class KalmanCarry:
    pos_m: jax.Array
    """(2,) estimated target position."""
    vel_mps: jax.Array
    """(2,) estimated target velocity."""
    cov: jax.Array
    """(2, 2) covariance of (position, velocity), shared by both axes."""
    ready: jax.Array
    """() bool: at least one sighting was fused."""
    last_tss_s: jax.Array
    """time_since_seen_s at the previous step (a drop marks a new sighting)."""


def kf_predict(c: KalmanCarry, dt_s: float, accel_noise: float) -> KalmanCarry:
    f = jnp.array([[1.0, dt_s], [0.0, 1.0]])
    q = accel_noise**2 * jnp.array([[dt_s**4 / 4, dt_s**3 / 2], [dt_s**3 / 2, dt_s**2]])
    return c.replace(pos_m=c.pos_m + c.vel_mps * dt_s, cov=f @ c.cov @ f.T + q)


def kf_update(c: KalmanCarry, z: jax.Array, meas_noise: float) -> KalmanCarry:
    s = c.cov[0, 0] + meas_noise**2
    gain = c.cov[:, 0] / s  # (2,): position and velocity gains
    innov = z - c.pos_m
    cov = c.cov - jnp.outer(gain, c.cov[0, :])
    return c.replace(pos_m=c.pos_m + gain[0] * innov, vel_mps=c.vel_mps + gain[1] * innov, cov=cov)


def interception_time_s(d: jax.Array, v: jax.Array, speed: float, horizon_s: float) -> jax.Array:
    """Earliest t >= 0 with |d + v t| = speed * t, capped at the horizon (d: robot -> target)."""
    a = jnp.sum(v * v) - speed**2
    b = 2.0 * jnp.sum(d * v)
    c = jnp.sum(d * d)
    disc = b * b - 4 * a * c
    safe_a = jnp.where(jnp.abs(a) < 1e-6, -1e-6, a)
    t = (-b - jnp.sqrt(jnp.maximum(disc, 0.0))) / (2 * safe_a)
    t = jnp.where((disc < 0) | (t < 0), horizon_s, t)
    return jnp.clip(t, 0.0, horizon_s)


@dataclasses.dataclass(frozen=True)
class InterceptPolicy:
    world: WorldCfg
    cfg: InterceptCfg = InterceptCfg()
    pursuit: PursuitCfg = PursuitCfg()

    def _fresh(self, sighting_m: jax.Array, obs: Obs, ready: jax.Array) -> KalmanCarry:
        """A filter started at the held sighting, at rest, with the initial uncertainty."""
        return KalmanCarry(
            pos_m=sighting_m,
            vel_mps=jnp.zeros(2),
            cov=jnp.diag(jnp.array([self.cfg.meas_noise_m**2, self.cfg.init_vel_std_mps**2])),
            ready=ready,
            last_tss_s=obs.time_since_seen_s,
        )

    def init_carry(self, state: EnvState, obs: Obs) -> KalmanCarry:
        xy, yaw = odometry(state)
        return self._fresh(xy + rotate(obs.target_obs_body_m, yaw), obs, obs.visible > 0.5)

    def step(self, carry: KalmanCarry, state: EnvState, obs: Obs, key: jax.Array):
        del key
        cfg, dt = self.cfg, self.world.episode.dt_s
        robot_xy, yaw = odometry(state)
        sighting = robot_xy + rotate(obs.target_obs_body_m, yaw)
        c = kf_predict(carry, dt, cfg.accel_noise_mps2)
        new = obs.time_since_seen_s < carry.last_tss_s
        first = new & ~carry.ready
        fresh = self._fresh(sighting, obs, jnp.ones((), bool))
        updated = kf_update(c, sighting, cfg.meas_noise_m)
        c = jax.tree.map(lambda a, b: jnp.where(new, a, b), updated, c)
        c = jax.tree.map(lambda a, b: jnp.where(first, a, b), fresh, c)
        c = c.replace(last_tss_s=obs.time_since_seen_s, ready=c.ready | new)

        d = c.pos_m - robot_xy
        t = interception_time_s(d, c.vel_mps, self.world.base.max_forward_mps, cfg.horizon_s)
        aim = c.pos_m + c.vel_mps * t
        if get_scene(self.world.scene.name).walls:
            aim = jnp.clip(aim, 0.0, self.world.arena.size_m)
        intercept = drive_toward(
            world_to_body(aim - robot_xy, yaw), jnp.zeros((), bool), self.world, self.pursuit
        )
        use_kf = c.ready & (obs.time_since_seen_s < cfg.stale_after_s)
        action = jnp.where(use_kf, intercept, pursuit_action(obs, self.world, self.pursuit))
        return c, action


def intercept_policy(world: WorldCfg, cfg: InterceptCfg | None = None) -> InterceptPolicy:
    return InterceptPolicy(world, cfg or InterceptCfg())
