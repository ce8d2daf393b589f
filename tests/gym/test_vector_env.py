"""CatchVectorEnv: shapes, seeding, same-step auto-reset and its final observations."""

from __future__ import annotations

import gymnasium
import jax
import jax.numpy as jnp
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode

from dyncatch.gym.catch_env import reset_flat, step_flat
from dyncatch.gym.vector_env import CatchVectorEnv
from dyncatch.sim.api import JaxCatchEnv, obs_dim, obs_layout
from dyncatch.sim.config import EpisodeCfg, WorldCfg

NUM_ENVS = 4
EPISODE_STEPS = 10
# 0.2 s at 50 Hz = 10 steps. The short episodes' world also feeds the staleness inputs
# (reading staleness_observation), so a final observation shows its episode's clock; the
# standard observation (without them) is the other fixture's. The single-env reference
# below is CatchEnv's jitted reset/step, an independent path without vmap or auto-reset.
# The walled arena: its range scan tells starts (and episodes) apart in the observation.
ARENA = WorldCfg().with_scene("arena")
SHORT_WORLD = ARENA.replace(
    episode=EpisodeCfg(duration_s=EPISODE_STEPS / 50),
    observation=ARENA.observation.replace(staleness_inputs=True),
)
ACTION = np.array([1.0, 0.3, -0.5], np.float32)
D = obs_dim(ARENA)
"""Width of ``Obs.flat`` in the arena."""


def _slot(world: WorldCfg, name: str) -> slice:
    """Where field ``name`` lies in ``Obs.flat`` of ``world``."""
    start = 0
    for field, size in obs_layout(world):
        if field == name:
            return slice(start, start + size)
        start += size
    raise KeyError(name)


SCAN = _slot(ARENA, "scan_m")
"""The range scan in ``Obs.flat``."""
SHORT_SCAN = _slot(SHORT_WORLD, "scan_m")
SHORT_TIME = _slot(SHORT_WORLD, "time_since_seen_s").start


@pytest.fixture(scope="module")
def venv() -> CatchVectorEnv:
    return CatchVectorEnv(num_envs=NUM_ENVS, world=ARENA)


@pytest.fixture(scope="module")
def short_venv() -> CatchVectorEnv:
    return CatchVectorEnv(num_envs=NUM_ENVS, world=SHORT_WORLD)


def test_shapes_and_dtypes(venv):
    assert venv.metadata["autoreset_mode"] is AutoresetMode.SAME_STEP
    assert D == 13 and SCAN == slice(5, 13)  # velocity 2, yaw rate 1, sighting 2, 8 rays
    assert venv.observation_space.shape == (NUM_ENVS, D)
    assert venv.action_space.shape == (NUM_ENVS, 3)
    obs, info = venv.reset(seed=0)
    assert obs.shape == (NUM_ENVS, D) and obs.dtype == np.float32 and info == {}
    assert venv.observation_space.contains(obs)
    venv.action_space.seed(0)
    obs, reward, terminated, truncated, info = venv.step(venv.action_space.sample())
    assert obs.shape == (NUM_ENVS, D) and venv.observation_space.contains(obs)
    assert reward.shape == (NUM_ENVS,) and reward.dtype == np.float32
    assert terminated.shape == truncated.shape == (NUM_ENVS,)
    assert terminated.dtype == truncated.dtype == np.bool_
    for key in ("reward/pursuit", "success", "distance_m"):
        assert info[key].shape == (NUM_ENVS,)
    assert not info["_final_obs"].any()
    np.testing.assert_array_equal(info["final_obs"], np.zeros((NUM_ENVS, D)))


def single_env_rollouts(seed: int, env: JaxCatchEnv, num_steps: int) -> np.ndarray:
    """Obs (num_envs, num_steps + 1, D) of env i started from split(PRNGKey(seed))[i]."""
    rollouts = []
    for key in jax.random.split(jax.random.PRNGKey(seed), NUM_ENVS):
        state, obs = reset_flat(key, env)
        all_obs = [obs]
        for _ in range(num_steps):
            state, obs, _, _ = step_flat(state, jnp.asarray(ACTION), env)
            all_obs.append(obs)
        rollouts.append(np.stack(all_obs))
    return np.stack(rollouts)


def test_reset_matches_single_env_resets(venv):
    obs, _ = venv.reset(seed=5)
    np.testing.assert_allclose(obs, single_env_rollouts(5, venv.env, 0)[:, 0], atol=1e-6)
    # The environments are independent: no two start at the same place in the arena (the
    # range scan, obs[SCAN], reads position and heading).
    gaps = np.linalg.norm(obs[:, None, SCAN] - obs[None, :, SCAN], axis=-1)
    assert gaps[~np.eye(NUM_ENVS, dtype=bool)].min() > 1e-3
    again, _ = venv.reset(seed=5)
    np.testing.assert_array_equal(obs, again)


def test_step_before_reset():
    with pytest.raises(RuntimeError, match="reset"):
        CatchVectorEnv(num_envs=2).step(np.zeros((2, 3), np.float32))


def test_wrong_action_shape(venv):
    venv.reset(seed=0)
    with pytest.raises(ValueError, match=r"shape \(4, 3\)"):
        venv.step(np.zeros((3, 3), np.float32))


class TestSameStepAutoreset:
    def run(self, env: CatchVectorEnv, num_steps: int):
        env.reset(seed=2)
        actions = np.tile(ACTION, (NUM_ENVS, 1))
        return [env.step(actions) for _ in range(num_steps)]

    def test_episodes_end_every_ten_steps(self, short_venv):
        steps = self.run(short_venv, 2 * EPISODE_STEPS + 3)
        truncated = np.stack([s[3] for s in steps])
        terminated = np.stack([s[2] for s in steps])
        assert not terminated.any()
        ended = np.flatnonzero(truncated.all(axis=1)) + 1
        np.testing.assert_array_equal(ended, [EPISODE_STEPS, 2 * EPISODE_STEPS])
        assert truncated.sum() == 2 * NUM_ENVS
        for obs, _, _, trunc, info in steps:
            assert short_venv.observation_space.contains(obs)
            np.testing.assert_array_equal(info["_final_obs"], trunc)
            np.testing.assert_array_equal(info["_final_info"], trunc)
            np.testing.assert_array_equal(info["final_obs"][~trunc], 0.0)

    def test_final_obs_is_the_last_obs_of_the_episode(self, short_venv):
        steps = self.run(short_venv, EPISODE_STEPS)
        obs, _, _, _, info = steps[-1]
        ref = single_env_rollouts(2, JaxCatchEnv(SHORT_WORLD), EPISODE_STEPS)[:, -1]
        np.testing.assert_allclose(info["final_obs"], ref, atol=1e-5)
        # Time since the last sighting (index 5): 0.2 s at the end, 0 in the new episode.
        assert SHORT_TIME == 5 and SHORT_SCAN == slice(7, 15)
        np.testing.assert_allclose(info["final_obs"][:, SHORT_TIME], 0.2, atol=1e-5)
        np.testing.assert_array_equal(obs[:, SHORT_TIME], 0.0)
        # The new episode starts elsewhere in the arena: the range scan differs.
        gap = obs[:, SHORT_SCAN] - info["final_obs"][:, SHORT_SCAN]
        assert np.linalg.norm(gap, axis=-1).min() > 1e-3

    def test_record_episode_statistics(self, short_venv):
        env = gymnasium.wrappers.vector.RecordEpisodeStatistics(short_venv)
        env.reset(seed=4)
        actions = np.tile(ACTION, (NUM_ENVS, 1))
        returns = np.zeros(NUM_ENVS)
        for _ in range(EPISODE_STEPS):
            _, reward, _, _, info = env.step(actions)
            returns += reward
        np.testing.assert_array_equal(info["_episode"], True)
        np.testing.assert_array_equal(info["episode"]["l"], EPISODE_STEPS)
        np.testing.assert_allclose(info["episode"]["r"], returns, rtol=1e-5, atol=1e-5)
