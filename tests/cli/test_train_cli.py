"""``dyncatch train``: logs, checkpoints, refusal to overwrite, and resume."""

import csv

import pytest

from dyncatch.cli.main import main

TINY = [
    "--behavior",
    "circle",
    "--ppo.num-envs",
    "8",
    "--ppo.num-steps",
    "8",
    "--ppo.num-minibatches",
    "2",
    "--ppo.update-epochs",
    "1",
    "--ppo.hidden-sizes",
    "16",
    "--checkpoint-every",
    "1",
]


def _iterations(out):
    with (out / "metrics.csv").open() as f:
        return [int(r["iteration"]) for r in csv.DictReader(f)]


@pytest.mark.extended  # exact resume: tests/rl/test_resume.py
def test_train_then_resume(tmp_path, capsys):
    out = tmp_path / "run"
    args = ["train", "--method", "rl", "--out", str(out), *TINY]
    assert main([*args, "--total-steps", "128"]) == 0  # 2 iterations of 64 samples
    assert (out / "checkpoint.safetensors").exists() and (out / "tb").is_dir()
    assert _iterations(out) == [1, 2]
    # Running again into the same folder would lose the run: refused with the fix.
    assert main([*args, "--total-steps", "256"]) == 2
    assert "--resume" in capsys.readouterr().err
    # Resuming continues the counter; other flags than the run's are refused.
    assert main([*args, "--total-steps", "256", "--resume"]) == 0
    assert _iterations(out) == [1, 2, 3, 4]
    assert main([*args, "--total-steps", "256", "--resume", "--seed", "5"]) == 2
    assert "seed" in capsys.readouterr().err


def test_predictor_methods_need_a_checkpoint(tmp_path, capsys):
    assert main(["train", "--method", "sp_rl", "--out", str(tmp_path / "r"), *TINY]) == 2
    assert "--predictor" in capsys.readouterr().err
    assert main(["train", "--method", "sp_fp", "--out", str(tmp_path / "r"), *TINY]) == 2
    assert "gt_rl" in capsys.readouterr().err


def test_loggers_are_chosen_by_flag_and_wandb_gets_the_run_config(tmp_path, monkeypatch, capsys):
    from dyncatch.utils.tree_io import read_header
    from tests.rl.test_logging import wandb_config

    monkeypatch.delenv("WANDB_MODE", raising=False)
    out = tmp_path / "run"
    argv = ["train", "--method", "rl", "--out", str(out), "--total-steps", "64", *TINY]
    assert main([*argv, "--logger", "csv", "wandb"]) == 0
    assert _iterations(out) == [1] and not (out / "tb").exists()
    (run_dir,) = (out / "wandb").glob("offline-run-*")
    config = wandb_config(run_dir)
    assert config == read_header(out / "checkpoint.safetensors")
    assert config["method"] == "rl" and config["world"]["target"]["behavior"] == "circle"
    # Unknown names are refused by the parser with the choices, repeats by the runner.
    with pytest.raises(SystemExit):
        main([*argv, "--logger", "mlflow"])
    err = capsys.readouterr().err
    assert all(name in err for name in ("mlflow", "csv", "tensorboard", "wandb")), err
    assert main([*argv, "--out", str(tmp_path / "r2"), "--logger", "csv", "csv"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "--logger csv csv" in err
