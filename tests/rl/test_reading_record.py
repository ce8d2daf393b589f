"""GT-Pred's reading keys a training run: chosen on the command line, recorded in the
checkpoint, read back at evaluation, and a gt_rl run that does not record it is refused."""

from __future__ import annotations

import jax.numpy as jnp
import pytest

from dyncatch.cli.main import parse
from dyncatch.rl.config import PPOCfg
from dyncatch.rl.methods import GROUND_TRUTH_READING
from dyncatch.rl.policy import load_run
from dyncatch.rl.runner import TRAIN_FORMAT, TrainRunCfg, TrainRunner, header_of
from dyncatch.utils.tree_io import TreeFileError, save_tree

PPO = PPOCfg(num_envs=8, num_steps=8, num_minibatches=2, update_epochs=1, hidden_sizes=(8,))


def test_the_reading_is_a_train_flag_with_when_predicted_the_default():
    assert parse(["train"])[1].ground_truth == GROUND_TRUTH_READING == "when_predicted"
    cfg = parse(["train", "--method", "gt_rl", "--ground-truth", "always"])[1]
    assert cfg.ground_truth == "always"
    assert header_of(cfg)["ground_truth"] == "always"
    with pytest.raises(SystemExit):
        parse(["train", "--ground-truth", "sometimes"])


def test_the_runner_trains_with_the_recorded_reading(tmp_path):
    cfg = TrainRunCfg(method="gt_rl", out=tmp_path, ground_truth="always", ppo=PPO)
    runner = TrainRunner(cfg)
    assert runner.obs_fn.ground_truth == "always" and runner.header["ground_truth"] == "always"


def test_a_gt_rl_run_without_its_reading_is_refused(tmp_path):
    header = header_of(TrainRunCfg(method="gt_rl", ppo=PPO))
    del header["ground_truth"]
    assert header["format"] == TRAIN_FORMAT
    save_tree(tmp_path / "checkpoint.safetensors", {"x": jnp.zeros(1)}, header)
    for as_method in ("gt_rl", "sp_fp"):
        with pytest.raises(TreeFileError, match="ground-truth reading.*retrain"):
            load_run(tmp_path, as_method, predictor=tmp_path / "unused")
