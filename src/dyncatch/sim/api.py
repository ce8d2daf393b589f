"""The environment protocol: what PPO, evaluation and the Gymnasium adapters need of a backend.

A backend is a value with a ``world`` (the catch task's constants, ``WorldCfg``, shared by
every backend) and pure ``reset`` / ``step`` / ``observe`` functions of one environment.
Batching and auto-reset are written once, over the protocol, in ``dyncatch.sim.vec``.
``JaxCatchEnv`` is the reduced-order JAX world; it is a pytree (the world's numeric fields
are leaves), so it is passed to jitted functions as an argument and never recompiles for a
new value. A second backend implements the same five members and needs no edit to PPO.
"""

from __future__ import annotations

from typing import Any, Protocol, runtime_checkable

import jax
from flax import struct

from dyncatch.sim import env as sim_env
from dyncatch.sim.base import command_high, command_low
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.obs_bounds import obs_bounds
from dyncatch.sim.state import ACTION_DIM, EnvState, Obs


def obs_layout(world: WorldCfg) -> tuple[tuple[str, int], ...]:
    """``Obs.layout`` in ``world``: its scan's rays and whether the staleness inputs are in."""
    return Obs.layout(world.scene.scan_rays, world.observation.staleness_inputs)


def obs_dim(world: WorldCfg) -> int:
    """Length of ``Obs.flat`` in ``world`` (its range scan has ``world.scene.scan_rays``;
    ``world.observation`` says whether the staleness inputs are in)."""
    return sum(size for _, size in obs_layout(world))


OBS_DIM = obs_dim(WorldCfg())
"""Length of ``Obs.flat`` in the default world, ``WorldCfg()``; ``obs_dim`` for another."""


@struct.dataclass
class Spec:
    """Shape and bounds of an observation or action vector (bounds are arrays of that shape)."""

    shape: tuple[int, ...] = struct.field(pytree_node=False)
    low: jax.Array
    high: jax.Array


@runtime_checkable
class Environment(Protocol):
    """One environment of a catch backend; every function is pure (``vmap`` for batches).

    ``step`` returns ``(state, obs, reward (), done () bool, info)`` where info holds at
    least ``success``, ``terminated``, ``truncated`` and the reward terms
    ``reward/<name>``. ``obs`` is an ``Obs`` (``Obs.flat`` is the network view).
    """

    world: WorldCfg

    def reset(self, key: jax.Array) -> Any: ...

    def step(
        self, state: Any, action: jax.Array
    ) -> tuple[Any, Obs, jax.Array, jax.Array, dict]: ...

    def observe(self, state: Any) -> Obs: ...

    def with_world(self, world: WorldCfg) -> Environment: ...

    @property
    def observation_spec(self) -> Spec: ...

    @property
    def action_spec(self) -> Spec: ...


@struct.dataclass
class JaxCatchEnv:
    """The reduced-order JAX world (``dyncatch.sim.env``) behind the protocol."""

    world: WorldCfg = WorldCfg()

    def reset(self, key: jax.Array) -> EnvState:
        return sim_env.reset(key, self.world)

    def step(self, state: EnvState, action: jax.Array):
        return sim_env.step(state, action, self.world)

    def observe(self, state: EnvState) -> Obs:
        return sim_env.observe(state, self.world)

    def with_world(self, world: WorldCfg) -> JaxCatchEnv:
        return self.replace(world=world)

    @property
    def observation_spec(self) -> Spec:
        """``Obs.flat``, (obs_dim(world),), within the bounds the simulator guarantees
        (``sim.obs_bounds``: velocities within the command limits, the scan within [0, its
        range], and with the staleness inputs the visible flag and time since seen >= 0;
        infinite where none is proven)."""
        low, high = obs_bounds(self.world)
        n = obs_dim(self.world)
        return Spec((n,), low.flat, high.flat)

    @property
    def action_spec(self) -> Spec:
        """The base command (vx, vy, yaw rate) in m/s and rad/s, (ACTION_DIM,)."""
        b = self.world.base
        return Spec((ACTION_DIM,), command_low(b), command_high(b))


def as_env(env_or_world: Environment | WorldCfg) -> Environment:
    """An environment from either an environment or a world (the JAX backend)."""
    if isinstance(env_or_world, WorldCfg):
        return JaxCatchEnv(env_or_world)
    return env_or_world
