"""run_gym_episodes: one episode per environment, catch times and failures as ``dyncatch eval``
counts them, checked against each episode replayed alone in a single ``CatchEnv``."""

from __future__ import annotations

import jax
import numpy as np
import pytest

from dyncatch.evaluation.grid import EVAL_STREAM
from dyncatch.evaluation.gym_episodes import format_summary, run_gym_episodes
from dyncatch.evaluation.stats import summarize
from dyncatch.gym.catch_env import CatchEnv
from dyncatch.gym.vector_env import CatchVectorEnv
from dyncatch.sim.api import obs_layout
from dyncatch.sim.config import EpisodeCfg, WorldCfg

NUM_ENVS = 4
# 3 s episodes of a target standing still: some catches, some failures, and the envs that
# catch early play further episodes that must not count.
WORLD = WorldCfg(episode=EpisodeCfg(duration_s=3.0)).with_speed(0.0)


_LAYOUT = obs_layout(WORLD)
_SIGHTING = sum(size for _, size in _LAYOUT[: [n for n, _ in _LAYOUT].index("target_obs_body_m")])
"""Where target_obs_body_m starts in ``Obs.flat``."""


def pursue(obs: np.ndarray) -> np.ndarray:
    """Drive at the last sighting in the body frame; spin while none."""
    x, y = obs[:, _SIGHTING], obs[:, _SIGHTING + 1]
    unseen = np.hypot(x, y) < 1e-6
    yaw_rate = np.where(unseen, 2.0, np.clip(3.0 * np.arctan2(y, x), -2.0, 2.0))
    vx = np.where(unseen, 0.0, np.clip(2.0 * x, -1.0, 2.0))
    return np.stack([vx, np.clip(2.0 * y, -1.0, 1.0), yaw_rate], axis=1).astype(np.float32)


def replay_alone(venv: CatchVectorEnv, index: int, seed: int) -> tuple[bool, float]:
    """(caught, catch time or the limit) of env ``index``'s first episode, stepped alone."""
    venv.reset(seed=EVAL_STREAM + seed)
    env = CatchEnv(world=venv.world)
    env._state = jax.tree.map(lambda x: x[index], venv.state)
    obs = np.asarray(env.env.observe(env.state).flat)
    for step in range(1, int(venv.world.episode.max_steps) + 1):
        obs, _, terminated, truncated, _ = env.step(pursue(obs[None])[0])
        if terminated or truncated:
            return terminated, (step if terminated else venv.world.episode.max_steps) * 0.02
    raise AssertionError("the episode did not end at its limit")


def test_outcomes_equal_each_episode_replayed_alone():
    venv = CatchVectorEnv(NUM_ENVS, world=WORLD)
    out = run_gym_episodes(venv, pursue, seed=1)
    assert out["success"].shape == out["catch_time_s"].shape == (NUM_ENVS,)
    expected = [replay_alone(venv, i, seed=1) for i in range(NUM_ENVS)]
    np.testing.assert_array_equal(out["success"], [caught for caught, _ in expected])
    np.testing.assert_allclose(out["catch_time_s"], [t for _, t in expected], atol=1e-9)
    assert out["success"].any(), "no catch: the check of catch times would be empty"
    assert not out["success"].all(), "no failure: the check of the limit would be empty"


def test_a_policy_that_stands_still_fails_every_episode_at_the_limit():
    venv = CatchVectorEnv(NUM_ENVS, world=WORLD)
    out = run_gym_episodes(venv, lambda obs: np.zeros((len(obs), 3), np.float32))
    s = summarize(out)
    assert (s["episodes"], s["success_rate"], s["catch_time_s"]) == (NUM_ENVS, 0.0, 3.0)
    assert format_summary(s) == (
        "success 0.000 [0.000, 0.490] (95 % CI), catch time 3.00 s, 4 episodes"
    )


def test_needs_same_step_autoreset():
    venv = CatchVectorEnv(NUM_ENVS, world=WORLD)
    venv.metadata = {**venv.metadata, "autoreset_mode": None}
    with pytest.raises(ValueError, match="same-step auto-reset.*CatchVectorEnv"):
        run_gym_episodes(venv, pursue)
