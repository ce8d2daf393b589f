"""``dyncatch demo``: the scripted pursuer against every behaviour, a table and one GIF each."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

from dyncatch.evaluation.episodes import run_episodes
from dyncatch.evaluation.stats import summarize
from dyncatch.policies.pursuit import pursuit_policy
from dyncatch.sim.behaviors import scripted_behaviors
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.validate import validate_speeds, validate_world
from dyncatch.utils.files import check_out_dir
from dyncatch.viz.render import render_frames, write_video
from dyncatch.viz.trajectory import record_episode


@dataclasses.dataclass(frozen=True)
class DemoCmd:
    """Scripted pursuer vs every target behaviour at slow and fast speeds; writes GIFs."""

    out: Path = Path("results/demo")
    """Folder for the table (demo.md, demo.json) and one GIF per behaviour."""
    episodes: int = 300
    """Episodes per (behaviour, speed) cell."""
    speeds_mps: tuple[float, ...] = (0.8, 1.8)
    """Target speeds to evaluate."""
    gif_speed_mps: float = 1.2
    """Target speed in the GIFs."""
    seed: int = 0
    """Seed of the evaluation episodes."""
    world: WorldCfg = WorldCfg()
    """The simulated world."""


def run_demo(cmd: DemoCmd) -> list[dict]:
    import jax
    from rich.console import Console
    from rich.table import Table

    for behavior in scripted_behaviors():
        validate_world(cmd.world.with_behavior(behavior))
    validate_speeds(cmd.speeds_mps, "--speeds-mps")
    if cmd.episodes < 1:
        raise ValueError("--episodes must be >= 1")
    check_out_dir(cmd.out).mkdir(parents=True, exist_ok=True)
    console = Console()
    rows = []
    policy = pursuit_policy(cmd.world)
    for behavior in scripted_behaviors():
        for speed in cmd.speeds_mps:
            cfg = cmd.world.with_behavior(behavior).with_speed(speed)
            outcome = run_episodes(policy, jax.random.key(cmd.seed), cfg, cmd.episodes)
            rows.append({"behavior": behavior, "speed_mps": speed, **summarize(outcome)})
        cfg = cmd.world.with_behavior(behavior).with_speed(cmd.gif_speed_mps)
        traj = record_episode(policy, jax.random.key(cmd.seed), cfg)
        write_video(render_frames(traj, cfg), cmd.out / f"pursuit_{behavior}.gif", fps=25)

    table = Table(title=f"Scripted pursuer, {cmd.episodes} episodes per cell")
    for col in ("behavior", "speed (m/s)", "catch rate [95% CI]", "mean catch time (s)"):
        table.add_column(col)
    for r in rows:
        lo, hi = r["success_ci95"]
        table.add_row(
            r["behavior"],
            f"{r['speed_mps']:.1f}",
            f"{r['success_rate']:.2f} [{lo:.2f}, {hi:.2f}]",
            f"{r['catch_time_s']:.2f}",
        )
    console.print(table)
    (cmd.out / "demo.json").write_text(json.dumps({"rows": rows}, indent=2))
    console.print(f"wrote {cmd.out}/demo.json and one GIF per behaviour in {cmd.out}/")
    return rows
