"""Gymnasium front-ends of the catch world: ``CatchEnv`` (one) and ``CatchVectorEnv`` (many).

The classes load on first use, so ``import dyncatch`` (which registers the gymnasium ids)
does not import JAX.
"""

from __future__ import annotations

from importlib import import_module
from typing import TYPE_CHECKING

from dyncatch.gym.registration import CATCH_ID, CATCH_VECTOR_ID, register_envs

if TYPE_CHECKING:
    from dyncatch.gym.catch_env import CatchEnv
    from dyncatch.gym.vector_env import CatchVectorEnv

_LAZY = {"CatchEnv": "dyncatch.gym.catch_env", "CatchVectorEnv": "dyncatch.gym.vector_env"}


def __getattr__(name: str):
    if name in _LAZY:
        return getattr(import_module(_LAZY[name]), name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")


__all__ = ["CATCH_ID", "CATCH_VECTOR_ID", "CatchEnv", "CatchVectorEnv", "register_envs"]
