"""What a reproduction runs: a profile (``full`` or ``quick``) with command-line overrides.

A ``Plan`` is plain data; the stages read it and the report records it, so a results folder
says exactly what produced it. Re-running with another plan into the same folder is refused
(stages are cached by name, not by content).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from dyncatch.reproduce.paper import PAPER_SPEEDS_MPS
from dyncatch.rl.config import PPOCfg

LEARNED = ("rl", "p_rl", "gt_rl", "sp_rl")
"""Methods that are trained; ``sp_fp`` is evaluated from the ``gt_rl`` runs."""
EVALUATED = ("rl", "p_rl", "sp_fp", "sp_rl", "gt_rl")
BASELINES = ("pursuit", "intercept")
ALL_BEHAVIORS = ("circle", "bounce", "reactive", "random_reactive")


@dataclass(frozen=True)
class Plan:
    profile: str
    seeds: int
    """Training seeds per (method, behaviour)."""
    behaviors: tuple[str, ...]
    """Behaviours trained on (Table I rows, Fig. 5 panels)."""
    train_steps: int
    """Environment steps per training run."""
    speeds_mps: tuple[float, ...]
    """Table I columns."""
    episodes: int
    """Evaluation episodes per (policy, behaviour, speed) cell."""
    fig6_speed_mps: float
    """The high speed of Fig. 6."""
    predictor_steps: int
    """Interaction steps the frozen predictors are trained on."""
    predictor_updates: int
    """Gradient steps of each predictor."""
    table_ii_budgets: tuple[int, ...]
    """Table II columns (interaction steps)."""
    table_ii_eval_steps: int
    """Held-out interaction steps per Table II behaviour."""
    videos: bool
    """One GIF per behaviour of the sp_rl policy."""
    ppo: PPOCfg = PPOCfg()

    @property
    def training_runs(self) -> int:
        return len(LEARNED) * len(self.behaviors) * self.seeds

    def to_json(self) -> dict:
        d = dataclasses.asdict(self)
        d["ppo"] = dataclasses.asdict(self.ppo)
        return d


PROFILES: dict[str, Plan] = {
    "full": Plan(
        profile="full",
        seeds=3,
        behaviors=("reactive", "random_reactive"),
        train_steps=4_000_000,
        speeds_mps=PAPER_SPEEDS_MPS,
        episodes=1000,
        fig6_speed_mps=1.8,
        predictor_steps=2_000_000,
        predictor_updates=6000,
        table_ii_budgets=(200_000, 500_000, 1_000_000, 2_000_000),
        table_ii_eval_steps=500_000,
        videos=True,
    ),
    "quick": Plan(
        profile="quick",
        seeds=1,
        behaviors=("reactive", "random_reactive"),
        train_steps=800_000,
        speeds_mps=PAPER_SPEEDS_MPS,
        episodes=200,
        fig6_speed_mps=1.8,
        predictor_steps=500_000,
        predictor_updates=1500,
        table_ii_budgets=(100_000, 500_000),
        table_ii_eval_steps=100_000,
        videos=True,
        # 128-128-64 networks train about 2.4x faster than 256-256-128 on 2 cores, so 0.8 M
        # steps (past the ~0.5 M knee of the full run's learning curves) fit in the 10
        # minutes: measured 8.5 min, every learned method at 0.73-1.00 success on reactive
        # at 1.8 m/s (one seed, docs/results.md).
        ppo=PPOCfg(hidden_sizes=(128, 128, 64)),
    ),
}

# Measured on the 2-core CI machine (docs/performance.md, docs/results.md); only used to
# print an estimate before starting.
EST_SAMPLES_PER_S = 17_000.0
EST_COMPILE_S_PER_RUN = 20.0
EST_EVAL_S_PER_1000_EPISODES = 6.0
EST_PREDICTOR_S_PER_M_STEPS = 8.0


def estimate_s(plan: Plan) -> float:
    """A rough wall-time estimate (seconds) for the whole plan on 2 cores."""
    train = plan.training_runs * (plan.train_steps / EST_SAMPLES_PER_S + EST_COMPILE_S_PER_RUN)
    policies = (len(EVALUATED) * plan.seeds + len(BASELINES)) * len(plan.behaviors)
    cells = policies * len(plan.speeds_mps) + policies * len(ALL_BEHAVIORS) // 2
    evaluate = cells * (plan.episodes / 1000 * EST_EVAL_S_PER_1000_EPISODES + 1.0)
    pred_steps = 2 * len(plan.behaviors) * plan.predictor_steps + 4 * max(plan.table_ii_budgets)
    predictors = pred_steps / 1e6 * EST_PREDICTOR_S_PER_M_STEPS + 30 * len(plan.behaviors)
    videos = 30.0 * len(ALL_BEHAVIORS) if plan.videos else 0.0
    return train + evaluate + predictors + videos


def validate_plan(plan: Plan) -> Plan:
    """Raise ValueError naming the flag that cannot work."""
    from dyncatch.rl.config import validate_ppo
    from dyncatch.sim.behaviors import BEHAVIORS

    if plan.seeds < 1:
        raise ValueError(f"--seeds must be >= 1, got {plan.seeds}")
    if plan.train_steps < plan.ppo.batch_size:
        raise ValueError(
            f"--train-steps {plan.train_steps} is below one PPO batch ({plan.ppo.batch_size}); "
            "raise it or shrink --ppo.num-envs / --ppo.num-steps"
        )
    if plan.episodes < 1:
        raise ValueError(f"--episodes must be >= 1, got {plan.episodes}")
    if not plan.speeds_mps or any(v < 0 for v in plan.speeds_mps + (plan.fig6_speed_mps,)):
        raise ValueError(f"--speeds-mps must be non-negative and non-empty, got {plan.speeds_mps}")
    bad = [b for b in plan.behaviors if b not in BEHAVIORS]
    if bad or not plan.behaviors:
        raise ValueError(f"--behaviors {bad or '()'}: choose from {', '.join(BEHAVIORS)}")
    if plan.predictor_steps < 1 or plan.predictor_updates < 1 or not plan.table_ii_budgets:
        raise ValueError(
            "--predictor-steps, --predictor-updates and --table-ii-budgets must be set"
        )
    validate_ppo(plan.ppo)
    return plan
