"""Batches of environments: auto-reset written once, and ``vmap``-ed reset/step.

The batch axis is the leading axis of every leaf of the state; nothing here assumes one
device, so a batch can be sharded with ``jax.sharding`` and a whole training run ``vmap``-ed
over seeds.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp

from dyncatch.sim.config import WorldCfg
from dyncatch.sim.env import observe, reset, step
from dyncatch.sim.state import EnvState

_RESET_STREAM = 1


def _select(pred: jax.Array, on_true, on_false):
    return jax.tree.map(lambda a, b: jnp.where(pred, a, b), on_true, on_false)


def auto_reset_step(state: EnvState, action: jax.Array, cfg: WorldCfg):
    """``step``, then start a new episode where this one ended.

    The returned observation is the new episode's first one where ``done``; the last
    observation of the finished episode is ``info["final_obs"]`` (for time-out bootstrapping).
    """
    next_state, obs, reward, done, info = step(state, action, cfg)
    fresh = reset(jax.random.fold_in(next_state.key, _RESET_STREAM), cfg)
    info["final_obs"] = obs
    return (
        _select(done, fresh, next_state),
        _select(done, observe(fresh, cfg), obs),
        reward,
        done,
        info,
    )


def batch_reset(key: jax.Array, cfg: WorldCfg, num_envs: int) -> EnvState:
    """``num_envs`` independent episodes; every leaf gets a leading axis of that size."""
    return jax.vmap(reset, in_axes=(0, None))(jax.random.split(key, num_envs), cfg)


batch_step = jax.vmap(auto_reset_step, in_axes=(0, 0, None))
"""(state [B], action [B, 3], cfg) -> (state [B], obs [B], reward [B], done [B], info [B])."""

batch_observe = jax.vmap(observe, in_axes=(0, None))
