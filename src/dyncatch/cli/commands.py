"""The registry of sub-commands.

A command is a frozen dataclass (its fields are the flags) and the function that runs it;
a group (``dyncatch bench env``) is a dict of commands under one name.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

from dyncatch.cli.bench import EnvBenchCmd, PPOBenchCmd, run_env_bench, run_ppo_bench
from dyncatch.cli.demo import DemoCmd, run_demo
from dyncatch.cli.eval import EvalCmd, run_eval
from dyncatch.cli.predictor import (
    PredictorTableCmd,
    PredictorTrainCmd,
    run_predictor_table,
    run_predictor_train,
)
from dyncatch.cli.render import RenderCmd, run_render
from dyncatch.cli.reproduce import ReproduceCmd, run_reproduce
from dyncatch.cli.train import TrainCmd, run_train


@dataclass(frozen=True)
class Command:
    spec: type
    run: Callable[[Any], Any]


@dataclass(frozen=True)
class Group:
    doc: str
    commands: dict[str, Command]


COMMANDS: dict[str, Command | Group] = {
    "demo": Command(DemoCmd, run_demo),
    "render": Command(RenderCmd, run_render),
    "train": Command(TrainCmd, run_train),
    "eval": Command(EvalCmd, run_eval),
    "reproduce": Command(ReproduceCmd, run_reproduce),
    "bench": Group(
        "Throughput benchmarks.",
        {"env": Command(EnvBenchCmd, run_env_bench), "ppo": Command(PPOBenchCmd, run_ppo_bench)},
    ),
    "predictor": Group(
        "The target-behaviour predictor (Section III-B, Table II).",
        {
            "train": Command(PredictorTrainCmd, run_predictor_train),
            "table": Command(PredictorTableCmd, run_predictor_table),
        },
    ),
}
