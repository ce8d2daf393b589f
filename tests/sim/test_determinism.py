"""Same key, same trajectory; the batched path equals a plain loop over single envs."""

import jax
import jax.numpy as jnp
import numpy as np

from dyncatch.sim import env, vec
from dyncatch.sim.api import JaxCatchEnv
from dyncatch.sim.config import WorldCfg

CFG = WorldCfg()
N, T = 4, 40
# One jitted function for the module: a new jit(vmap(...)) per call would compile the same
# program again for each trajectory.
BATCHED_STEP = jax.jit(jax.vmap(env.step, in_axes=(0, 0, None)))
# The resets as programs too: eagerly, every operation of a reset compiles on its own.
BATCH_RESET = jax.jit(vec.batch_reset, static_argnums=2)
RESET = jax.jit(env.reset)


def _actions():
    return jax.random.uniform(jax.random.key(7), (T, N, 3), minval=-1.5, maxval=2.0)


def _batched(key):
    state = BATCH_RESET(key, JaxCatchEnv(CFG), N)
    out = []
    for a in _actions():
        state, obs, reward, done, info = BATCHED_STEP(state, a, CFG)
        out.append((obs.flat, reward))
    return out


def test_same_key_gives_identical_trajectories():
    a, b = _batched(jax.random.key(1)), _batched(jax.random.key(1))
    for (oa, ra), (ob, rb) in zip(a, b, strict=True):
        np.testing.assert_array_equal(oa, ob)
        np.testing.assert_array_equal(ra, rb)
    c = _batched(jax.random.key(2))
    assert not np.array_equal(a[-1][0], c[-1][0])


def test_jit_vmap_step_equals_a_plain_loop_over_envs():
    batched = _batched(jax.random.key(3))
    keys = jax.random.split(jax.random.key(3), N)
    step = jax.jit(env.step)
    actions = _actions()
    for i in range(N):
        s = RESET(keys[i], CFG)
        for t in range(T):
            s, obs, reward, done, info = step(s, actions[t, i], CFG)
            np.testing.assert_allclose(obs.flat, batched[t][0][i], atol=1e-4, rtol=1e-5)
            np.testing.assert_allclose(reward, batched[t][1][i], atol=1e-5)


def test_auto_reset_starts_a_new_episode_where_one_ends():
    cfg = CFG.replace(episode=CFG.episode.replace(duration_s=0.2))  # 10 steps
    state = BATCH_RESET(jax.random.key(0), JaxCatchEnv(cfg), 3)
    step = jax.jit(vec.batch_step)
    for _t in range(10):
        state, obs, reward, done, info = step(state, jnp.zeros((3, 3)), JaxCatchEnv(cfg))
    assert bool(jnp.all(done)) and bool(jnp.all(info["truncated"]))
    assert bool(jnp.all(state.step == 0))
    # The finished episode's last observation differs from the new first one.
    assert not np.allclose(info["final_obs"].flat, obs.flat)
