"""Catch rate of the scripted baselines per behaviour and speed (the tables in docs/model.md).

``python benchmarks/pursuit_calibration.py [--episodes N] [--scene NAME] [--baselines ...]``;
1000 episodes per cell, every baseline of ``dyncatch.policies.registry.BASELINES`` and the
default scene unless told otherwise.
"""

from __future__ import annotations

import dataclasses

import jax
import tyro

from dyncatch.evaluation.episodes import run_episodes
from dyncatch.evaluation.stats import summarize
from dyncatch.policies.registry import BASELINES
from dyncatch.sim.behaviors import BEHAVIORS
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.validate import validate_world
from dyncatch.utils.jax_setup import setup_jax


@dataclasses.dataclass(frozen=True)
class CalibrationCmd:
    episodes: int = 1000
    """Episodes per cell."""
    speeds_mps: tuple[float, ...] = (0.8, 1.2, 1.8)
    """Target speeds, one column each."""
    baselines: tuple[str, ...] = tuple(BASELINES)
    """Baselines, one table each."""
    world: WorldCfg = WorldCfg()
    """The simulated world (``--scene NAME`` picks its scene)."""


def main(cmd: CalibrationCmd) -> None:
    world = validate_world(cmd.world)
    for name in cmd.baselines:
        policy = BASELINES[name](world)
        print(f"\n{name}, scene {world.scene.name}, {cmd.episodes} episodes per cell")
        print("| behaviour | " + " | ".join(f"{v} m/s" for v in cmd.speeds_mps) + " |")
        print("|---|" + "---:|" * len(cmd.speeds_mps))
        for behavior in BEHAVIORS:
            cells = []
            for speed in cmd.speeds_mps:
                cfg = world.with_behavior(behavior).with_speed(speed)
                s = summarize(run_episodes(policy, jax.random.key(2024), cfg, cmd.episodes))
                lo, hi = s["success_ci95"]
                cells.append(
                    f"{s['success_rate']:.3f} [{lo:.2f}, {hi:.2f}] / {s['catch_time_s']:.1f} s"
                )
            print(f"| {behavior} | " + " | ".join(cells) + " |", flush=True)


if __name__ == "__main__":
    setup_jax()
    main(tyro.cli(CalibrationCmd))
