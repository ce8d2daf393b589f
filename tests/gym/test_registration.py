"""Gymnasium registration: idempotent, no TimeLimit, and the same reward as ``dyncatch train``."""

from __future__ import annotations

import dataclasses
import warnings

import gymnasium
import pytest

import dyncatch  # noqa: F401  (registers the gymnasium ids)
from dyncatch.cli.main import parse
from dyncatch.gym import CATCH_ID, CATCH_VECTOR_ID, register_envs
from dyncatch.gym.vector_env import CatchVectorEnv
from dyncatch.sim.reward import weights


def test_registration_is_idempotent():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        register_envs()
        register_envs()
    assert gymnasium.spec(CATCH_ID).max_episode_steps is None
    venv = gymnasium.make_vec(CATCH_VECTOR_ID, num_envs=3, behavior="bounce")
    assert isinstance(venv, CatchVectorEnv)
    assert (venv.num_envs, venv.world.target.behavior) == (3, "bounce")


# Eq. 9's weights in the standard setting (docs/model.md): w1 = 1, w2 = 0.2 per second,
# w3 = 5 paid once at the catch.
TRAINING_REWARD = {
    "pursuit": 1.0,
    "visibility": 0.2,
    "success": 5.0,
    "visibility_per": "per_second",
    "success_per": "terminal",
}


def test_gymnasium_make_and_dyncatch_train_share_the_training_reward(tmp_path):
    made = gymnasium.make(CATCH_ID).unwrapped.world
    trained = parse(["train", "--out", str(tmp_path)])[1].world
    assert dataclasses.asdict(made.reward) == TRAINING_REWARD
    assert dataclasses.asdict(trained.reward) == TRAINING_REWARD
    # The visibility term pays 0.2 per second (0.004 per 50 Hz step), not 0.2 per step.
    assert weights(made.reward, made.episode.dt_s)["visibility"] == pytest.approx(0.004)
