"""reset(options=...) of both adapters: the world they ask for equals an adapter built with it,
it holds for later episodes, bad keys and values are refused by name, and the handler
registry is the seam for new options."""

from __future__ import annotations

import numpy as np
import pytest

from dyncatch.gym import options as gym_options
from dyncatch.gym.catch_env import CatchEnv
from dyncatch.gym.vector_env import CatchVectorEnv
from dyncatch.sim.validate import ConfigError

ACTION = np.array([1.0, 0.3, -0.5], np.float32)
NUM_ENVS = 4


def first_obs(env: CatchEnv, seed: int, steps: int = 5, **reset_kwargs) -> np.ndarray:
    """Observations (steps + 1, 17) from ``reset(seed=seed, **reset_kwargs)`` under ACTION."""
    obs = [env.reset(seed=seed, **reset_kwargs)[0]]
    obs += [env.step(ACTION)[0] for _ in range(steps)]
    return np.stack(obs)


class TestCatchEnvOptions:
    def test_options_give_the_world_of_an_env_built_with_them(self):
        env, built = CatchEnv("reactive"), CatchEnv("circle", speed_mps=0.7)
        got = first_obs(env, 5, options={"behavior": "circle", "speed_mps": 0.7})
        np.testing.assert_array_equal(got, first_obs(built, 5))
        assert env.world == built.world
        # Later episodes keep the world the options chose.
        np.testing.assert_array_equal(first_obs(env, 6), first_obs(built, 6))

    def test_the_scene_option_gives_the_world_of_an_env_built_in_that_scene(self):
        env = CatchEnv("reactive", speed_mps=1.8)
        built = CatchEnv("reactive", world=env.world.with_scene("open_plane"), speed_mps=1.8)
        got = first_obs(env, 2, options={"scene": "open_plane"})
        np.testing.assert_array_equal(got, first_obs(built, 2))
        assert env.world.scene.name == "open_plane"
        assert env.observation_space == built.observation_space

    def test_speed_none_restores_the_built_range(self):
        env = CatchEnv("circle")
        built = (env.world.target.speed_min_mps, env.world.target.speed_max_mps)
        assert built == (0.0, 1.8)
        env.reset(seed=0, options={"speed_mps": 0.5})
        assert (env.world.target.speed_min_mps, env.world.target.speed_max_mps) == (0.5, 0.5)
        assert float(env.state.target.speed_mps) == pytest.approx(0.5)
        env.reset(seed=0, options={"speed_mps": None})
        assert (env.world.target.speed_min_mps, env.world.target.speed_max_mps) == built

    def test_empty_options_change_nothing(self):
        env = CatchEnv("circle", speed_mps=0.7)
        world = env.world
        env.reset(seed=0, options={})
        assert env.world is world

    @pytest.mark.parametrize(
        ("options", "error", "named"),
        [
            (
                {"weather": "rain"},
                ValueError,
                r"'weather'.*allowed: 'scene', 'behavior', 'speed_mps'",
            ),
            ({"scene": "forest"}, ConfigError, r"unknown scene 'forest'"),
            ({"behavior": "zigzag"}, ConfigError, r"target.behavior: unknown behavior 'zigzag'"),
            ({"speed_mps": -1.0}, ConfigError, r"'speed_mps': -1.0.*speed_min_mps"),
            ({"speed_mps": "fast"}, ValueError, r"'speed_mps' must be a speed in m/s"),
            ({"speed_mps": True}, ValueError, r"'speed_mps' must be a speed in m/s"),
            ({"behavior": 3}, ValueError, r"'behavior' must be a behaviour name"),
        ],
    )
    def test_bad_options_are_refused_and_change_nothing(self, options, error, named):
        env = CatchEnv("circle", speed_mps=0.7)
        world = env.world
        with pytest.raises(error, match=named):
            env.reset(seed=0, options=options)
        assert env.world is world


def test_vector_env_options_match_a_vector_env_built_with_them():
    venv = CatchVectorEnv(NUM_ENVS)
    built = CatchVectorEnv(NUM_ENVS, speed_mps=0.7)
    got, _ = venv.reset(seed=3, options={"speed_mps": 0.7})
    np.testing.assert_array_equal(got, built.reset(seed=3)[0])
    actions = np.tile(ACTION, (NUM_ENVS, 1))
    np.testing.assert_array_equal(venv.step(actions)[0], built.step(actions)[0])
    assert venv.world == built.world
    with pytest.raises(ValueError, match="allowed: 'scene', 'behavior', 'speed_mps'"):
        venv.reset(options={"reset_mask": np.ones(NUM_ENVS, bool)})


class TestTheSeam:
    """A new option is one entry in RESET_OPTIONS; one that would change a space is refused."""

    def test_a_registered_option_is_applied(self, monkeypatch):
        def camera_noise(world, value, built):
            return world.replace(sensor=world.sensor.replace(noise_m=float(value)))

        monkeypatch.setitem(gym_options.RESET_OPTIONS, "camera_noise_m", camera_noise)
        env = CatchEnv()
        env.reset(seed=0, options={"camera_noise_m": 0.2})
        assert env.world.sensor.noise_m == 0.2

    def test_an_option_that_changes_the_observation_space_is_refused(self, monkeypatch):
        def scan_range(world, value, built):
            return world.replace(scene=world.scene.replace(scan_range_m=float(value)))

        monkeypatch.setitem(gym_options.RESET_OPTIONS, "scan_range_m", scan_range)
        env = CatchEnv()
        world = env.world
        with pytest.raises(ValueError, match="change the observation space.*gymnasium.make"):
            env.reset(seed=0, options={"scan_range_m": 20.0})
        assert env.world is world
