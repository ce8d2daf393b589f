"""Env-steps/s of ``dyncatch eval --backend mujoco`` (``fullbody.catch``), for docs/performance.md.

``python benchmarks/fullbody_throughput.py [--episodes N] [--duration-s T] [--speed-mps V]
[--workers W] [--fullbody.FIELD VALUE ...]``: the pursuit baseline against the reactive
target, N episodes of at most T seconds played at once over W worker processes
(``FullBodies``; default one per core), run twice (the first run compiles the JAX side), with
the full body's settings as ``dyncatch eval`` takes them. Prints the second run's 50 Hz env
steps, wall time, CPU time (this process and its workers) and the steps per second of each.
"""

from __future__ import annotations

import dataclasses
import json

import jax
import tyro

from dyncatch.evaluation.backends import run_fullbody_episodes
from dyncatch.fullbody.config import FullBodyCfg
from dyncatch.policies.registry import BASELINES
from dyncatch.sim.config import WorldCfg
from dyncatch.utils.jax_setup import setup_jax


@dataclasses.dataclass(frozen=True)
class ThroughputCmd:
    episodes: int = 8
    """Episodes played at once."""
    duration_s: float = 4.0
    """Episode limit (short: the cost per step is what is measured)."""
    speed_mps: float = 1.2
    """Target speed (reactive)."""
    workers: int | None = None
    """Worker processes the bodies are split over (None: one per core; 1: this process)."""
    fullbody: FullBodyCfg = FullBodyCfg()
    """The full body's settings, as ``dyncatch eval --fullbody.*`` takes them (e.g.
    ``--fullbody.gait.mpc.solver proxqp``)."""


def main(cmd: ThroughputCmd) -> dict:
    world = WorldCfg().with_speed(cmd.speed_mps)
    world = world.replace(episode=world.episode.replace(duration_s=cmd.duration_s))
    policy = BASELINES["pursuit"](world)
    for seed in (0, 1):
        out = run_fullbody_episodes(
            policy, jax.random.key(seed), world, cmd.episodes, cmd.fullbody, workers=cmd.workers
        )
    result = {
        "episodes": cmd.episodes,
        "workers": cmd.workers,
        "solver": cmd.fullbody.gait.mpc.solver,
        "env_steps": out["env_steps"],
        "wall_s": round(out["wall_s"], 2),
        "cpu_s": round(out["cpu_s"], 2),
        "env_steps_per_wall_s": round(out["env_steps"] / out["wall_s"], 1),
        "env_steps_per_cpu_s": round(out["env_steps"] / out["cpu_s"], 1),
    }
    print(json.dumps(result))
    return result


if __name__ == "__main__":
    setup_jax()
    main(tyro.cli(ThroughputCmd))
