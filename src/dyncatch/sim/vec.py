"""Batches of environments: auto-reset written once, and ``vmap``-ed reset/step.

Written over the environment protocol (``dyncatch.sim.api``), so every backend gets the
same batching. The batch axis is the leading axis of every leaf of the state; nothing here
assumes one device, so a batch can be sharded with ``jax.sharding`` and a whole training
run ``vmap``-ed over seeds.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from dyncatch.sim.api import Environment

_RESET_STREAM = 1


def _select(pred: jax.Array, on_true, on_false):
    return jax.tree.map(lambda a, b: jnp.where(pred, a, b), on_true, on_false)


def auto_reset_step_with_final(state, action, env: Environment):
    """``auto_reset_step`` that also returns the finished episode's last state (the state
    after the step, before any reset), for inputs with a carry (``rl.methods.MethodObs``)."""
    next_state, obs, reward, done, info = env.step(state, action)
    fresh = env.reset(jax.random.fold_in(next_state.key, _RESET_STREAM))
    info["final_obs"] = obs
    return (
        _select(done, fresh, next_state),
        _select(done, env.observe(fresh), obs),
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
