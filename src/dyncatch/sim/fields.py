"""Field helpers of the config dataclasses.

Kept apart from ``config`` so that behaviour modules, whose config classes ``config``
composes into ``TargetCfg``, can use them without importing ``config``.
"""

from __future__ import annotations

from flax import struct


def static(default):
    """A config field that is a compile-time constant (changing it recompiles)."""
    return struct.field(pytree_node=False, default=default)
