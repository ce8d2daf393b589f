"""Refuse a ``Plan`` that cannot work, naming the flag, before anything runs."""

from __future__ import annotations

from dyncatch.reproduce.endpoints import validate_endpoints
from dyncatch.reproduce.executors import validate_executor
from dyncatch.reproduce.fig9 import scene_world
from dyncatch.reproduce.plan import Plan
from dyncatch.rl.config import validate_ppo
from dyncatch.rl.methods import METHODS, check_selection
from dyncatch.sim.behaviors import BEHAVIORS
from dyncatch.sim.validate import validate_speeds, validate_world


def validate_plan(plan: Plan) -> Plan:
    """Raise ValueError naming the flag that cannot work; else return ``plan``."""
    if plan.quick and plan.power:
        raise ValueError("--quick and --power are two profiles: choose one")
    if plan.seeds < 1:
        raise ValueError(f"--seeds must be >= 1, got {plan.seeds}")
    if plan.first_seed < 0:
        raise ValueError(f"--first-seed must be >= 0, got {plan.first_seed}")
    validate_executor(plan)
    if plan.train_steps < plan.ppo.batch_size:
        raise ValueError(
            f"--train-steps {plan.train_steps} is below one PPO batch ({plan.ppo.batch_size}); "
            "raise it or shrink --ppo.num-envs / --ppo.num-steps"
        )
    if plan.episodes < 1:
        raise ValueError(f"--episodes must be >= 1, got {plan.episodes}")
    validate_speeds(plan.speeds_mps, "--speeds-mps")
    validate_speeds((plan.fig6_speed_mps,), "--fig6-speed-mps")
    bad = [b for b in plan.behaviors if b not in BEHAVIORS]
    if bad or not plan.behaviors:
        raise ValueError(f"--behaviors {bad or '()'}: choose from {', '.join(BEHAVIORS)}")
    if plan.predictor_steps < 1 or plan.predictor_updates < 1 or not plan.table_ii_budgets:
        raise ValueError(
            "--predictor-steps, --predictor-updates and --table-ii-budgets must be set"
        )
    validate_ppo(plan.ppo)
    if plan.methods is not None:
        if not plan.methods:
            raise ValueError("--methods needs at least one method (or leave it unset)")
        check_selection(plan.methods)
    validate_endpoints(plan.primary_endpoints, tuple(BEHAVIORS), tuple(METHODS))
    named = (
        ("table-i", plan.table_i_behaviors),
        ("fig6", plan.fig6_behaviors),
        ("table-ii", plan.table_ii_behaviors),
    )
    for name, value in named:
        if value is not None and not value:
            raise ValueError(f"--{name}-behaviors needs at least one behaviour (or leave it unset)")
    shown = (
        ("table-i", plan.table_i_rows),
        ("fig6", plan.fig6_columns),
        *((("fig9", plan.fig9_columns),) if plan.fig9 else ()),
    )
    for name, value in shown:
        bad = [b for b in value if b not in plan.behaviors]
        if bad:
            raise ValueError(
                f"--{name}-behaviors {', '.join(bad)}: not trained on (--behaviors); each "
                "policy is evaluated on its own behaviour (--transfer-behaviors tests others)"
            )
    if plan.transfer_behaviors and plan.transfer_from not in plan.behaviors:
        raise ValueError(
            f"--transfer-from {plan.transfer_from} is not trained on (--behaviors), "
            "or give --transfer-behaviors with no value"
        )
    rows = (
        *plan.behaviors,
        *plan.table_i_rows,
        *plan.fig6_columns,
        *plan.table_ii_rows,
        *plan.transfer_behaviors,
    )
    bad = [b for b in rows if b not in BEHAVIORS]
    if bad:
        raise ValueError(f"behaviours {bad}: choose from {', '.join(BEHAVIORS)}")
    for b in dict.fromkeys(rows):
        validate_world(plan.world.with_behavior(b))
    if plan.fig9:
        _validate_fig9(plan)
    return plan


def _validate_fig9(plan: Plan) -> None:
    if not plan.fig9_scenes or not plan.fig9_columns:
        raise ValueError("--fig9-scenes and --fig9-behaviors need one each (or --no-fig9)")
    if plan.fig9_episodes < 1:
        raise ValueError(f"--fig9-episodes must be >= 1, got {plan.fig9_episodes}")
    if plan.fig9_speed_mps is not None:
        validate_speeds((plan.fig9_speed_mps,), "--fig9-speed-mps")
    if plan.fig9_duration_s is not None and plan.fig9_duration_s <= 0:
        raise ValueError(f"--fig9-duration-s must be positive, got {plan.fig9_duration_s}")
    for scene in plan.fig9_scenes:
        for b in plan.fig9_columns:
            w = scene_world(plan.world, scene, b, plan.fig9_duration_s, plan.fig9_speed_mps)
            validate_world(w)
