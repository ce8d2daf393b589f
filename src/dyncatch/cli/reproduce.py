"""``dyncatch reproduce [--quick]``: every table and figure of the paper, cached and resumable."""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

from dyncatch.cli.train import TRAIN_WORLD
from dyncatch.rl.config import PPOCfg
from dyncatch.sim.config import WorldCfg


@dataclasses.dataclass(frozen=True)
class ReproduceCmd:
    """Train rl, p_rl, gt_rl, sp_rl (sp_fp reuses gt_rl) on reactive targets over seeds, then
    write Table I, Table II, Fig. 5, Fig. 6, videos, report.md and results.json.

    Re-running the same command skips finished stages and resumes an interrupted one.
    """

    quick: bool = False
    """The quick profile (one seed, short training, fewer episodes; about 10 min on 2 cores)
    instead of the full one (3 seeds, 4 M steps per run, 1000 episodes per cell)."""
    out: Path | None = None
    """Results folder (default results/full or results/quick)."""
    seeds: int | None = None
    """Training seeds per method and behaviour (profile default: full 3, quick 1)."""
    train_steps: int | None = None
    """Environment steps per training run (profile default)."""
    episodes: int | None = None
    """Evaluation episodes per cell (profile default)."""
    behaviors: tuple[str, ...] | None = None
    """Behaviours to train on (default: reactive random_reactive)."""
    speeds_mps: tuple[float, ...] | None = None
    """Table I speeds (default 0.8 1.0 1.2 1.4 1.6 1.8)."""
    predictor_steps: int | None = None
    """Interaction steps of each frozen predictor (profile default)."""
    predictor_updates: int | None = None
    """Gradient steps of each predictor (profile default)."""
    table_ii_budgets: tuple[int, ...] | None = None
    """Table II budgets (profile default)."""
    table_ii_eval_steps: int | None = None
    """Held-out interaction steps per Table II behaviour (profile default)."""
    videos: bool = True
    """Write one GIF per behaviour of the sp_rl policy."""
    ppo: PPOCfg = PPOCfg()
    """PPO hyper-parameters and batch geometry of every run. A field left at its default
    takes the profile's value (quick: 128-128-64 networks)."""
    world: WorldCfg = TRAIN_WORLD
    """The simulated world."""


def plan_of(cmd: ReproduceCmd):
    from dyncatch.reproduce.plan import PROFILES, validate_plan

    base = PROFILES["quick" if cmd.quick else "full"]
    overrides = {
        f.name: getattr(cmd, f.name)
        for f in dataclasses.fields(base)
        if hasattr(cmd, f.name)
        and getattr(cmd, f.name) is not None
        and f.name not in ("profile", "ppo")
    }
    default = PPOCfg()
    ppo_changed = {
        f.name: getattr(cmd.ppo, f.name)
        for f in dataclasses.fields(PPOCfg)
        if getattr(cmd.ppo, f.name) != getattr(default, f.name)
    }
    ppo = dataclasses.replace(base.ppo, **ppo_changed)
    return validate_plan(dataclasses.replace(base, ppo=ppo, **overrides))


def run_reproduce(cmd: ReproduceCmd) -> dict:
    from rich.console import Console

    from dyncatch.reproduce.pipeline import run
    from dyncatch.sim.validate import validate_world

    plan = plan_of(cmd)
    validate_world(cmd.world)
    out = cmd.out or Path("results") / plan.profile
    console = Console()
    command = "dyncatch " + " ".join(sys.argv[1:]) if sys.argv[1:] else "dyncatch reproduce"
    return run(plan, out, cmd.world, command, lambda msg: console.print(f"[bold]{msg}"))
