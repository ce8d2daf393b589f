"""The PPO loss worked by hand."""

import math

import jax.numpy as jnp
import numpy as np

from dyncatch.rl.loss import ppo_loss
from dyncatch.rl.networks import gaussian_kl, gaussian_log_prob


def test_gaussian_log_prob_by_hand():
    # N(0, 1) at 0 in one dimension: -0.5 log(2 pi)
    lp = gaussian_log_prob(jnp.zeros((1, 1)), jnp.zeros((1, 1)), jnp.zeros(1))
    np.testing.assert_allclose(lp, [-0.5 * math.log(2 * math.pi)], atol=1e-6)
    assert float(gaussian_kl(jnp.zeros(2), jnp.zeros(2), jnp.zeros(2), jnp.zeros(2))) == 0.0


def test_clipped_surrogate_and_value_loss_by_hand():
    # Two samples; advantages +1/-1 stay +1/-1 after normalisation (mean 0, std 1).
    # New policy doubles the density of sample 0 (ratio 2 -> clipped to 1.2 since A > 0)
    # and halves sample 1 (ratio 0.5, A < 0: min(0.5*-1, 0.8*-1) = -0.8).
    # policy loss = -(1.2 + -0.8) / 2 = -0.2
    mean = jnp.zeros((2, 1))
    log_std = jnp.zeros(1)
    lp_new = gaussian_log_prob(jnp.zeros((2, 1)), mean, log_std)
    batch = {
        "actions": jnp.zeros((2, 1)),
        "log_probs": lp_new - jnp.log(jnp.array([2.0, 0.5])),
        "values": jnp.array([0.0, 0.0]),
        "advantages": jnp.array([1.0, -1.0]),
        "returns": jnp.array([1.0, 1.0]),
    }
    # Value 0.5 vs return 1: unclipped error 0.25; clipped (0 + 0.2) error 0.64 -> max 0.64.
    value = jnp.array([0.5, 0.5])
    loss, m = ppo_loss(mean, log_std, value, batch, 0.2, 0.2, vf_coef=1.0, ent_coef=0.0)
    np.testing.assert_allclose(m["loss/policy"], -0.2, atol=1e-5)
    np.testing.assert_allclose(m["loss/value"], 0.64, atol=1e-5)
    np.testing.assert_allclose(loss, -0.2 + 0.64, atol=1e-5)
    np.testing.assert_allclose(m["clip_fraction"], 1.0)
