"""``dyncatch evader train`` and ``dyncatch evader selfplay``: the flags are ``EvaderTrainCfg``
and ``SelfPlayCfg``; the runners are ``dyncatch.rl.evader_train.train_evader`` and
``dyncatch.rl.selfplay.SelfPlayRunner``."""

from __future__ import annotations

from dyncatch.cli.progress import rich_progress
from dyncatch.rl.evader_train import EvaderTrainCfg, train_evader
from dyncatch.rl.selfplay import SelfPlayRunner
from dyncatch.rl.selfplay_cfg import SelfPlayCfg
from dyncatch.sim.behaviors.evader_net import EVADER_CHECKPOINT


def run_evader_train(cfg: EvaderTrainCfg) -> dict[str, float]:
    with rich_progress() as progress:
        metrics = train_evader(cfg, progress)
    print(f"wrote {cfg.out / EVADER_CHECKPOINT}; last iteration: {metrics}")
    return metrics


def run_evader_selfplay(cfg: SelfPlayCfg) -> dict:
    with rich_progress() as progress:
        summary = SelfPlayRunner(cfg).learn(progress)
    print((cfg.out / "summary.md").read_text(), end="")
    return summary
