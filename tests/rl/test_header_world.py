"""A checkpoint header's world: the staleness inputs as recorded, and True for a run trained
before ``observation.staleness_inputs`` existed (it fed them; issue 32 changed the default)."""

from __future__ import annotations

from pathlib import Path

import jax
import pytest

from dyncatch.rl.config import PPOCfg
from dyncatch.rl.policy import header_world, load_run
from dyncatch.rl.runner import TrainRunCfg, TrainRunner, header_of
from dyncatch.sim.api import JaxCatchEnv, obs_dim
from dyncatch.sim.config import WorldCfg
from dyncatch.utils.tree_io import save_tree

PPO = PPOCfg(num_envs=8, num_steps=8, num_minibatches=2, update_epochs=1, hidden_sizes=(8,))
PATH = Path("old/checkpoint.safetensors")


def _world(staleness: bool) -> WorldCfg:
    w = WorldCfg()
    return w.replace(observation=w.observation.replace(staleness_inputs=staleness))


@pytest.mark.parametrize("staleness", [False, True])
def test_a_recorded_observation_is_read_as_recorded(staleness):
    header = header_of(TrainRunCfg(method="rl", world=_world(staleness)))
    assert header["world"]["observation"] == {"staleness_inputs": staleness}
    assert header_world(PATH, header).observation.staleness_inputs is staleness


@pytest.mark.parametrize("lost", ["observation", "staleness_inputs"])
def test_a_header_from_before_the_field_is_read_with_the_staleness_inputs(lost):
    header = header_of(TrainRunCfg(method="rl", world=_world(True)))
    if lost == "observation":
        del header["world"]["observation"]
    else:
        del header["world"]["observation"]["staleness_inputs"]
    assert WorldCfg().observation.staleness_inputs is False  # not today's default
    assert header_world(PATH, header).observation.staleness_inputs is True


def test_an_old_checkpoint_loads_and_acts_at_the_width_it_was_trained_at(tmp_path):
    """Its weights take 15 inputs: read with today's default (13) they would not load."""
    world = _world(True)
    runner = TrainRunner(TrainRunCfg(method="rl", out=tmp_path / "new", ppo=PPO, world=world))
    header = dict(runner.header, world={k: v for k, v in runner.header["world"].items()
                                        if k != "observation"})  # fmt: skip
    save_tree(tmp_path / "old" / "checkpoint.safetensors", runner.initial_state(), header)
    run = load_run(tmp_path / "old")
    assert run.world.observation.staleness_inputs is True
    assert run.policy.norm.mean.shape == (obs_dim(world),) == (15,)
    env = JaxCatchEnv(run.world)
    state = env.reset(jax.random.key(0))
    obs = env.observe(state)
    assert obs.flat.shape == (15,)
    carry = run.policy.init_carry(state, obs)
    _, command = run.policy.step(carry, state, obs, jax.random.key(1))
    assert command.shape == (3,)
