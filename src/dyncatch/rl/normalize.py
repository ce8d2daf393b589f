"""Running mean and variance of observations (parallel-merge update, pure)."""

from __future__ import annotations

import jax
import jax.numpy as jnp
from flax import struct


@struct.dataclass
class RunningNorm:
    mean: jax.Array
    var: jax.Array
    count: jax.Array

    @classmethod
    def create(cls, dim: int) -> RunningNorm:
        return cls(jnp.zeros(dim), jnp.ones(dim), jnp.array(1e-4))

    def update(self, batch: jax.Array) -> RunningNorm:
        """Merge a batch (..., dim) into the statistics (Chan et al.'s parallel formula)."""
        x = batch.reshape(-1, batch.shape[-1])
        n = x.shape[0]
        b_mean, b_var = x.mean(0), x.var(0)
        delta = b_mean - self.mean
        total = self.count + n
        mean = self.mean + delta * n / total
        m2 = self.var * self.count + b_var * n + delta**2 * self.count * n / total
        return RunningNorm(mean, m2 / total, total)

    def __call__(self, x: jax.Array, clip: float = 10.0) -> jax.Array:
        return jnp.clip((x - self.mean) / jnp.sqrt(self.var + 1e-8), -clip, clip)
