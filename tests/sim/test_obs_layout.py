"""``Obs.flat`` keeps its layout, and its width follows the fields' shapes and the world's
ray count."""

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from dyncatch.sim.api import OBS_DIM, obs_dim
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.state import SCAN_RAYS, Obs, obs_field

# Per-environment width of each field, in ``flat`` order (the trained networks rely on it).
# All egocentric (issue 12): no world position, heading or wall distances.
LAYOUT = {
    "robot_vel_body_mps": 2,
    "robot_yaw_rate_rps": 1,
    "target_obs_body_m": 2,
    "time_since_seen_s": 1,
    "visible": 1,
    "scan_m": 8,
}


def _array_fields(cls):
    """The array fields of an Obs class (``staleness`` is a static flag, not in ``flat``)."""
    return [f for f in cls.__dataclass_fields__.values() if "shape" in f.metadata]


def _numbered(cls, batch, rays=8):
    """An Obs whose every entry is its own index in the flat vector, with batch dims."""
    fields, start = {}, 0
    for f in _array_fields(cls):
        shape = tuple(rays if d == SCAN_RAYS else d for d in f.metadata["shape"])
        size = int(np.prod(shape))
        vals = jnp.arange(start, start + size, dtype=jnp.float32).reshape(shape)
        fields[f.name] = jnp.broadcast_to(vals, batch + vals.shape)
        start += size
    return cls(**fields), start


def test_obs_dim_is_15_in_the_documented_order():
    assert OBS_DIM == sum(LAYOUT.values()) == 15
    assert [f.name for f in _array_fields(Obs)] == list(LAYOUT)
    obs, n = _numbered(Obs, (3, 5))
    flat = obs.flat
    assert flat.shape == (3, 5, OBS_DIM)
    np.testing.assert_array_equal(flat[2, 4], np.arange(n))


def test_a_new_field_widens_flat_without_touching_it():
    @struct.dataclass
    class Wider(Obs):
        target_vel_m: jax.Array = obs_field((2,))

    obs, n = _numbered(Wider, (4,))
    assert n == OBS_DIM + 2
    np.testing.assert_array_equal(obs.flat[0], np.arange(n))


def test_the_scan_is_as_wide_as_the_worlds_rays():
    world = WorldCfg().for_scene("room_4")
    assert obs_dim(world) == 7 + 32
    obs, n = _numbered(Obs, (2,), rays=32)
    assert n == 39 and obs.flat.shape == (2, 39)
    assert dict(Obs.layout(32))["scan_m"] == 32
