"""Generalised advantage estimation with time-out bootstrapping.

An episode that ends by *termination* (a catch) has no future value; one that is *truncated*
(the 20 s limit) does: its last reward is credited with gamma * V(final observation). In
both cases the advantage chain is cut at the episode boundary.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp


def bootstrap_timeouts(
    rewards: jax.Array, truncated: jax.Array, final_values: jax.Array, gamma: float
) -> jax.Array:
    """rewards + gamma * V(final obs) where truncated; all (T, B)."""
    return rewards + gamma * final_values * truncated


def gae(
    rewards: jax.Array,
    values: jax.Array,
    dones: jax.Array,
    last_value: jax.Array,
    gamma: float,
    lam: float,
) -> tuple[jax.Array, jax.Array]:
    """Advantages and returns, (T, B) each.

    ``values[t]`` is V(obs_t); ``dones[t]`` says the episode ended at step t (the next
    observation belongs to a new episode); ``last_value`` (B,) is V of the observation after
    the last step.
    """
    not_done = 1.0 - dones.astype(rewards.dtype)
    next_values = jnp.concatenate([values[1:], last_value[None]], axis=0)
    deltas = rewards + gamma * next_values * not_done - values

    def body(carry, x):
        delta, nd = x
        adv = delta + gamma * lam * nd * carry
        return adv, adv

    _, adv = jax.lax.scan(body, jnp.zeros_like(last_value), (deltas, not_done), reverse=True)
    return adv, adv + values
