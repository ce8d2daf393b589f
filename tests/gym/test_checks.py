"""Gymnasium's own checks: the PassiveEnvChecker that ``gymnasium.make`` adds raises no warning
over whole episodes, and (Gymnasium 1.4 has no vector-env checker) the vector env's API
contract compared piece by piece with Gymnasium's ``SyncVectorEnv`` over ``CatchEnv``."""

from __future__ import annotations

import warnings

import gymnasium
import numpy as np
import pytest
from gymnasium.vector import AutoresetMode
from gymnasium.wrappers import PassiveEnvChecker
from gymnasium.wrappers.vector import DictInfoToList

import dyncatch  # noqa: F401  (registers the gymnasium ids)
from dyncatch.gym import CATCH_ID, CATCH_VECTOR_ID
from dyncatch.gym.vector_env import CatchVectorEnv
from dyncatch.sim.api import OBS_DIM
from dyncatch.sim.config import EpisodeCfg, WorldCfg

SIZE_PX = 128
NUM_ENVS = 4
EPISODE_STEPS = 10
SHORT_WORLD = WorldCfg(episode=EpisodeCfg(duration_s=EPISODE_STEPS / 50))


def wrappers_of(env) -> list[type]:
    types = []
    while isinstance(env, gymnasium.Wrapper):
        types.append(type(env))
        env = env.env
    return types


@pytest.mark.parametrize("render_mode", [None, "rgb_array"])
def test_passive_env_checker_sees_no_warning(render_mode):
    """Two whole episodes (a catch or the limit, then a reset) with every warning an error."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        env = gymnasium.make(
            CATCH_ID, render_mode=render_mode, render_size_px=SIZE_PX, world=SHORT_WORLD
        )
        assert PassiveEnvChecker in wrappers_of(env)
        env.action_space.seed(0)
        episodes, steps = 0, 0
        env.reset(seed=0)
        while episodes < 2:
            _, _, terminated, truncated, _ = env.step(env.action_space.sample())
            steps += 1
            if render_mode is not None:
                assert env.render().shape == (SIZE_PX, SIZE_PX, 3)
            if terminated or truncated:
                episodes += 1
                env.reset()
        env.close()
    assert steps == 2 * EPISODE_STEPS


def reference_vector_env() -> gymnasium.vector.SyncVectorEnv:
    """Gymnasium's own vector env over CatchEnv, with the same auto-reset mode."""
    return gymnasium.make_vec(
        CATCH_ID,
        num_envs=NUM_ENVS,
        vectorization_mode="sync",
        vector_kwargs={"autoreset_mode": AutoresetMode.SAME_STEP},
        world=SHORT_WORLD,
        render_mode="rgb_array",
        render_size_px=SIZE_PX,
    )


def per_env(info: dict, num_envs: int) -> list[dict]:
    """What each environment's info holds: key -> (shape of one entry, dtype kind), keys
    kept where their ``_key`` mask is set, nested dicts included. The kind ("f", "b"), as
    the reference batches Python floats as float64 and ours are float32."""
    out: list[dict] = [{} for _ in range(num_envs)]
    for key, value in info.items():
        if key.startswith("_"):
            continue
        for i in np.flatnonzero(info[f"_{key}"]):
            if isinstance(value, dict):
                out[i][key] = per_env(value, num_envs)[i]
            else:
                entry = np.asarray(value[i])
                out[i][key] = (entry.shape, entry.dtype.kind)
    return out


@pytest.fixture(scope="module")
def envs():
    """(ours through gymnasium.make_vec, the reference), both rendering."""
    ours = gymnasium.make_vec(
        CATCH_VECTOR_ID,
        num_envs=NUM_ENVS,
        world=SHORT_WORLD,
        render_mode="rgb_array",
        render_size_px=SIZE_PX,
    )
    assert isinstance(ours, CatchVectorEnv)
    return ours, reference_vector_env()


class TestVectorContract:
    def test_spaces_and_metadata(self, envs):
        ours, ref = envs
        assert ours.num_envs == ref.num_envs == NUM_ENVS
        for name in ("observation_space", "action_space"):
            assert getattr(ours, f"single_{name}") == getattr(ref, f"single_{name}")
            assert getattr(ours, name) == getattr(ref, name)
        for key in ("autoreset_mode", "render_modes", "render_fps"):
            assert ours.metadata[key] == ref.metadata[key], key
        assert ours.render_mode == ref.render_mode == "rgb_array"

    def test_step_outputs_and_info_layout(self, envs):
        """Every step, and the step where every episode ends, as the reference lays them out."""
        ours, ref = envs
        actions = np.tile(np.array([1.0, 0.3, -0.5], np.float32), (NUM_ENVS, 1))
        for env in envs:
            obs, info = env.reset(seed=0)
            assert obs.shape == (NUM_ENVS, OBS_DIM) and obs.dtype == np.float32 and info == {}
        for t in range(1, EPISODE_STEPS + 1):
            out, ref_out = ours.step(actions), ref.step(actions)
            # obs float32, rewards float (the reference's float64, ours float32), flags bool.
            for a, b in zip(out[:4], ref_out[:4], strict=True):
                assert (a.shape, a.dtype.kind) == (b.shape, b.dtype.kind)
            np.testing.assert_array_equal(out[3], t == EPISODE_STEPS)
            np.testing.assert_array_equal(out[3], ref_out[3])
            info, ref_info = out[4], ref_out[4]
            # Each environment's info holds the same keys with entries of the same shape.
            assert per_env(info, NUM_ENVS) == per_env(ref_info, NUM_ENVS), t
            # The reference keeps final_obs as an object array of per-env observations, and
            # only on steps where an episode ended; ours is always a (num_envs, OBS_DIM) array.
            assert info["final_obs"].shape == (NUM_ENVS, OBS_DIM)
            assert info["final_obs"].dtype == np.float32
            if t == EPISODE_STEPS:
                np.testing.assert_array_equal(info["_final_obs"], True)
                assert np.stack(ref_info["final_obs"]).shape == info["final_obs"].shape
            else:
                assert "final_obs" not in ref_info and not info["_final_obs"].any()

    def test_dict_info_to_list_reads_our_masks(self, envs):
        ours, ref = envs
        lists = []
        for env in (ours, ref):
            wrapped = DictInfoToList(env)
            wrapped.reset(seed=1)
            *_, infos = wrapped.step(np.zeros((NUM_ENVS, 3), np.float32))
            lists.append(infos)
        assert len(lists[0]) == NUM_ENVS
        assert [sorted(i) for i in lists[0]] == [sorted(i) for i in lists[1]]
        assert all(isinstance(i["success"], bool | np.bool_) for i in lists[0])

    def test_render_is_a_tuple_like_the_reference(self, envs):
        for env in envs:
            env.reset(seed=2)
        frames = [env.render() for env in envs]
        for got in frames:
            assert isinstance(got, tuple) and len(got) == NUM_ENVS
            assert {(f.shape, f.dtype) for f in got} == {
                ((SIZE_PX, SIZE_PX, 3), np.dtype(np.uint8))
            }
