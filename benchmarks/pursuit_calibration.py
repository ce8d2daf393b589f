"""Catch rate of the scripted pursuer per behaviour and speed (the table in docs/model.md).

``python benchmarks/pursuit_calibration.py [episodes]``; 1000 episodes per cell by default.
"""

import sys

import jax

from dyncatch.evaluation.episodes import run_episodes
from dyncatch.evaluation.stats import summarize
from dyncatch.policies.pursuit import pursuit_policy
from dyncatch.sim.behaviors import BEHAVIORS
from dyncatch.sim.config import WorldCfg
from dyncatch.utils.jax_setup import setup_jax

SPEEDS_MPS = (0.8, 1.2, 1.8)


def main(episodes: int) -> None:
    world = WorldCfg()
    policy = pursuit_policy(world)
    print("| behaviour | " + " | ".join(f"{v} m/s" for v in SPEEDS_MPS) + " |")
    print("|---|" + "---:|" * len(SPEEDS_MPS))
    for behavior in BEHAVIORS:
        cells = []
        for speed in SPEEDS_MPS:
            cfg = world.with_behavior(behavior).with_speed(speed)
            s = summarize(run_episodes(policy, jax.random.key(2024), cfg, episodes))
            lo, hi = s["success_ci95"]
            cells.append(
                f"{s['success_rate']:.3f} [{lo:.2f}, {hi:.2f}] / {s['catch_time_s']:.1f} s"
            )
        print(f"| {behavior} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    setup_jax()
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 1000)
