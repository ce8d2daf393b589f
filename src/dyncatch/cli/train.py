"""``dyncatch train``: the flags are ``TrainRunCfg``; the runner lives in ``dyncatch.rl.runner``."""

from __future__ import annotations

from dyncatch.rl.runner import TrainRunCfg


def run_train(cfg: TrainRunCfg) -> dict:
    from dyncatch.cli.progress import rich_progress
    from dyncatch.rl.runner import TrainRunner

    runner = TrainRunner(cfg)
    with rich_progress() as progress:
        return runner.learn(progress)
