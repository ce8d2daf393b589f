"""A rough wall-time estimate of each stage on 2 cores, printed before a reproduction starts.

A stage's time is its work at a measured rate plus its compilations, counted from the plan:
a training group compiles its iteration and periodic evaluation once (a (method,
behaviour)'s seeds compile once, grouped or one by one: docs/scaling.md); an evaluation
compiles one program per (method or baseline, scene, behaviour), seeds, speeds and the
Fig. 9 blend flag being arguments (``benchmarks/eval_compiles.py``). Each constant below
names the measurement it comes from, all on the idle 2-core Xeon:

* the quick profile from an empty compilation cache (a fresh clone's ``make demo``),
  docs/performance.md "A reproduction's stages": predictors 10 s, Table II 32 s, 4 training
  runs 91 s (21-24 s each), 7 Table I jobs 55 s (7-9 s each, 4 s for ``sp_rl``'s, whose
  program ``sp_fp``'s job had compiled), a video 9 s, 3 Fig. 9 jobs 26 s, its video 7 s:
  230 s; ``benchmarks/reproduce_stages.py`` splits each stage into compilation and work;
* the full run of 2026-12-02 (docs/results.md: 3 seeds, 1000 episodes a Table I cell, 500
  a Fig. 9 cell, evaluation then compiling once per policy and speed): a group of 3 seeds x
  4 M steps 551-582 s, Table I 12.2 min, Fig. 9 37.3 min, videos 0.5 min;
* ``dyncatch bench ppo`` for the training rate, and the 13 s / 18 s per 1000 Fig. 9
  episodes of ``Plan.fig9_episodes``;
* the power run of 2026-12-03 (``benchmarks/results/power``, commit 0e2ccfb: 30 seeds x
  4 M steps a group at 128-128-64, 13 inputs), its two uncontended groups on
  random_reactive: ``rl`` 2,334 s (1,988 s of it training iterations, the ``time_s`` of
  metrics.csv, which leaves out the periodic evaluations), ``sp_rl`` 2,792 s (2,208 s).
  The estimate printed before that run, 131 min, was 25 % under its 2 h 55 min: it counted
  the periodic evaluations as a fixed 20 % of the iterations and every method at ``rl``'s
  rate.

On another machine these constants do not hold (2-core AMD EPYCs ran 1.2-1.6x slower), so
each function takes the machine's ``MachineSpeed`` (``bench.speed_probe``, which
``dyncatch reproduce`` measures first): its work scaled by the compute factor, its
compilations (the ``*_COMPILE_S`` terms) by the compile factor; the default is the
reference machine itself. The serial executor's log also gives, from a stage's second job
on, the stage's time left at its mean measured job (``executors.remaining_note``).
"""

from __future__ import annotations

import math

from dyncatch.bench.ppo_bench import ppo_flops_per_sample
from dyncatch.bench.speed_probe import REFERENCE, MachineSpeed
from dyncatch.policies.registry import BASELINES
from dyncatch.predictor.table import all_kinds
from dyncatch.reproduce.fig9 import rows_of
from dyncatch.reproduce.layout import fig6_evaluated_columns
from dyncatch.reproduce.plan import Plan
from dyncatch.rl.methods import METHODS, predictor_kinds, trained_methods
from dyncatch.rl.runner import TrainRunCfg, eval_due
from dyncatch.sim.api import obs_dim

EST_S_PER_SAMPLE = 4.8e-6
"""Seconds per training sample outside the networks (simulator, GAE, normaliser): the
intercept of the two measured sizes below."""
EST_S_PER_PPO_FLOP = 5.9e-12
"""Seconds per PPO FLOP (``bench.ppo_bench.ppo_flops_per_sample``'s count). With the line
above it fits ``dyncatch bench ppo`` on the idle 2-core Xeon: 27,000 samples/s at
256-256-128 (5.47 M FLOPs per sample) and 76,322 at 128-128-64 (1.41 M)."""
EST_TRAIN_OVERHEAD = 0.937
"""A training iteration's time over the two lines above at one seed (the lines are a fit to
an older benchmark; today's ``dyncatch bench ppo`` runs 0.916 of them, a training run a
little more): with ``EST_GROUP_LOG_COST`` it gives back the power run's ``rl`` on
random_reactive, 30 seeds x 245 iterations of 16,384 samples (120.4 M) in 1,988 s of
iterations, 16.51 us a sample (13.04 us x 0.937 x 1.350 at 128-128-64). The periodic
evaluations are counted apart (below)."""
EST_GROUP_LOG_COST = 0.103
"""A vmap-ped group of S seeds costs (1 + this x ln S) times one seed's time a sample on 2
CPU cores: ``dyncatch bench ppo --json --seeds S --gemm-rows 4096`` at 128-128-64, run back
to back on the idle 2-core Xeon (2026-12-03): 83,730 samples/s at 1 seed, 67,568 at 10
(0.81x: 0.104 ln 10), 62,130 at 30 (0.74x: 0.102 ln 30). One seed's batch already fills
both cores, and a group's batched products run slower than one seed's; hence
``Plan.vmap_seeds`` is off by default (dyncatch is CPU-first; on a GPU pass --vmap-seeds)."""
EST_TRAIN_PREDICTOR_S_PER_SAMPLE = 1.83e-6
"""A learned predictor's time a training sample (``p_rl``, ``sp_rl``, a tracker: it runs
in every rollout step, whatever the policy's size): the power run's ``sp_rl`` on
random_reactive took 2,208 s of iterations against ``rl``'s 1,988 s at the same 120.4 M
samples."""
EST_TRAIN_EVAL_S_PER_1000_EPISODES = {False: 2.22, True: 3.74}
"""Seconds per 1000 periodic-evaluation episodes of a training group (``TrainRunCfg``'s
``eval_every``, ``eval_episodes``; its compilation and the run's final writes included),
without and with a learned predictor: the power run's groups on random_reactive less their
iterations, 346 s (``rl``) and 584 s (``sp_rl``) for 26 evaluations x 30 seeds x 200
episodes."""
EST_TRAIN_COMPILE_S = 13.0
"""One training group's compilations (its iteration) and start: the quick run's training
runs took 21-24 s: 8.3 s of 0.5 M samples at the lines above, 2.2 s of 5 periodic
evaluations of 200 episodes, and this."""
EST_EVAL_COMPILE_S = 5.0
"""One open-plane evaluation program (Table I, Fig. 6, transfer): the quick run's Table I
jobs with a compilation took 7-9 s, ``sp_rl``'s, whose program was compiled, 4 s."""
EST_EVAL_S_PER_CELL = 0.45
"""A cell's fixed cost (its policy and predictor loaded, the rollout dispatched, the JSON
written). With the next constant it solves two measurements: the quick run's ``sp_rl``
Table I job, 6 cells x 200 episodes without a compilation, 4 s (6 x 0.45 + 1.2 x 1.08),
and the full run's Table I, 204 cells x 1000 episodes and 84 compilations, 732 s
(204 x (0.45 + 1.08) + 84 x 5)."""
EST_EVAL_S_PER_1000_EPISODES = 1.08
"""Seconds per 1000 open-plane episodes of 20 s (the line above)."""
EST_SCENE_S_PER_1000_EPISODES = {False: 4.7, True: 16.1}
"""Seconds per 1000 Fig. 9 episodes of 40 s in a room, plain and with the blend
(``Plan.fig9_episodes``): ``python benchmarks/fig9_episode_cost.py`` with the power run's
``sp_rl`` seed 0 in room_8 on reactive at 1.8 m/s, 500 episodes, the idle 2-core Xeon
(2026-12-03, commit 4d782fd): 4.65 and 4.75 s plain, 16.0 and 16.1 s blended (pursuit
alone: 2.0 s, so the networks and the blend are the cost, not the scene). The earlier
constants, 13 and 18 s, were measured on older code (15 inputs)."""
EST_SCENE_COMPILE_S = 6.0
"""One Fig. 9 program (a scene's obstacles and scan, the blend a flag): the quick run's
Fig. 9 jobs, 8-10 s each, less their cells at the rates measured then (13 and 18 s per
1000 episodes), 5.8-6.0 s; the full run's Fig. 9, 192 cells and 96 compilations (one per
row, scene and behaviour then) in 2,190 s besides its 6 videos, gives 5.8 s at those rates."""
EST_PREDICTOR_S_PER_M_STEPS = 8.0
"""Seconds per million interaction steps a predictor trains on (its data collected, its
updates): Table II of the quick run, 2 kinds x 4 behaviours x 0.5 M steps, took 32 s."""
EST_PREDICTOR_COMPILE_S = 2.0
"""A behaviour's predictors' compilations and start (collection, training and held-out
evaluation programs): the quick run's two predictors took 10 s, 8 s of them their 1 M
steps at the line above. The full run's predictors and Table II took 228 s together,
196 s at these two constants (-14 %, half a minute of its 2 h)."""
EST_VIDEO_S = 8.0
"""One GIF: the quick run's 9 s (``sp_rl`` on reactive) and 7 s (room_8); the full run's 4
in 0.5 min."""


def predictors_s(plan: Plan, speed: MachineSpeed = REFERENCE) -> float:
    pairs = len(predictor_kinds(plan.method_names)) * len(plan.behaviors)
    steps = pairs * plan.predictor_steps
    work = steps / 1e6 * EST_PREDICTOR_S_PER_M_STEPS
    return work * speed.compute + EST_PREDICTOR_COMPILE_S * len(plan.behaviors) * speed.compile


def table_ii_s(plan: Plan, speed: MachineSpeed = REFERENCE) -> float:
    steps = len(all_kinds()) * len(plan.table_ii_rows) * max(plan.table_ii_budgets)
    return steps / 1e6 * EST_PREDICTOR_S_PER_M_STEPS * speed.compute


def group_size(plan: Plan) -> int:
    """Seeds trained as one computation: the plan's seeds with ``vmap_seeds``, else 1."""
    return plan.seeds if plan.vmap_seeds else 1


def samples_per_s(plan: Plan) -> float:
    """Training samples per second at the plan's network size (``rl``'s input in the plan's
    world) and group size, all of a group's seeds counted."""
    flops = ppo_flops_per_sample(obs_dim(plan.world), plan.ppo)["total"]
    group = 1.0 + EST_GROUP_LOG_COST * math.log(group_size(plan))
    return 1.0 / ((EST_S_PER_SAMPLE + EST_S_PER_PPO_FLOP * flops) * EST_TRAIN_OVERHEAD * group)


def train_evaluations(plan: Plan) -> int:
    """Periodic evaluations in one training run of ``plan`` (the first iteration's, every
    ``eval_every``-th, the last's)."""
    cfg = TrainRunCfg(total_steps=plan.train_steps, ppo=plan.ppo)
    iters = -(-plan.train_steps // plan.ppo.batch_size)
    return sum(eval_due(cfg, it, 0, iters) for it in range(iters))


def group_s(plan: Plan, method: str, speed: MachineSpeed = REFERENCE) -> float:
    """One (method, behaviour)'s seeds, grouped or one by one: their iterations, their
    periodic evaluations and one compilation (one by one, the later seeds reuse the first
    seed's programs in the same process)."""
    learned = METHODS[method].predictor_kind is not None
    per_sample_s = 1.0 / samples_per_s(plan) + EST_TRAIN_PREDICTOR_S_PER_SAMPLE * learned
    iterations = plan.seeds * plan.train_steps * per_sample_s
    episodes = plan.seeds * train_evaluations(plan) * TrainRunCfg.eval_episodes
    evaluations = episodes / 1000 * EST_TRAIN_EVAL_S_PER_1000_EPISODES[learned]
    return (iterations + evaluations) * speed.compute + EST_TRAIN_COMPILE_S * speed.compile


def training_s(plan: Plan, speed: MachineSpeed = REFERENCE) -> float:
    methods = trained_methods(plan.method_names)
    return len(plan.behaviors) * sum(group_s(plan, m, speed) for m in methods)


def _policies(plan: Plan) -> int:
    return len(plan.method_names) * plan.seeds + len(BASELINES)


def _programs(plan: Plan) -> int:
    """Compiled evaluation programs per (scene, behaviour): one per method (its input
    function) and per baseline; a method's seeds and speeds are arguments of its program."""
    return len(plan.method_names) + len(BASELINES)


def _per_cell_s(plan: Plan) -> float:
    return EST_EVAL_S_PER_CELL + plan.episodes / 1000 * EST_EVAL_S_PER_1000_EPISODES


def table_i_s(plan: Plan, speed: MachineSpeed = REFERENCE) -> float:
    cells = _policies(plan) * len(plan.speeds_mps) * len(plan.table_i_rows)
    programs = _programs(plan) * len(plan.table_i_rows)
    return cells * _per_cell_s(plan) * speed.compute + programs * EST_EVAL_COMPILE_S * speed.compile


def fig6_s(plan: Plan, speed: MachineSpeed = REFERENCE) -> float:
    columns = len(fig6_evaluated_columns(plan))
    cells = _policies(plan) * _per_cell_s(plan) * speed.compute
    return (cells + _programs(plan) * EST_EVAL_COMPILE_S * speed.compile) * columns


def transfer_s(plan: Plan, speed: MachineSpeed = REFERENCE) -> float:
    # Only the trained methods' policies (no baselines), one speed, per transfer column.
    cells = len(plan.method_names) * plan.seeds * _per_cell_s(plan) * speed.compute
    compiles = len(plan.method_names) * EST_EVAL_COMPILE_S * speed.compile
    return (cells + compiles) * len(plan.transfer_behaviors)


def videos_s(plan: Plan, speed: MachineSpeed = REFERENCE) -> float:
    return EST_VIDEO_S * len(plan.fig6_columns) * speed.compute


def fig9_s(plan: Plan, speed: MachineSpeed = REFERENCE) -> float:
    # One compilation per (policy, scene, behaviour): a trained policy's seeds (a pytree
    # policy is an argument) and its rows with and without the blend (a traced flag) share it.
    rows = rows_of(plan)
    scenes_behaviors = len(plan.fig9_scenes) * len(plan.fig9_columns)
    episodes = plan.fig9_episodes / 1000 * (plan.fig9_duration_s or 40.0) / 40.0
    per_group = sum(
        (plan.seeds if r.learned else 1)
        * (EST_EVAL_S_PER_CELL + episodes * EST_SCENE_S_PER_1000_EPISODES[r.blend])
        for r in rows
    )
    compiles = len({r.policy for r in rows})
    compile_s = compiles * EST_SCENE_COMPILE_S * speed.compile
    return (per_group * speed.compute + compile_s) * scenes_behaviors


def fig9_videos_s(plan: Plan, speed: MachineSpeed = REFERENCE) -> float:
    return EST_VIDEO_S * len(plan.fig9_scenes) * speed.compute
