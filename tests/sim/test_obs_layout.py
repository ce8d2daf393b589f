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
# All egocentric (issue 12): no world position, heading or wall distances. The staleness
# inputs are in ``flat`` only under ``observation.staleness_inputs`` (reading
# ``staleness_observation``); the default is the paper's s (IV-A), without them.
LAYOUT = {
    "robot_vel_body_mps": 2,
    "robot_yaw_rate_rps": 1,
    "target_obs_body_m": 2,
    "time_since_seen_s": 1,
    "visible": 1,
    "scan_m": 8,
}
STALENESS = ("time_since_seen_s", "visible")
PAPER_LAYOUT = {k: v for k, v in LAYOUT.items() if k not in STALENESS}


def _array_fields(cls):
    """The array fields of an Obs class (``staleness`` is a static flag, not in ``flat``)."""
    return [f for f in cls.__dataclass_fields__.values() if "shape" in f.metadata]


def _numbered(cls, batch, rays=8, staleness=True):
    """An Obs whose every entry is its own index among all its array fields (the flat
    vector with the staleness inputs), with batch dims."""
    fields, start = {}, 0
    for f in _array_fields(cls):
        shape = tuple(rays if d == SCAN_RAYS else d for d in f.metadata["shape"])
        size = int(np.prod(shape))
        vals = jnp.arange(start, start + size, dtype=jnp.float32).reshape(shape)
        fields[f.name] = jnp.broadcast_to(vals, batch + vals.shape)
        start += size
    return cls(**fields, staleness=staleness), start


def _stale_world() -> WorldCfg:
    w = WorldCfg()
    return w.replace(observation=w.observation.replace(staleness_inputs=True))


def test_obs_dim_is_13_in_the_documented_order_and_15_with_the_staleness_inputs():
    assert OBS_DIM == obs_dim(WorldCfg()) == sum(PAPER_LAYOUT.values()) == 13
    assert obs_dim(_stale_world()) == sum(LAYOUT.values()) == 15
    assert dict(Obs.layout(8, staleness=False)) == PAPER_LAYOUT
    assert dict(Obs.layout(8, staleness=True)) == LAYOUT
    assert [f.name for f in _array_fields(Obs)] == list(LAYOUT)
    obs, n = _numbered(Obs, (3, 5))
    flat = obs.flat
    assert n == 15 and flat.shape == (3, 5, 15)
    np.testing.assert_array_equal(flat[2, 4], np.arange(n))
    # Without them: indices 5 and 6 (time_since_seen_s, visible) are left out, in order.
    paper, _ = _numbered(Obs, (3, 5), staleness=False)
    assert paper.flat.shape == (3, 5, OBS_DIM)
    np.testing.assert_array_equal(paper.flat[2, 4], [0, 1, 2, 3, 4, *range(7, 15)])


def test_a_new_field_widens_flat_without_touching_it():
    @struct.dataclass
    class Wider(Obs):
        target_vel_m: jax.Array = obs_field((2,))

    obs, n = _numbered(Wider, (4,))
    assert n == 15 + 2
    np.testing.assert_array_equal(obs.flat[0], np.arange(n))


def test_the_scan_is_as_wide_as_the_worlds_rays():
    world = WorldCfg().for_scene("room_4")
    assert obs_dim(world) == 5 + 32
    assert obs_dim(world.replace(observation=_stale_world().observation)) == 7 + 32
    obs, n = _numbered(Obs, (2,), rays=32)
    assert n == 39 and obs.flat.shape == (2, 39)
    assert dict(Obs.layout(32, staleness=False))["scan_m"] == 32
