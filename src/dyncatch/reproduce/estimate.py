"""A rough wall-time estimate of each stage on 2 cores, printed before a reproduction starts.

Measured on the idle 2-core machine. The full run of 2026-12-02 (docs/results.md): a group
of 3 seeds x 4 M steps took 551-582 s with its compilation and periodic evaluations
(training is bound by PPO's update, not the simulator); Table I's 6 speeds x 1000 episodes
about 20 s per policy; a video 7 s. Its uncontended stages sum to about 132 min; these
constants give 139. A (method, behaviour)'s seeds compile once whether grouped or one by
one (a process reuses the compiled iteration: docs/scaling.md). An evaluation compiles once
per (method or baseline, scene, behaviour): seeds, speeds and the Fig. 9 blend flag are
arguments (``benchmarks/eval_compiles.py``); the formulas count those compilations, and the
constants are re-measured when the full reproduction is re-run.
"""

from __future__ import annotations

from dyncatch.bench.ppo_bench import ppo_flops_per_sample
from dyncatch.policies.registry import BASELINES
from dyncatch.predictor.table import all_kinds
from dyncatch.reproduce.fig9 import rows_of
from dyncatch.reproduce.layout import fig6_evaluated_columns
from dyncatch.reproduce.plan import Plan
from dyncatch.rl.methods import predictor_kinds
from dyncatch.sim.api import OBS_DIM

EST_S_PER_SAMPLE = 4.8e-6
"""Seconds per training sample outside the networks (simulator, GAE, normaliser): the
intercept of the two measured sizes below."""
EST_S_PER_PPO_FLOP = 5.9e-12
"""Seconds per PPO FLOP (``bench.ppo_bench.ppo_flops_per_sample``'s count). With the line
above it fits ``dyncatch bench ppo`` on the idle 2-core Xeon: 27,000 samples/s at
256-256-128 (5.47 M FLOPs per sample) and 76,322 at 128-128-64 (1.41 M)."""
EST_TRAIN_OVERHEAD = 1.2
"""A training run's time over its PPO iterations' (periodic evaluations, logs,
checkpoints): the full run's 551-582 s per 3-seed group of 4 M steps at 256-256-128, about
22,000 samples/s against the benchmark's 27,000."""
EST_COMPILE_S = 20.0  # one compilation: a training group's iteration, a Fig. 9 row's rollout
EST_EVAL_S_PER_1000_EPISODES = 3.0
EST_PREDICTOR_S_PER_M_STEPS = 8.0
EST_VIDEO_S = 10.0


def predictors_s(plan: Plan) -> float:
    steps = len(predictor_kinds(plan.method_names)) * len(plan.behaviors) * plan.predictor_steps
    return steps / 1e6 * EST_PREDICTOR_S_PER_M_STEPS + 30 * len(plan.behaviors)


def table_ii_s(plan: Plan) -> float:
    steps = len(all_kinds()) * len(plan.table_ii_rows) * max(plan.table_ii_budgets)
    return steps / 1e6 * EST_PREDICTOR_S_PER_M_STEPS


def samples_per_s(plan: Plan) -> float:
    """Training samples per second at the plan's network size (``rl``'s input)."""
    flops = ppo_flops_per_sample(OBS_DIM, plan.ppo)["total"]
    return 1.0 / ((EST_S_PER_SAMPLE + EST_S_PER_PPO_FLOP * flops) * EST_TRAIN_OVERHEAD)


def training_s(plan: Plan) -> float:
    groups = plan.training_runs // plan.seeds
    return plan.training_runs * plan.train_steps / samples_per_s(plan) + groups * EST_COMPILE_S


def _policies(plan: Plan) -> int:
    return len(plan.method_names) * plan.seeds + len(BASELINES)


def _programs(plan: Plan) -> int:
    """Compiled evaluation programs per (scene, behaviour): one per method (its input
    function) and per baseline; a method's seeds and speeds are arguments of its program."""
    return len(plan.method_names) + len(BASELINES)


def _per_cell_s(plan: Plan) -> float:
    return plan.episodes / 1000 * EST_EVAL_S_PER_1000_EPISODES


def table_i_s(plan: Plan) -> float:
    cells = _policies(plan) * len(plan.speeds_mps) * len(plan.table_i_rows)
    return cells * _per_cell_s(plan) + _programs(plan) * len(plan.table_i_rows) * EST_COMPILE_S


def fig6_s(plan: Plan) -> float:
    columns = len(fig6_evaluated_columns(plan))
    return (_policies(plan) * _per_cell_s(plan) + _programs(plan) * EST_COMPILE_S) * columns


def transfer_s(plan: Plan) -> float:
    # Only the trained methods' policies (no baselines), one speed, per transfer column.
    cells = len(plan.method_names) * plan.seeds * _per_cell_s(plan)
    return (cells + len(plan.method_names) * EST_COMPILE_S) * len(plan.transfer_behaviors)


def videos_s(plan: Plan) -> float:
    return EST_VIDEO_S * len(plan.fig6_columns)


def fig9_s(plan: Plan) -> float:
    # One compilation per (policy, scene, behaviour): a trained policy's seeds (a pytree
    # policy is an argument) and its rows with and without the blend (a traced flag) share it.
    rows = rows_of(plan)
    scenes_behaviors = len(plan.fig9_scenes) * len(plan.fig9_columns)
    cells = sum(plan.seeds if r.learned else 1 for r in rows) * scenes_behaviors
    compiles = len({r.policy for r in rows}) * scenes_behaviors
    # A 40 s episode is 2 of the 20 s ones the evaluation constant was measured on.
    episode_s = (plan.fig9_duration_s or 40.0) / 20.0
    per_cell = plan.fig9_episodes / 1000 * EST_EVAL_S_PER_1000_EPISODES * episode_s
    return cells * per_cell + compiles * EST_COMPILE_S


def fig9_videos_s(plan: Plan) -> float:
    return EST_VIDEO_S * len(plan.fig9_scenes)
