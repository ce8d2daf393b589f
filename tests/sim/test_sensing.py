"""The camera: 2 Hz sample-and-hold, field-of-view edges, latency."""

import math

import jax
import jax.numpy as jnp
import numpy as np
import pytest

from dyncatch.sim import env
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.sensing import in_view

from .helpers import fixed_rollout, place, world_xy

CFG = WorldCfg().with_behavior("bounce").with_speed(1.0)


def _facing(cfg, target_xy=(12.0, 8.0), heading=math.pi / 2):
    """The robot at (8, 8) (world) facing +x; the stored frame is centred on it."""
    s = jax.jit(env.reset)(jax.random.key(0), cfg)
    return place(s, robot_xy=(8.0, 8.0), robot_yaw=0.0, target_xy=target_xy, heading=heading)


def _held_world(states):
    """The held sighting in world coordinates, (T, 2)."""
    return np.asarray(world_xy(states, states.sensor.obs_xy_m))


def _changes(held):
    """Rollout indices where the held sighting moved. Re-centring rounds it by ~1e-6 m a
    step; a new frame moves it by ~0.5 m (1 m/s for half a second)."""
    return np.flatnonzero(np.linalg.norm(np.diff(held, axis=0), axis=-1) > 1e-3) + 1


def test_observations_update_exactly_every_half_second():
    s = _facing(CFG)
    states, obs, _ = fixed_rollout(s, jnp.zeros(3), CFG, 100)
    held = _held_world(states)
    changed = _changes(held)
    # Step k of the rollout is control step k + 1: frames land on steps 25, 50, 75, 100.
    np.testing.assert_array_equal(changed + 1, [25, 50, 75, 100])
    # Each delivered frame is the true position at that step.
    for k in (24, 49, 74):
        np.testing.assert_allclose(held[k], world_xy(states, states.target.xy_m)[k], atol=1e-5)
    tss = np.asarray(obs.time_since_seen_s)
    np.testing.assert_allclose(tss[24], 0.0, atol=1e-6)
    np.testing.assert_allclose(tss[23], 0.48, atol=1e-5)


@pytest.mark.parametrize(
    ("angle_deg", "seen"),
    [(59.0, True), (61.0, False), (-59.0, True), (-61.0, False), (180.0, False)],
)
def test_field_of_view_edges(angle_deg, seen):
    s = _facing(CFG)
    a = math.radians(angle_deg)
    point = jnp.array([8.0 + 3 * math.cos(a), 8.0 + 3 * math.sin(a)])
    assert bool(in_view(s.robot, point - s.origin_xy_m, CFG)) is seen


def test_range_limit():
    s = _facing(CFG)
    local = -s.origin_xy_m  # world points are stored relative to the robot
    assert bool(in_view(s.robot, jnp.array([8.0 + 9.9, 8.0]) + local, CFG))
    assert not bool(in_view(s.robot, jnp.array([8.0 + 10.1, 8.0]) + local, CFG))


def test_no_update_while_out_of_view():
    s = _facing(CFG, target_xy=(4.0, 8.0))  # behind the robot
    states, obs, _ = fixed_rollout(s, jnp.zeros(3), CFG, 100)
    held = _held_world(states)
    np.testing.assert_allclose(held, np.broadcast_to(held[0], held.shape), atol=1e-5)
    assert float(obs.visible.max()) == 0.0
    # Time since last sighting keeps growing by 0.02 s a step.
    np.testing.assert_allclose(np.diff(np.asarray(obs.time_since_seen_s)), 0.02, atol=1e-5)


def test_latency_delays_delivery():
    cfg = CFG.replace(sensor=CFG.sensor.replace(latency_s=0.1))
    s = _facing(cfg)
    states, obs, _ = fixed_rollout(s, jnp.zeros(3), cfg, 60)
    held = _held_world(states)
    changed = _changes(held)
    # Captured at control steps 25 and 50, delivered 5 steps (0.1 s) later.
    np.testing.assert_array_equal(changed + 1, [30, 55])
    np.testing.assert_allclose(held[29], world_xy(states, states.target.xy_m)[24], atol=1e-5)
    np.testing.assert_allclose(obs.time_since_seen_s[29], 0.1, atol=1e-6)
