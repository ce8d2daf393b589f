"""``dyncatch train``: the flags are ``TrainRunCfg``; the runners live in ``dyncatch.rl``
(``--seeds S`` > 1 trains S seeds as one vmap-ped computation, ``dyncatch.rl.seeds``)."""

from __future__ import annotations

from dyncatch.cli.progress import rich_progress
from dyncatch.rl.runner import TrainRunCfg
from dyncatch.rl.seeds import make_runner


def run_train(cfg: TrainRunCfg) -> dict | list[dict]:

    runner = make_runner(cfg)
    with rich_progress() as progress:
        return runner.learn(progress)
