"""The registry of sub-commands.

A command is a frozen dataclass (its fields are the flags) and the function that runs it;
a group (``dyncatch bench env``) is a dict of commands under one name. A command whose
defaults depend on a flag (``reproduce --quick`` picks a profile, ``eval RUN`` starts from
the run's world) has a ``refine``: the command line is parsed once, ``refine`` turns that
into the defaults, and the command line is parsed again on top of them, so every flag given
overrides, even one equal to the library default.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from dyncatch.cli.bench import (
    EnvBenchCmd,
    GaitBenchCmd,
    MachineBenchCmd,
    PPOBenchCmd,
    run_env_bench,
    run_gait_bench,
    run_machine_bench,
    run_ppo_bench,
)
from dyncatch.cli.demo import DemoCmd, run_demo
from dyncatch.cli.evader import run_evader_selfplay, run_evader_train
from dyncatch.cli.eval import EvalCmd, run_eval, run_world_default
from dyncatch.cli.export import ExportCmd, run_export
from dyncatch.cli.plot import PlotCmd, run_plot
from dyncatch.cli.predictor import (
    PredictorScoreCmd,
    PredictorTableCmd,
    run_predictor_score,
    run_predictor_table,
    run_predictor_train,
)
from dyncatch.cli.render import RenderCmd, run_render
from dyncatch.cli.reproduce import run_reproduce
from dyncatch.cli.train import run_train
from dyncatch.predictor.pipeline import PredictorTrainCfg
from dyncatch.reproduce.plan import Plan, profile_default
from dyncatch.rl.evader_train import EvaderTrainCfg
from dyncatch.rl.runner import TrainRunCfg
from dyncatch.rl.selfplay_cfg import SelfPlayCfg


@dataclass(frozen=True)
class Command:
    spec: type
    run: Callable[[Any], Any]
    refine: Callable[[Any], Any] | None = None
    """First parse -> the defaults of the second (see the module docstring)."""


@dataclass(frozen=True)
class Group:
    doc: str
    commands: dict[str, Command]


COMMANDS: dict[str, Command | Group] = {
    "demo": Command(DemoCmd, run_demo),
    "render": Command(RenderCmd, run_render),
    "train": Command(TrainRunCfg, run_train),
    "eval": Command(EvalCmd, run_eval, run_world_default),
    "export": Command(ExportCmd, run_export),
    "plot": Command(PlotCmd, run_plot),
    "reproduce": Command(Plan, run_reproduce, profile_default),
    "bench": Group(
        "Throughput benchmarks; the full-body gait's step responses; this machine's speed.",
        {
            "env": Command(EnvBenchCmd, run_env_bench),
            "ppo": Command(PPOBenchCmd, run_ppo_bench),
            "gait": Command(GaitBenchCmd, run_gait_bench),
            "machine": Command(MachineBenchCmd, run_machine_bench),
        },
    ),
    "evader": Group(
        "Targets that learn to escape (issue 34): a PPO evader against frozen pursuers, and "
        "self-play rounds of evaders and pursuers.",
        {
            "train": Command(EvaderTrainCfg, run_evader_train),
            "selfplay": Command(SelfPlayCfg, run_evader_selfplay),
        },
    ),
    "predictor": Group(
        "The target-behaviour predictor (Section III-B, Table II).",
        {
            "train": Command(PredictorTrainCfg, run_predictor_train),
            "table": Command(PredictorTableCmd, run_predictor_table),
            "score": Command(PredictorScoreCmd, run_predictor_score),
        },
    ),
}
