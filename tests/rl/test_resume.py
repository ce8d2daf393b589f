"""Checkpoint and resume: an interrupted run continues exactly."""

import jax
import numpy as np
import pytest

from dyncatch.rl.config import PPOCfg
from dyncatch.rl.train import make_train
from dyncatch.sim.config import WorldCfg
from dyncatch.utils.tree_io import TreeFileError, load_fields, load_tree, save_tree

WORLD = WorldCfg().with_behavior("bounce")
PPO = PPOCfg(num_envs=8, num_steps=8, num_minibatches=2, update_epochs=2, hidden_sizes=(32,))


@pytest.fixture(scope="module")
def trainer():
    init, iterate, _ = make_train(WORLD, PPO)
    return jax.jit(init), jax.jit(iterate)


def test_resume_matches_an_uninterrupted_run(trainer, tmp_path):
    init, iterate = trainer
    ts = init(jax.random.key(3))
    straight = []
    for _ in range(4):
        ts, m = iterate(ts)
        straight.append(jax.device_get(m))

    ts = init(jax.random.key(3))
    for _ in range(2):
        ts, _ = iterate(ts)
    save_tree(tmp_path / "ckpt.safetensors", ts, {"iteration": 2})
    template = init(jax.random.key(99))  # any state of the same config
    ts, header = load_tree(tmp_path / "ckpt.safetensors", template)
    assert header == {"iteration": 2} and int(ts.iteration) == 2
    for i in range(2, 4):
        ts, m = iterate(ts)
        for k, v in jax.device_get(m).items():
            np.testing.assert_array_equal(v, straight[i][k], err_msg=k)


def test_a_checkpoint_of_another_config_or_a_corrupt_file_is_refused(trainer, tmp_path):
    init, _ = trainer
    ts = init(jax.random.key(0))
    other_init, _, _ = make_train(WORLD, PPO.replace(hidden_sizes=(8,)))
    save_tree(tmp_path / "other.safetensors", jax.jit(other_init)(jax.random.key(0)), {})
    with pytest.raises(TreeFileError, match="another config"):
        load_tree(tmp_path / "other.safetensors", ts)
    bad = tmp_path / "bad.safetensors"
    bad.write_bytes(b"\x00" * 64)
    with pytest.raises(TreeFileError, match="corrupt"):
        load_tree(bad, ts)
    with pytest.raises(FileNotFoundError):
        load_tree(tmp_path / "missing.safetensors", ts)


def test_a_policy_loads_when_only_the_environment_part_of_the_state_changed(trainer, tmp_path):
    """A scene that adds a field to the environment state leaves old policies loadable."""
    init, _ = trainer
    ts = init(jax.random.key(0))
    saved = ts.replace(env_state=ts.env_state.replace(step=ts.env_state.step[:1]))
    save_tree(tmp_path / "old.safetensors", saved, {"iteration": 0})
    with pytest.raises(TreeFileError, match="env_state"):
        load_tree(tmp_path / "old.safetensors", ts)
    got, header = load_fields(tmp_path / "old.safetensors", ts, ("params", "norm"))
    assert header == {"iteration": 0}
    for name in ("params", "norm"):
        jax.tree_util.tree_map(np.testing.assert_array_equal, got[name], getattr(ts, name))
    # A policy part that changed is still refused, naming the leaf.
    other_init, _, _ = make_train(WORLD, PPO.replace(hidden_sizes=(8,)))
    save_tree(tmp_path / "other.safetensors", jax.jit(other_init)(jax.random.key(0)), {})
    with pytest.raises(TreeFileError, match=r"\.params.*another config"):
        load_fields(tmp_path / "other.safetensors", ts, ("params",))
