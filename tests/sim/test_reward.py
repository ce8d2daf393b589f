"""Eq. 6-9 worked by hand."""

import math

import jax.numpy as jnp
import numpy as np

from dyncatch.sim.config import RewardCfg, WorldCfg
from dyncatch.sim.reward import reward_terms, total_reward

CFG = WorldCfg()
EQ9 = RewardCfg(visibility_per="per_step")
DT = 0.02


def test_terms_and_weights_by_hand():
    # Eq. 9 as written (per step). Closed 0.3 m, target 50 deg off the heading (inside the
    # 60 deg half-cone), no catch: R = 1 * 0.3 + 0.2 * 1 + 5 * 0 = 0.5
    terms = reward_terms(
        jnp.array(2.0), jnp.array(1.7), jnp.array(math.radians(50)), jnp.array(False), CFG.sensor
    )
    np.testing.assert_allclose(terms["pursuit"], 0.3, atol=1e-6)
    assert float(terms["visibility"]) == 1.0 and float(terms["success"]) == 0.0
    np.testing.assert_allclose(total_reward(terms, EQ9, DT), 0.5, atol=1e-6)
    # The default reads w2 per second: R = 0.3 + 0.2 * 0.02 * 1 = 0.304
    np.testing.assert_allclose(total_reward(terms, CFG.reward, DT), 0.304, atol=1e-6)
    # Lost 0.1 m, target behind (70 deg), caught: R = -0.1 + 0 + 5 = 4.9
    terms = reward_terms(
        jnp.array(1.0), jnp.array(1.1), jnp.array(math.radians(-70)), jnp.array(True), CFG.sensor
    )
    np.testing.assert_allclose(total_reward(terms, EQ9, DT), 4.9, atol=1e-6)
    np.testing.assert_allclose(total_reward(terms, CFG.reward, DT), 4.9, atol=1e-6)


def test_paper_weights_are_the_defaults():
    r = CFG.reward
    assert (r.pursuit, r.visibility, r.success) == (1.0, 0.2, 5.0)
    assert r.visibility_per == "per_second"
    assert abs(CFG.sensor.fov_rad - math.radians(120)) < 1e-12
