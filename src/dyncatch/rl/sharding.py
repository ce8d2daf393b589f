"""Placing a training state on every local device: a 1-D mesh over ``jax.devices()`` whose
``"batch"`` axis splits the environments (``make_train(..., mesh=...)`` splits the PPO
minibatches along it too); everything else (parameters, optimiser, normaliser, keys) is
replicated. One device is the one-element case of the same code.

Tested on CPU with ``XLA_FLAGS=--xla_force_host_platform_device_count=2`` (set before jax is
imported): the metrics equal those of one device to float tolerance.
"""

from __future__ import annotations

from collections.abc import Sequence

import jax
import numpy as np
from jax.sharding import Mesh, NamedSharding, PartitionSpec

from dyncatch.rl.config import PPOCfg
from dyncatch.rl.train import BATCH_AXIS, TrainState


def batch_mesh(devices: Sequence[jax.Device] | None = None) -> Mesh:
    """A 1-D mesh named ``"batch"`` over ``devices`` (default: every local device)."""
    devices = list(devices) if devices is not None else jax.local_devices()
    return Mesh(np.array(devices), (BATCH_AXIS,))


def validate_mesh(ppo: PPOCfg, n: int) -> None:
    """Raise ValueError naming the flag when the batch cannot be split evenly over ``n``
    devices."""
    if ppo.num_envs % n:
        raise ValueError(
            f"ppo.num_envs={ppo.num_envs} must divide by the {n} local devices it is split "
            f"over; pick a multiple of {n} (--ppo.num-envs)"
        )
    if ppo.minibatch_size % n:
        raise ValueError(
            f"the PPO minibatch ({ppo.minibatch_size} samples) must divide by the {n} local "
            "devices; change --ppo.num-minibatches or --ppo.num-envs"
        )


def state_shardings(template: TrainState, mesh: Mesh, env_axis: int = 0):
    """A pytree of ``NamedSharding`` shaped like ``template`` (arrays or ShapeDtypeStructs):
    the environment state and observation split along ``env_axis`` (1 when a leading seed
    axis is ``vmap``-ped), every other leaf replicated."""
    split = NamedSharding(mesh, PartitionSpec(*([None] * env_axis), BATCH_AXIS))
    whole = NamedSharding(mesh, PartitionSpec())
    every = jax.tree.map(lambda _: whole, template)
    return every.replace(
        env_state=jax.tree.map(lambda _: split, template.env_state),
        obs=jax.tree.map(lambda _: split, template.obs),
    )
