"""The observation bounds by hand (the property test that every observation of random
rollouts lies inside them is in tests/gym/test_catch_env.py, beside its compiled envs)."""

from __future__ import annotations

import numpy as np

from dyncatch.gym.catch_env import observation_space
from dyncatch.sim.api import JaxCatchEnv
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.obs_bounds import obs_bounds, velocity_bound_holds

INF = np.inf
VEL = slice(0, 3)
"""robot_vel_body_mps (2) and robot_yaw_rate_rps (1) in ``Obs.flat``."""


def test_default_world_bounds_by_hand():
    # Obs.flat: body velocity (2), yaw rate, target in the body frame (2), range scan (8
    # rays, capped at 10 m); with the staleness inputs (reading staleness_observation) time
    # since seen and visible come after the target.
    space = observation_space(JaxCatchEnv(WorldCfg()))
    low = [-1, -1, -2, -INF, -INF] + [0] * 8
    high = [2, 1, 2, INF, INF] + [10] * 8
    np.testing.assert_array_equal(space.low, low)
    np.testing.assert_array_equal(space.high, high)
    assert space.dtype == np.float32
    w = WorldCfg()
    stale = w.replace(observation=w.observation.replace(staleness_inputs=True))
    space = observation_space(JaxCatchEnv(stale))
    np.testing.assert_array_equal(space.low, [-1, -1, -2, -INF, -INF, 0, 0] + [0] * 8)
    np.testing.assert_array_equal(space.high, [2, 1, 2, INF, INF, INF, 1] + [10] * 8)


def test_bounds_follow_the_world():
    w = WorldCfg()
    world = w.replace(
        scene=w.scene.replace(scan_rays=4, scan_range_m=20.0),
        base=w.base.replace(max_forward_mps=3.0, max_yaw_rate_rps=1.5),
    )
    low, high = obs_bounds(world)
    np.testing.assert_array_equal(high.scan_m, [20.0] * 4)
    assert observation_space(JaxCatchEnv(world)).shape == (9,)  # 5 + 4 rays
    np.testing.assert_array_equal(high.robot_vel_body_mps, [3.0, 1.0])
    np.testing.assert_array_equal([low.robot_yaw_rate_rps, high.robot_yaw_rate_rps], [-1.5, 1.5])
    # A 0.005 s physics sub-step against a 0.004 s lag overshoots: no velocity bound.
    lagless = w.replace(base=w.base.replace(lag_s=0.004))
    assert not bool(velocity_bound_holds(lagless))
    low, high = obs_bounds(lagless)
    assert np.isneginf(low.flat[VEL]).all() and np.isposinf(high.flat[VEL]).all()


def test_bounds_are_jit_safe():
    """A traced world gives the same bounds (``observation_spec`` may be read under jit)."""
    import jax

    world = WorldCfg()
    low, high = jax.jit(lambda w: obs_bounds(w))(world)
    ref_low, ref_high = obs_bounds(world)
    np.testing.assert_array_equal(low.flat, ref_low.flat)
    np.testing.assert_array_equal(high.flat, ref_high.flat)
