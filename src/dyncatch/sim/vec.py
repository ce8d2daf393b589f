"""Batches of environments: auto-reset written once, and ``vmap``-ed reset/step.

Written over the environment protocol (``dyncatch.sim.api``), so every backend gets the
same batching. The batch axis is the leading axis of every leaf of the state; nothing here
assumes one device, so a batch can be sharded with ``jax.sharding`` and a whole training
run ``vmap``-ed over seeds.
"""

from __future__ import annotations

from functools import partial

import jax
import jax.numpy as jnp

from dyncatch.sim.api import Environment
from dyncatch.sim.gate import where_active

_RESET_STREAM = 1
RESET_COMPACT_FRACTIONS = (1 / 64, 1 / 8)
"""Under ``vmap`` fresh episodes are computed only for the environments that are done, on a
compact sub-batch of 1/64 or 1/8 of the batch, or the whole batch when more are done
(``sim.gate``; ``()`` computes them everywhere; below ``MIN_COMPACT_BATCH``
environments, the whole batch when any is done). An episode ends in well under 1 % of
environment steps, but all at once when a batch started together times out."""


def _select(pred: jax.Array, on_true, on_false):
    return jax.tree.map(lambda a, b: jnp.where(pred, a, b), on_true, on_false)


def _fresh_episode(key_data: jax.Array, env: Environment, impl):
    """A new episode and its first observation from the finished episode's last key, as raw
    data (``sim.gate`` gathers and scatters plain arrays); the key is folded here, so only
    the environments that reset pay for it."""
    key = jax.random.fold_in(jax.random.wrap_key_data(key_data, impl=impl), _RESET_STREAM)
    state = env.reset(key)
    return jax.tree.map(_key_data, state), env.observe(state)


def _is_key(x) -> bool:
    return jax.dtypes.issubdtype(x.dtype, jax.dtypes.prng_key)


def _key_data(x):
    return jax.random.key_data(x) if _is_key(x) else x


def _rewrap_key(x, like):
    return jax.random.wrap_key_data(x, impl=jax.random.key_impl(like)) if _is_key(like) else x


def auto_reset_step_with_final(state, action, env: Environment):
    """``auto_reset_step`` that also returns the finished episode's last state (the state
    after the step, before any reset), for inputs with a carry (``rl.methods.MethodObs``)."""
    next_state, obs, reward, done, info = env.step(state, action)
    key = jax.random.key_data(next_state.key)
    fresh_episode = partial(_fresh_episode, impl=jax.random.key_impl(next_state.key))
    fresh, fresh_obs = where_active(fresh_episode, RESET_COMPACT_FRACTIONS)(done, key, env)
    fresh = jax.tree.map(_rewrap_key, fresh, next_state)
    info["final_obs"] = obs
    return (
        _select(done, fresh, next_state),
        _select(done, fresh_obs, obs),
        reward,
        done,
        info,
        next_state,
    )


def auto_reset_step(state, action, env: Environment):
    """``env.step``, then start a new episode where this one ended.

    The returned observation is the new episode's first one where ``done``; the last
    observation of the finished episode is ``info["final_obs"]`` (for time-out bootstrapping).
    """
    return auto_reset_step_with_final(state, action, env)[:5]


def batch_reset(key: jax.Array, env: Environment, num_envs: int):
    """``num_envs`` independent episodes; every leaf gets a leading axis of that size."""
    return jax.vmap(env.reset)(jax.random.split(key, num_envs))


batch_step = jax.vmap(auto_reset_step, in_axes=(0, 0, None))
"""(state [B], action [B, 3], env) -> (state [B], obs [B], reward [B], done [B], info [B])."""

batch_step_with_final = jax.vmap(auto_reset_step_with_final, in_axes=(0, 0, None))
"""``batch_step`` plus the pre-reset states [B] (``auto_reset_step_with_final``)."""


def batch_observe(state, env: Environment):
    """Observations of a batch of states, [B]."""
    return jax.vmap(env.observe)(state)
