"""``dyncatch evader train``: the flags are ``EvaderTrainCfg``; the runner is
``dyncatch.rl.evader_train.train_evader``."""

from __future__ import annotations

from dyncatch.cli.progress import rich_progress
from dyncatch.rl.evader_train import EvaderTrainCfg, train_evader
from dyncatch.sim.behaviors.evader_net import EVADER_CHECKPOINT


def run_evader_train(cfg: EvaderTrainCfg) -> dict[str, float]:
    with rich_progress() as progress:
        metrics = train_evader(cfg, progress)
    print(f"wrote {cfg.out / EVADER_CHECKPOINT}; last iteration: {metrics}")
    return metrics
