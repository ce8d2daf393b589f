"""The Kalman-filter interception baseline."""

import math
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from dyncatch.evaluation.episodes import run_episodes
from dyncatch.policies.intercept import (
    InterceptCfg,
    KalmanCarry,
    interception_time_s,
    kf_predict,
    kf_update,
)
from dyncatch.policies.registry import BASELINES
from dyncatch.sim import env as sim_env
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.frame import world_position_m


def test_interception_time_by_hand():
    # Still target 4 m away, robot at 2 m/s: 2 s.
    np.testing.assert_allclose(
        interception_time_s(jnp.array([4.0, 0]), jnp.zeros(2), 2.0, 10.0), 2.0, atol=1e-5
    )
    # Fleeing straight away at 1.5 m/s from 1 m: 1 / (2 - 1.5) = 2 s.
    np.testing.assert_allclose(
        interception_time_s(jnp.array([1.0, 0]), jnp.array([1.5, 0]), 2.0, 10.0), 2.0, atol=1e-4
    )
    # Crossing at 1.5 m/s, 3 m ahead: (1.5 t)^2 + 9 = (2 t)^2 -> t = 3 / sqrt(1.75).
    np.testing.assert_allclose(
        interception_time_s(jnp.array([3.0, 0]), jnp.array([0, 1.5]), 2.0, 10.0),
        3 / math.sqrt(1.75),
        atol=1e-4,
    )
    # Faster than the robot and running away: no solution, the horizon is used.
    assert float(interception_time_s(jnp.array([1.0, 0]), jnp.array([3.0, 0]), 2.0, 2.5)) == 2.5


def test_kalman_filter_recovers_a_constant_velocity_from_2hz_sightings():
    cfg = InterceptCfg()
    v_true = jnp.array([1.2, -0.7])
    c = KalmanCarry(
        jnp.zeros(2),
        jnp.zeros(2),
        jnp.diag(jnp.array([0.05**2, 1.5**2])),
        jnp.array(True),
        jnp.array(0.0),
    )
    for k in range(1, 9):  # 4 s of 2 Hz sightings, 25 predictions of 0.02 s between them
        for _ in range(25):
            c = kf_predict(c, 0.02, cfg.accel_noise_mps2)
        c = kf_update(c, v_true * 0.5 * k, cfg.meas_noise_m)
    np.testing.assert_allclose(c.vel_mps, v_true, atol=0.05)
    np.testing.assert_allclose(c.pos_m, v_true * 4.0, atol=0.02)


@pytest.mark.extended  # a behaviour claim; the by-hand interception and Kalman tests cover the code
def test_interception_beats_pure_pursuit_on_fast_bouncing_targets():
    world = WorldCfg()
    cfg = world.with_behavior("bounce").with_speed(1.8)
    rates = {
        name: float(run_episodes(f(world), jax.random.key(11), cfg, 200)["success"].mean())
        for name, f in BASELINES.items()
    }
    # Measured 0.89 vs 0.76 over 300 episodes: leading the target pays on straight lines.
    assert rates["intercept"] > rates["pursuit"] + 0.05, rates


_FAR_M = 1.0e6  # 1000 km


@partial(jax.jit, static_argnames="num_steps")
def _intercept_episodes(anchor_xy_m: jax.Array, key: jax.Array, world: WorldCfg, num_steps: int):
    """8 intercept episodes with the scene placed at ``anchor_xy_m``: success (8,) and the
    state after each step (leaves (T, 8, ...))."""
    policy = BASELINES["intercept"](world)
    k_reset, k_act = jax.random.split(key)
    state = jax.vmap(sim_env.reset, in_axes=(0, None))(jax.random.split(k_reset, 8), world)
    state = state.replace(anchor_xy_m=state.anchor_xy_m + anchor_xy_m)
    obs = jax.vmap(sim_env.observe, in_axes=(0, None))(state, world)
    carry = jax.vmap(policy.init_carry)(state, obs)

    def body(c, t):
        state, obs, carry, done, success = c
        keys = jax.random.split(jax.random.fold_in(k_act, t), 8)
        carry, action = jax.vmap(policy.step)(carry, state, obs, keys)
        state, obs, _, now_done, info = jax.vmap(sim_env.step, in_axes=(0, 0, None))(
            state, action, world
        )
        success = success | (~done & info["success"])
        return (state, obs, carry, done | now_done, success), state

    none = jnp.zeros(8, bool)
    steps = jnp.arange(num_steps)
    (*_, success), states = jax.lax.scan(body, (state, obs, carry, none, none), steps)
    return success, states


def test_interception_1000_km_out_succeeds_exactly_as_at_the_origin():
    world = WorldCfg().with_scene("open_plane").with_speed(1.2)
    key = jax.random.key(3)
    far_m = jnp.array([_FAR_M, -_FAR_M], jnp.float32)
    steps = round(world.episode.duration_s * world.episode.control_hz)  # the whole episode
    success, near = _intercept_episodes(jnp.zeros(2), key, world, steps)
    success_far, far = _intercept_episodes(far_m, key, world, steps)
    assert 0 < int(success.sum()) < 8  # a batch that can tell a change apart
    np.testing.assert_array_equal(success_far, success)
    # The robot's world position over the episode, far out less the placement, is the one at
    # the origin to well under 1 mm (bit for bit: the anchor is never rounded into it).
    world_far = world_position_m(far) - np.array([_FAR_M, -_FAR_M])
    assert np.abs(world_far - world_position_m(near)).max() < 1e-3
    # What it replaced: one float32 world position, stepped by the same displacements,
    # rounds to 1/16 m at 1000 km and drifts by metres within the episode.
    origins = np.asarray(near.origin_xy_m, np.float64)  # (T, 8, 2)
    single = np.float32(_FAR_M) + origins[0].astype(np.float32)
    for d in np.diff(origins, axis=0).astype(np.float32):
        single = single + d
    assert np.abs(single.astype(np.float64) - _FAR_M - origins[-1]).max() > 0.1
