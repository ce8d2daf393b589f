"""Actor and critic MLPs, and the Gaussian policy head with a learned log-std."""

from __future__ import annotations

import math

import flax.linen as nn
import jax
import jax.numpy as jnp


@jax.custom_jvp
def elu(x: jax.Array) -> jax.Array:
    """ELU (alpha 1), the same numbers as ``jax.nn.elu`` and its gradient, at less cost.

    The derivative is read from the output alone: 1 where ``y > 0``, else ``exp(x) =
    y + 1``, which is what JAX's own rule for ``expm1`` computes, so values and gradients
    are bit-identical to ``jax.nn.elu`` (``tests/rl/test_networks.py``). ``jax.nn.elu``'s
    backward differentiates through two ``where``s and keeps the input and the mask alive;
    this one keeps only ``y`` (which the next layer's weight gradient keeps anyway) and
    does one multiply: a forward + backward of the actor and critic alone takes about 0.66
    of the time (``benchmarks/ppo_profile.py``, ``grad_fast_elu`` against ``grad_elu``), a
    whole update epoch about 0.93 (docs/performance.md, "PPO throughput")."""
    return jnp.where(x > 0, x, jnp.expm1(jnp.minimum(x, 0.0)))


@elu.defjvp
def _elu_jvp(primals, tangents):
    (x,), (t,) = primals, tangents
    y = elu(x)
    return y, t * (jnp.minimum(y, 0.0) + 1.0)


class MLP(nn.Module):
    hidden_sizes: tuple[int, ...]
    out_dim: int
    out_scale: float = 1.0

    @nn.compact
    def __call__(self, x: jax.Array) -> jax.Array:
        for h in self.hidden_sizes:
            x = elu(nn.Dense(h, kernel_init=nn.initializers.orthogonal(math.sqrt(2)))(x))
        return nn.Dense(self.out_dim, kernel_init=nn.initializers.orthogonal(self.out_scale))(x)


class ActorCritic(nn.Module):
    """(normalised obs (..., D)) -> (action mean (..., A), log std (A,), value (...))."""

    action_dim: int
    hidden_sizes: tuple[int, ...]
    init_log_std: float = 0.0

    @nn.compact
    def __call__(self, obs: jax.Array):
        mean = MLP(self.hidden_sizes, self.action_dim, 0.01, name="actor")(obs)
        value = MLP(self.hidden_sizes, 1, 1.0, name="critic")(obs)[..., 0]
        log_std = self.param(
            "log_std", nn.initializers.constant(self.init_log_std), (self.action_dim,)
        )
        return mean, log_std, value


def gaussian_log_prob(x: jax.Array, mean: jax.Array, log_std: jax.Array) -> jax.Array:
    """Log density of a diagonal Gaussian, summed over the last axis."""
    z = (x - mean) * jnp.exp(-log_std)
    return jnp.sum(-0.5 * z**2 - log_std - 0.5 * math.log(2 * math.pi), axis=-1)


def gaussian_entropy(log_std: jax.Array) -> jax.Array:
    return jnp.sum(log_std + 0.5 * math.log(2 * math.pi * math.e), axis=-1)


def gaussian_kl(mean_old, log_std_old, mean_new, log_std_new) -> jax.Array:
    """KL(old || new) of diagonal Gaussians, summed over the last axis."""
    var_old, var_new = jnp.exp(2 * log_std_old), jnp.exp(2 * log_std_new)
    kl = log_std_new - log_std_old + (var_old + (mean_old - mean_new) ** 2) / (2 * var_new) - 0.5
    return jnp.sum(kl, axis=-1)
