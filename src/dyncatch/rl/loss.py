"""The PPO loss: clipped surrogate, clipped value loss and an entropy bonus."""

from __future__ import annotations

import jax
import jax.numpy as jnp

from dyncatch.rl.networks import gaussian_entropy, gaussian_log_prob


def ppo_loss(
    mean: jax.Array,
    log_std: jax.Array,
    value: jax.Array,
    batch: dict[str, jax.Array],
    clip_eps: float,
    value_clip_eps: float,
    vf_coef: float,
    ent_coef: float,
) -> tuple[jax.Array, dict[str, jax.Array]]:
    """Loss to minimise for one minibatch (M,) given the new network outputs.

    ``batch`` holds ``actions`` (M, A), ``log_probs`` (M,), ``values`` (M,), ``advantages``
    (M,) and ``returns`` (M,) from the rollout. Advantages are normalised per minibatch.
    """
    adv = batch["advantages"]
    adv = (adv - adv.mean()) / (adv.std() + 1e-8)
    log_prob = gaussian_log_prob(batch["actions"], mean, log_std)
    ratio = jnp.exp(log_prob - batch["log_probs"])
    surrogate = jnp.minimum(ratio * adv, jnp.clip(ratio, 1 - clip_eps, 1 + clip_eps) * adv)
    policy_loss = -surrogate.mean()

    v_clipped = batch["values"] + jnp.clip(value - batch["values"], -value_clip_eps, value_clip_eps)
    value_loss = jnp.maximum(
        (value - batch["returns"]) ** 2, (v_clipped - batch["returns"]) ** 2
    ).mean()
    entropy = gaussian_entropy(log_std)
    loss = policy_loss + vf_coef * value_loss - ent_coef * entropy
    return loss, {
        "loss/policy": policy_loss,
        "loss/value": value_loss,
        "loss/entropy": entropy,
        "clip_fraction": jnp.mean(jnp.abs(ratio - 1) > clip_eps),
    }
