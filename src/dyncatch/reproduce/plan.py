"""What a reproduction runs: a ``Plan``, which is also the command line of ``dyncatch reproduce``.

A profile (``full``, or ``quick`` with ``--quick``) gives every field its default; any flag
given on the command line overrides it, even when it equals another profile's value. The
plan, with its whole world and PPO config, is recorded in ``plan.json``: a results folder
says exactly what produced it, and a re-run with another plan into it is refused.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from dyncatch.policies.registry import BASELINES
from dyncatch.predictor.table import all_behaviors, all_kinds
from dyncatch.reproduce.paper import PAPER_SPEEDS_MPS
from dyncatch.reproduce.readings import ReadingName, apply_readings
from dyncatch.rl.config import PPOCfg, validate_ppo
from dyncatch.rl.methods import (
    MethodName,
    check_selection,
    predictor_kinds,
    selected,
    trained_methods,
)
from dyncatch.sim.behaviors import BEHAVIORS, BehaviorName
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.scenes import SceneName
from dyncatch.sim.validate import validate_world
from dyncatch.utils.config_io import to_json


@dataclass(frozen=True)
class Plan:
    """Train every trained method on each behaviour over seeds (evaluation-only methods
    reuse their policies), then write Table I, Table II, Fig. 5, Fig. 6, Fig. 9, videos,
    report.md and results.json. Re-running the same command skips finished stages and resumes an
    interrupted one.
    """

    quick: bool = False
    """The quick profile (one seed, one behaviour, short training, fewer episodes; 9 min on 2 cores)
    instead of the full one (3 seeds, 4 M steps per run, 1000 episodes per cell)."""
    out: Path | None = None
    """Results folder (default results/full or results/quick)."""
    setting: tuple[ReadingName, ...] = ()
    """Readings of the paper applied on top of the profile, in order
    (dyncatch.reproduce.readings; none: the library defaults). Flags still override them."""
    seeds: int = 3
    """Training seeds per (method, behaviour)."""
    behaviors: tuple[BehaviorName, ...] = ("reactive", "random_reactive")
    """Behaviours trained on (Table I rows, Fig. 5 panels)."""
    train_steps: int = 4_000_000
    """Environment steps per training run."""
    table_i_behaviors: tuple[BehaviorName, ...] | None = None
    """Rows of Table I (default: the behaviours trained on). One not trained on is evaluated
    with the first trained behaviour's policies and predictors (transfer, as in Fig. 6);
    ``trained_on`` in results.json says which."""
    speeds_mps: tuple[float, ...] = PAPER_SPEEDS_MPS
    """Table I columns (target speeds, m/s)."""
    episodes: int = 1000
    """Evaluation episodes per (policy, behaviour, speed) cell."""
    fig6_speed_mps: float = 1.8
    """The high speed of Fig. 6."""
    fig6_behaviors: tuple[BehaviorName, ...] | None = None
    """Columns of Fig. 6 and the videos (default: every registered behaviour)."""
    predictor_steps: int = 2_000_000
    """Interaction steps the frozen predictors are trained on."""
    predictor_updates: int = 6000
    """Gradient steps of each predictor."""
    table_ii_budgets: tuple[int, ...] = (200_000, 500_000, 1_000_000, 2_000_000)
    """Table II columns (interaction steps)."""
    table_ii_eval_steps: int = 500_000
    """Held-out interaction steps per Table II behaviour."""
    table_ii_behaviors: tuple[BehaviorName, ...] | None = None
    """Rows of Table II (default: every registered behaviour)."""
    methods: tuple[MethodName, ...] | None = None
    """Methods compared, names of dyncatch.rl.methods.METHODS (default: all but the opt-in
    ones beyond the paper, st_rl and st_fp; list every method wanted to add them). A method
    evaluated with another's policy (sp_fp, st_fp) needs that one (gt_rl) listed too."""
    videos: bool = True
    """One GIF per behaviour of the filmed method's policy (and one per Fig. 9 scene)."""
    fig9: bool = True
    """The Fig. 9 stage: the plane-trained policies in rooms and woods, with and without
    eq. 10's collision-avoidance blend (dyncatch.reproduce.fig9); --no-fig9 skips it."""
    fig9_scenes: tuple[SceneName, ...] = (
        "room_0",
        "room_4",
        "room_8",
        "woods_plane",
        "woods_rough",
        "woods_stairs",
    )
    """Scenes of Fig. 9 (the paper's Room-0/4/8 and Wood-P/R/S)."""
    fig9_behaviors: tuple[BehaviorName, ...] = ("circle", "bounce", "reactive", "random_reactive")
    """Behaviours of Fig. 9: the paper's three (Sec. V-E names circle, bounce and reactive,
    and its Room-0 average, 86.8 %, is their mean) and random_reactive (Table I's other
    row). One not trained on uses the first trained behaviour's policies, as in Fig. 6; the
    first is filmed."""
    fig9_episodes: int = 500
    """Evaluation episodes per Fig. 9 cell (scene, behaviour, row, seed). 500, not Table I's
    1000: Fig. 9 has 192 cells of 40 s episodes (measured on 2 cores: 13 s per 1000 episodes
    of plain sp_rl in room_8, 18 s blended). Its CIs are over seeds; a seed's own binomial
    error at 500 episodes is at most 0.022 (in the full run, room_8's seeds of blended sp_rl
    on reactive spread less than that, 0.950-0.962, so there it is part of the CI)."""
    fig9_duration_s: float | None = None
    """Episode length of Fig. 9 (default: each scene's, 40 s as in the paper)."""
    vmap_seeds: bool = True
    """Train a (method, behaviour)'s seeds as one vmap-ped computation (dyncatch.rl.seeds:
    equal to separate runs to float tolerance); --no-vmap-seeds trains them one by one."""
    executor: Literal["serial", "ray"] = "serial"
    """Who runs each stage's independent jobs (predictors, training runs, evaluation cells,
    videos): this process, or Ray tasks (dyncatch.reproduce.executors, docs/scaling.md).
    The results are the same; it is not recorded in plan.json."""
    ray_address: str | None = None
    """With --executor ray: the Ray cluster to join (e.g. ray://head:10001 or auto); unset
    starts a local Ray on this machine's cores."""
    ray_workers: int | None = None
    """With --executor ray and no --ray-address: worker processes of the local Ray (default:
    one per core; fewer leave cores to other work)."""
    ray_gpus_per_job: float = 0.0
    """With --executor ray: GPUs each job asks Ray for (e.g. 0.5 packs two jobs a GPU)."""
    ppo: PPOCfg = PPOCfg()
    """PPO hyper-parameters and batch geometry of every run."""
    world: WorldCfg = WorldCfg()
    """The simulated world of every stage."""

    @property
    def profile(self) -> str:
        return "quick" if self.quick else "full"

    @property
    def out_dir(self) -> Path:
        return self.out if self.out is not None else Path("results") / self.profile

    @property
    def fig6_columns(self) -> tuple[str, ...]:
        """The behaviours of Fig. 6 and the videos."""

        return self.fig6_behaviors if self.fig6_behaviors is not None else all_behaviors()

    @property
    def table_i_rows(self) -> tuple[str, ...]:
        """The behaviours of Table I."""
        return self.table_i_behaviors if self.table_i_behaviors is not None else self.behaviors

    @property
    def table_ii_rows(self) -> tuple[str, ...]:
        """The behaviours of Table II."""

        return self.table_ii_behaviors if self.table_ii_behaviors is not None else all_behaviors()

    @property
    def method_names(self) -> tuple[str, ...]:
        """The methods compared, in registry order."""

        return tuple(selected(self.methods))

    @property
    def training_runs(self) -> int:

        return len(trained_methods(self.method_names)) * len(self.behaviors) * self.seeds

    def to_json(self) -> dict:
        """Everything that shapes the results (all fields but where they go and who runs
        the jobs), as JSON values."""

        d = to_json(self)
        for name in NOT_RECORDED:
            del d[name]
        return d


NOT_RECORDED = ("out", "executor", "ray_address", "ray_workers", "ray_gpus_per_job")
"""Plan fields that do not shape the results, left out of plan.json."""


PROFILES: dict[str, Plan] = {
    "full": Plan(),
    "quick": Plan(
        quick=True,
        seeds=1,
        # Measured 2026-12-02 on the idle 2-core machine: the previous quick profile (both
        # fleeing behaviours trained for 0.8 M steps, Fig. 6 on every behaviour) ran
        # `make demo` in 17.8 min (training 528 s, Table I 180 s, Fig. 6 105 s of the
        # reproduction's 999 s), over the 10 minutes. Evaluation is mostly compilation (about
        # 10 s per cell), so the profile keeps fewer cells rather than fewer episodes: the
        # paper's central behaviour only, Fig. 6 on it and on circle (the transfer column),
        # 0.5 M steps (the knee of the full run's learning curves). Measured: docs/results.md.
        behaviors=("reactive",),
        fig6_behaviors=("reactive", "circle"),
        train_steps=500_000,
        episodes=200,
        predictor_steps=500_000,
        predictor_updates=1500,
        table_ii_budgets=(100_000, 500_000),
        table_ii_eval_steps=100_000,
        # 128-128-64 networks train about 2.4x faster than 256-256-128 on 2 cores.
        ppo=PPOCfg(hidden_sizes=(128, 128, 64)),
        # One scene, the one with the most obstacles (walls, occlusion, the scan and the
        # blend all act), on the trained behaviour: 4 cells, each compiled once, and one GIF.
        # Measured with two scenes (room_8, woods_rough): 98 s of the quick run's 11.8 min;
        # terrain is left to the full profile and the tests.
        fig9_scenes=("room_8",),
        fig9_behaviors=("reactive",),
        fig9_episodes=100,
    ),
}


def profile_default(plan: Plan) -> Plan:
    """The profile and readings a first parse of the command line asked for: the command
    line is parsed again on top of them, so every flag given overrides both."""

    return apply_readings(PROFILES[plan.profile], plan.setting)


# Measured on the idle 2-core machine; only used to print an estimate before starting.
# The full run of 2026-12-02 (docs/results.md): a group of 3 seeds x 4 M steps took
# 551-582 s with its compilation and periodic evaluations (training is bound by PPO's
# update, not the simulator); Table I's 6 speeds x 1000 episodes about 20 s per policy;
# a video 7 s. Its uncontended stages sum to about 132 min; these constants give 139.
# A (method, behaviour)'s seeds compile once whether grouped or one by one (a process
# reuses the compiled iteration: docs/scaling.md).
EST_SAMPLES_PER_S = 22_000.0
EST_COMPILE_S = 20.0  # one compilation: a training group's iteration, a Fig. 9 row's rollout
EST_EVAL_S_PER_1000_EPISODES = 3.0
EST_PREDICTOR_S_PER_M_STEPS = 8.0
EST_VIDEO_S = 10.0


def estimate_s(plan: Plan) -> float:
    """A rough wall-time estimate (seconds) for the whole plan on 2 cores."""
    # Local: this module imports plan (a cycle inside reproduce/, left to its owners).
    from dyncatch.reproduce.stages import fig6_evaluated_columns

    columns = plan.fig6_columns
    groups = plan.training_runs // plan.seeds
    train = plan.training_runs * plan.train_steps / EST_SAMPLES_PER_S
    train += groups * EST_COMPILE_S
    policies = len(plan.method_names) * plan.seeds + len(BASELINES)
    fig6 = len(fig6_evaluated_columns(plan))
    cells = policies * (len(plan.speeds_mps) * len(plan.table_i_rows) + fig6)
    evaluate = cells * (plan.episodes / 1000 * EST_EVAL_S_PER_1000_EPISODES + 1.0)
    pred_steps = (
        len(predictor_kinds(plan.method_names)) * len(plan.behaviors) * plan.predictor_steps
    )
    pred_steps += len(all_kinds()) * len(plan.table_ii_rows) * max(plan.table_ii_budgets)
    predictors = pred_steps / 1e6 * EST_PREDICTOR_S_PER_M_STEPS + 30 * len(plan.behaviors)
    videos = EST_VIDEO_S * len(columns) if plan.videos else 0.0
    fig9 = 0.0
    if plan.fig9:
        # Local: this module imports plan (a cycle inside reproduce/, left to its owners).
        from dyncatch.reproduce.fig9 import rows_of

        # The seeds of a trained row share one compilation (a pytree policy is an argument).
        rows = rows_of(plan)
        scenes_behaviors = len(plan.fig9_scenes) * len(plan.fig9_behaviors)
        cells = sum(plan.seeds if r.learned else 1 for r in rows) * scenes_behaviors
        compiles = len(rows) * scenes_behaviors
        # A 40 s episode is 2 of the 20 s ones the evaluation constant was measured on.
        episode_s = (plan.fig9_duration_s or 40.0) / 20.0
        per_cell = plan.fig9_episodes / 1000 * EST_EVAL_S_PER_1000_EPISODES * episode_s
        fig9 = cells * per_cell + compiles * EST_COMPILE_S
        fig9 += EST_VIDEO_S * len(plan.fig9_scenes) if plan.videos else 0.0
    return train + evaluate + predictors + videos + fig9


def validate_plan(plan: Plan) -> Plan:
    """Raise ValueError naming the flag that cannot work."""

    if plan.seeds < 1:
        raise ValueError(f"--seeds must be >= 1, got {plan.seeds}")
    # Local: this module imports plan (a cycle inside reproduce/, left to its owners).
    from dyncatch.reproduce.executors import validate_executor

    validate_executor(plan)
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
    if plan.methods is not None:
        if not plan.methods:
            raise ValueError("--methods needs at least one method (or leave it unset)")
        check_selection(plan.methods)
    named = (
        ("table-i", plan.table_i_behaviors),
        ("fig6", plan.fig6_behaviors),
        ("table-ii", plan.table_ii_behaviors),
    )
    for name, value in named:
        if value is not None and not value:
            raise ValueError(f"--{name}-behaviors needs at least one behaviour (or leave it unset)")
    rows = (*plan.behaviors, *plan.table_i_rows, *plan.fig6_columns, *plan.table_ii_rows)
    for b in dict.fromkeys(rows):
        validate_world(plan.world.with_behavior(b))
    if plan.fig9:
        _validate_fig9(plan)
    return plan


def _validate_fig9(plan: Plan) -> None:
    # Local: this module imports plan (a cycle inside reproduce/, left to its owners).
    from dyncatch.reproduce.fig9 import scene_world

    if not plan.fig9_scenes or not plan.fig9_behaviors:
        raise ValueError("--fig9-scenes and --fig9-behaviors need one each (or --no-fig9)")
    if plan.fig9_episodes < 1:
        raise ValueError(f"--fig9-episodes must be >= 1, got {plan.fig9_episodes}")
    if plan.fig9_duration_s is not None and plan.fig9_duration_s <= 0:
        raise ValueError(f"--fig9-duration-s must be positive, got {plan.fig9_duration_s}")
    for scene in plan.fig9_scenes:
        for b in plan.fig9_behaviors:
            validate_world(scene_world(plan.world, scene, b, plan))
