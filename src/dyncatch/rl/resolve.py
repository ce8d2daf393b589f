"""A policy by name: a baseline of the registry, or a run folder written by training (rl, not
evaluation: it loads runs, and evaluation sits below rl)."""

from __future__ import annotations

from pathlib import Path

from dyncatch.policies.registry import BASELINES
from dyncatch.rl.methods import METHODS
from dyncatch.rl.policy import load_run
from dyncatch.sim.config import WorldCfg


def resolve_policy(target: str, world: WorldCfg, as_method=None, predictor=None):
    """``(policy, method name, training world or None)`` for a baseline name or a run folder.

    A baseline is built for ``world``; a run is loaded with its own training world (see
    ``dyncatch.rl.policy.load_run``; ``as_method`` and ``predictor`` are passed to it).
    """

    if target in BASELINES:
        if as_method is not None:
            raise ValueError("--as-method applies to trained runs, not to baselines")
        return BASELINES[target](world), target, None
    if target in METHODS:
        raise ValueError(
            f"{target!r} is a learned method: train it (dyncatch train --method "
            f"{METHODS[target].policy_source} --out runs/NAME) and pass the run folder"
        )
    if not Path(target).exists():
        raise ValueError(
            f"unknown method or run {target!r}: baselines are {', '.join(BASELINES)}; "
            "a learned method is evaluated from its run folder"
        )

    run = load_run(target, as_method, predictor)
    return run.policy, run.method, run.world
