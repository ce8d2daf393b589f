"""A control step's random draws from one ``jax.random.split`` of the episode's key.

``step_draws(key)`` gives the next step's key, the behaviour's key and the step's standard
normals (the gait's 3 and the camera's 2). The normals are made from the data of the extra
keys of the same split: a threefry key's data are output words of the hash, as
``jax.random.bits`` returns them, and they go through the map ``jax.random.normal`` uses
(23 mantissa bits to a uniform in (-1, 1), then sqrt(2) erfinv), which the tests check
word for word. On XLA:CPU every threefry call is a loop of its own: the three calls a step
made before (a split into 4, then the gait's and the camera's normals apart) took 0.43 ms
per step of 4096 environments, this one 0.22 ms (2026-12-02; docs/performance.md, "A step's
random numbers, XLA's library fusions and the obstacles").
"""

from __future__ import annotations

import math
from typing import NamedTuple

import jax
import jax.numpy as jnp

GAIT_NORMALS = 3
"""The gait's velocity noise (vx, vy, yaw rate), ``base.add_gait_noise``."""
SENSE_NORMALS = 2
"""The camera's position noise (x, y), ``sensing.sensor_tick``."""


class StepDraws(NamedTuple):
    next_key: jax.Array
    """The key of the next step (a key of the same implementation as the one drawn from)."""
    behavior_key: jax.Array
    """The key passed to the behaviour's ``desired_heading``."""
    gait_noise: jax.Array
    """(3,) standard normal."""
    sense_noise: jax.Array
    """(2,) standard normal."""


def _normals(bits: jax.Array) -> jax.Array:
    """Standard normals from uint32 words: 23 bits of mantissa give a uniform in (-1, 1),
    then sqrt(2) erfinv, the map ``jax.random.normal`` uses."""
    unit = jax.lax.bitcast_convert_type((bits >> 9) | jnp.uint32(0x3F800000), jnp.float32) - 1.0
    lo = jnp.nextafter(jnp.float32(-1.0), jnp.float32(0.0))
    u = jnp.maximum(lo, unit * (1.0 - lo) + lo)
    return jnp.float32(math.sqrt(2.0)) * jax.lax.erf_inv(u)


def step_draws(key: jax.Array) -> StepDraws:
    """The step's draws from ``key`` (a typed PRNG key, ()), in one ``split``."""
    words_per_key = math.prod(jax.random.key_data(key).shape)
    normals = GAIT_NORMALS + SENSE_NORMALS
    keys = jax.random.split(key, 2 + math.ceil(normals / words_per_key))
    noise = _normals(jax.random.key_data(keys[2:]).reshape(-1)[:normals])
    return StepDraws(
        next_key=keys[0],
        behavior_key=keys[1],
        gait_noise=noise[:GAIT_NORMALS],
        sense_noise=noise[GAIT_NORMALS:],
    )
