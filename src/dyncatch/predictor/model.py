"""The predictor Phi of eq. 4: an MLP from s_phi to the target's next velocity (m/s, world).

``Predictor`` is a frozen, hashable dataclass, so it can be a static argument of a jitted
rollout; its parameters are a plain dict pytree::

    {"mlp": <flax params>, "in_mean": (D,), "in_std": (D,)}

``predict(predictor, params, history) -> (2,)`` works on one history; ``vmap`` it for batches.
"""

from __future__ import annotations

from dataclasses import dataclass

import flax.linen as nn
import jax
import jax.numpy as jnp

from dyncatch.predictor.config import PredictorCfg
from dyncatch.predictor.features import History, dummy_history, get_encoder
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.geometry import rotate


class MLP(nn.Module):
    hidden: tuple[int, ...]
    out_dim: int = 2

    @nn.compact
    def __call__(self, x: jax.Array) -> jax.Array:
        for width in self.hidden:
            x = nn.gelu(nn.Dense(width)(x))
        return nn.Dense(self.out_dim)(x)


@dataclass(frozen=True)
class Predictor:
    """What a checkpoint must match: the network config and the world quantities it encodes."""

    cfg: PredictorCfg
    arena_size_m: float
    """Side of the arena the wall features are scaled by, the world's ``arena.size_m``."""
    frame_dt_s: float
    """Time between camera frames, the world's ``sensor.period_s``; labels are displacements
    over it."""

    stateful = False
    """Reads only the environment state (the tracker carries a memory)."""

    @property
    def kind(self) -> str:
        return self.cfg.kind

    @classmethod
    def for_world(cls, cfg: PredictorCfg, world: WorldCfg) -> Predictor:
        """The predictor of ``cfg`` in ``world``: the one way to make one (a checkpoint
        records the world's quantities, and loading it into another world is refused)."""
        return cls(cfg, float(world.arena.size_m), float(world.sensor.period_s))

    def encode(self, history: History) -> tuple[jax.Array, jax.Array]:
        """(inputs (D,), output yaw ()) for one history."""
        encoder = get_encoder(self.cfg.kind, self.cfg.frame)
        return encoder(history, self.arena_size_m, self.frame_dt_s)

    @property
    def input_dim(self) -> int:
        return int(jax.eval_shape(self.encode, dummy_history())[0].shape[0])

    @property
    def net(self) -> MLP:
        return MLP(self.cfg.hidden)

    def init(self, key: jax.Array) -> dict:
        """Fresh parameters with identity input normalisation."""
        d = self.input_dim
        mlp = self.net.init(key, jnp.zeros((d,)))["params"]
        return {"mlp": mlp, "in_mean": jnp.zeros(d), "in_std": jnp.ones(d)}

    def apply_encoded(self, params: dict, x: jax.Array, yaw_out: jax.Array) -> jax.Array:
        """World velocity (..., 2) from encoded inputs (..., D) and output yaws (...)."""
        z = (x - params["in_mean"]) / params["in_std"]
        return rotate(self.net.apply({"params": params["mlp"]}, z), yaw_out)

    def predict(self, params: dict, history: History) -> jax.Array:
        """v_hat_{t+1}: the target's mean velocity over the next camera period, (2,) m/s."""
        x, yaw_out = self.encode(history)
        return self.apply_encoded(params, x, yaw_out)


def predict(predictor: Predictor, params: dict, history: History) -> jax.Array:
    """Functional form of ``Predictor.predict``: (2,) world velocity in m/s."""
    return predictor.predict(params, history)
