"""``dyncatch eval RUN_OR_METHOD``: success rate and catch time per target speed (Table I)."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import tyro

from dyncatch.sim.config import WorldCfg


@dataclasses.dataclass(frozen=True)
class EvalCmd:
    """Evaluate a trained run or a baseline on evaluation seeds disjoint from training ones."""

    method: tyro.conf.Positional[str]
    """A run folder written by dyncatch train, or a non-learned baseline: pursuit, intercept."""
    behavior: str = "reactive"
    """Target behaviour."""
    speeds: tuple[float, ...] = (0.8, 1.0, 1.2, 1.4, 1.6, 1.8)
    """Target speeds (m/s), one row each."""
    episodes: int = 1000
    """Episodes per speed (each environment plays exactly one)."""
    seed: int = 0
    """Evaluation seed."""
    as_method: str | None = None
    """Evaluate a run as a method that reuses its policy (sp_fp for a gt_rl run)."""
    predictor: Path | None = None
    """Predictor checkpoint, overriding the one the run was trained with (needed for sp_fp)."""
    json: bool = False
    """Print one JSON object {"rows": [...]} instead of a table."""
    world: WorldCfg = WorldCfg()
    """The simulated world of the baselines (a run is evaluated in the world it was trained in)."""


def resolve(target: str, world: WorldCfg, as_method=None, predictor=None):
    """(policy, method name, world) for a baseline name or a run folder."""
    from dyncatch.policies.registry import BASELINES
    from dyncatch.rl.methods import METHODS

    if target in BASELINES:
        if as_method is not None:
            raise ValueError("--as-method applies to trained runs, not to baselines")
        return BASELINES[target](world), target, world
    if target in METHODS:
        raise ValueError(
            f"{target!r} is a learned method: train it (dyncatch train --method "
            f"{METHODS[target].trained_as or target} --out runs/NAME) and pass the run folder"
        )
    if not Path(target).exists():
        raise ValueError(
            f"unknown method or run {target!r}: baselines are {', '.join(BASELINES)}; "
            "a learned method is evaluated from its run folder"
        )
    from dyncatch.rl.policy import load_run

    run = load_run(target, as_method, predictor)
    return run.policy, run.method, run.world


def run_eval(cmd: EvalCmd) -> list[dict]:
    from dyncatch.evaluation.grid import evaluate_speeds
    from dyncatch.sim.validate import validate_world

    if cmd.episodes < 1:
        raise ValueError(f"--episodes must be >= 1, got {cmd.episodes}")
    if any(v < 0 for v in cmd.speeds):
        raise ValueError(f"--speeds must be non-negative, got {cmd.speeds}")
    policy, method, world = resolve(cmd.method, cmd.world, cmd.as_method, cmd.predictor)
    world = validate_world(world.with_behavior(cmd.behavior))
    rows = evaluate_speeds(policy, world, cmd.behavior, cmd.speeds, cmd.episodes, cmd.seed, method)
    if cmd.json:
        print(json.dumps({"rows": rows}))
    else:
        print(f"{method} vs {cmd.behavior}, {cmd.episodes} episodes per speed")
        print("| speed (m/s) | success [95% CI] | catch time (s) |\n|---:|---|---:|")
        for r in rows:
            lo, hi = r["success_ci95"]
            print(
                f"| {r['speed_mps']:.1f} | {r['success_rate']:.3f} [{lo:.3f}, {hi:.3f}] | "
                f"{r['catch_time_s']:.2f} |"
            )
    return rows
