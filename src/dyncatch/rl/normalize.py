"""Running mean and variance of observations (parallel-merge update, pure).

The scale is floored at ``min_std``: an input that never varies in training (a flag always
1) would otherwise be divided by sqrt(1e-8) and any change at test time would hit the clip.
"""

from __future__ import annotations

import jax
import jax.numpy as jnp
from flax import struct


@struct.dataclass
class RunningNorm:
    mean: jax.Array
    var: jax.Array
    count: jax.Array
    min_std: float = struct.field(pytree_node=False, default=0.0)
    """Floor of the scale ``std``, in the input's units (``PPOCfg.obs_min_std``)."""

    @classmethod
    def create(cls, dim: int, min_std: float = 0.0) -> RunningNorm:
        return cls(jnp.zeros(dim), jnp.ones(dim), jnp.array(1e-4), min_std)

    @property
    def std(self) -> jax.Array:
        """The scale each input is divided by, (dim,)."""
        return jnp.maximum(jnp.sqrt(self.var + 1e-8), self.min_std)

    def update(self, batch: jax.Array) -> RunningNorm:
        """Merge a batch (..., dim) into the statistics (Chan et al.'s parallel formula)."""
        x = batch.reshape(-1, batch.shape[-1])
        n = x.shape[0]
        b_mean, b_var = x.mean(0), x.var(0)
        delta = b_mean - self.mean
        total = self.count + n
        mean = self.mean + delta * n / total
        m2 = self.var * self.count + b_var * n + delta**2 * self.count * n / total
        return RunningNorm(mean, m2 / total, total, self.min_std)

    def __call__(self, x: jax.Array, clip: float = 10.0) -> jax.Array:
        return jnp.clip((x - self.mean) / self.std, -clip, clip)
