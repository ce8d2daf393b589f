"""``run_episodes``' ``events``: an ``info`` flag reported per episode, as whether it was set
on one of the episode's own steps (none after its end), equal to a plain loop's."""

import jax
import numpy as np
from flax import struct

from dyncatch.evaluation.episodes import run_episodes
from dyncatch.policies.registry import BASELINES
from dyncatch.sim.api import JaxCatchEnv
from dyncatch.sim.config import WorldCfg

WORLD = WorldCfg().with_behavior("reactive").with_speed(0.4)
WORLD = WORLD.replace(episode=WORLD.episode.replace(duration_s=1.0))


@struct.dataclass
class NearEnv(JaxCatchEnv):
    """The JAX world whose step also says whether the target is within 3.5 m."""

    def step(self, state, action):
        state, obs, reward, done, info = super().step(state, action)
        return state, obs, reward, done, {**info, "near": info["distance_m"] < 3.5}


def test_an_event_is_whether_it_happened_during_the_episode():
    policy, key, n = BASELINES["pursuit"](WORLD), jax.random.key(2), 8
    env = NearEnv(WORLD)
    out = jax.device_get(run_episodes(policy, key, env, n, events=("near",)))
    plain = jax.device_get(run_episodes(policy, key, env, n))
    np.testing.assert_array_equal(out["success"], plain["success"])
    assert "near" not in plain
    # The plain loop: the same keys as run_episodes, the flag kept only on live steps.
    k_reset, k_act = jax.random.split(key)
    state = jax.vmap(env.reset)(jax.random.split(k_reset, n))
    obs = jax.vmap(env.observe)(state)
    done, near = np.zeros(n, bool), np.zeros(n, bool)
    act = jax.jit(jax.vmap(policy))
    step = jax.jit(jax.vmap(env.step))
    for t in range(int(WORLD.episode.max_steps)):
        keys = jax.random.split(jax.random.fold_in(k_act, t), n)
        state, obs, _, now_done, info = step(state, act(obs, keys))
        near |= ~done & np.asarray(info["near"])
        done |= np.asarray(now_done)
    np.testing.assert_array_equal(out["near"], near)
    assert near.any() and not near.all()  # the test tells the two apart
