"""``dyncatch eval METHOD``: success rate and catch time over target speeds (Table I rows)."""

from __future__ import annotations

import dataclasses
import json

import tyro

from dyncatch.sim.config import WorldCfg


@dataclasses.dataclass(frozen=True)
class EvalCmd:
    """Evaluate a method on evaluation seeds disjoint from training ones."""

    method: tyro.conf.Positional[str]
    """A non-learned baseline: pursuit or intercept."""
    behavior: str = "reactive"
    """Target behaviour."""
    speeds: tuple[float, ...] = (0.8, 1.0, 1.2, 1.4, 1.6, 1.8)
    """Target speeds (m/s), one row each."""
    episodes: int = 1000
    """Episodes per speed (each environment plays exactly one)."""
    seed: int = 0
    """Evaluation seed."""
    json: bool = False
    """Print one JSON object {"rows": [...]} instead of a table."""
    world: WorldCfg = WorldCfg()
    """The simulated world."""


def run_eval(cmd: EvalCmd) -> list[dict]:
    from dyncatch.evaluation.grid import evaluate_speeds
    from dyncatch.policies.registry import BASELINES
    from dyncatch.sim.validate import validate_world

    if cmd.method not in BASELINES:
        raise ValueError(f"unknown method {cmd.method!r}: baselines are {', '.join(BASELINES)}")
    if cmd.episodes < 1:
        raise ValueError(f"--episodes must be >= 1, got {cmd.episodes}")
    if any(v < 0 for v in cmd.speeds):
        raise ValueError(f"--speeds must be non-negative, got {cmd.speeds}")
    world = validate_world(cmd.world.with_behavior(cmd.behavior))
    policy = BASELINES[cmd.method](world)
    rows = evaluate_speeds(
        policy, world, cmd.behavior, cmd.speeds, cmd.episodes, cmd.seed, cmd.method
    )
    if cmd.json:
        print(json.dumps({"rows": rows}))
    else:
        print(f"{cmd.method} vs {cmd.behavior}, {cmd.episodes} episodes per speed")
        print("| speed (m/s) | success [95% CI] | catch time (s) |\n|---:|---|---:|")
        for r in rows:
            lo, hi = r["success_ci95"]
            print(
                f"| {r['speed_mps']:.1f} | {r['success_rate']:.3f} [{lo:.3f}, {hi:.3f}] | "
                f"{r['catch_time_s']:.2f} |"
            )
    return rows
