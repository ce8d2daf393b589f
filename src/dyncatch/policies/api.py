"""The policy protocol: stateless ``(obs, key) -> action`` or recurrent with a carry.

Everything that plays episodes (evaluation, rendering) calls ``as_recurrent(policy)`` and
then ``init_carry(state, obs)`` / ``step(carry, state, obs, key) -> (carry, action)`` for
one environment. The env ``state`` is passed so that privileged methods (ground-truth
prediction) fit the same mould; honest policies read only ``obs`` and their own carry.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any, Protocol, runtime_checkable

import jax

from dyncatch.sim.state import EnvState, Obs


@runtime_checkable
class RecurrentPolicy(Protocol):
    def init_carry(self, state: EnvState, obs: Obs) -> Any: ...

    def step(
        self, carry: Any, state: EnvState, obs: Obs, key: jax.Array
    ) -> tuple[Any, jax.Array]: ...


@dataclasses.dataclass(frozen=True)
class Stateless:
    """A stateless ``(obs, key) -> action`` seen through the recurrent protocol."""

    policy: Callable[[Obs, jax.Array], jax.Array]

    def init_carry(self, state: EnvState, obs: Obs) -> tuple:
        return ()

    def step(self, carry: tuple, state: EnvState, obs: Obs, key: jax.Array):
        return carry, self.policy(obs, key)


def as_recurrent(policy) -> RecurrentPolicy:
    return policy if isinstance(policy, RecurrentPolicy) else Stateless(policy)
