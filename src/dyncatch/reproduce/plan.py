"""What a reproduction runs: a ``Plan``, which is also the command line of ``dyncatch reproduce``.

A profile (``full``; ``quick`` with ``--quick``; ``power`` with ``--power``) gives every
field its default; any flag given on the command line overrides it, even when it equals
another profile's value. The plan, with its whole world and PPO config, is recorded in
``plan.json``: a results folder says exactly what produced it, and a re-run with another
plan into it is refused.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Literal

from dyncatch.predictor.table import all_behaviors
from dyncatch.reproduce.endpoints import PRIMARY_ENDPOINTS, EndpointArg
from dyncatch.reproduce.paper import PAPER_FIG9_SCENES, PAPER_SPEEDS_MPS
from dyncatch.reproduce.presentation import chosen
from dyncatch.reproduce.readings import ReadingName, apply_readings
from dyncatch.rl.config import PPOCfg
from dyncatch.rl.methods import (
    GROUND_TRUTH_READING,
    GroundTruthReading,
    MethodName,
    trained_methods,
)
from dyncatch.sim.behaviors import BehaviorName
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.scenes import SceneName
from dyncatch.utils.config_io import to_json


@dataclass(frozen=True)
class Plan:
    """Train every trained method on each behaviour over seeds (evaluation-only methods
    reuse their policies), then write Table I, Table II, Fig. 5, Fig. 6, Fig. 9, the
    transfer table, videos, report.md and results.json.

    The paper's protocol: a policy (with its behaviour's own predictor) is evaluated on the
    behaviour it was trained on, in Table I, Fig. 6 and Fig. 9; every behaviour those show
    must be trained on. Transfer (policies trained on ``transfer_from`` tested on other
    behaviours) is a separate, labelled table (``transfer_behaviors``). Re-running the same
    command skips finished stages and resumes an interrupted one.
    """

    quick: bool = False
    """The quick profile (one seed, one behaviour, short training, fewer episodes; about 4
    min on 2 cores) instead of the full one (10 seeds on each of the four behaviours, 4 M
    steps per run, 300 episodes per cell)."""
    power: bool = False
    """The power profile: only rl and sp_rl, 30 seeds on reactive and random_reactive,
    Table I at 1.6 and 1.8 m/s (the primary endpoints; no Table II, Fig. 9, transfer or
    videos). 30 seeds: at the full run's pooled seed SDs (rl 0.23, sp_rl 0.06) the 95 % CI
    half-width on sp_rl - rl is about 0.09, within the 0.10 target; 10 seeds give about
    0.17."""
    out: Path | None = None
    """Results folder (default results/full or results/quick)."""
    setting: tuple[ReadingName, ...] = ()
    """Readings of the paper applied on top of the profile, in order
    (dyncatch.reproduce.readings; none: the library defaults). Flags still override them."""
    seeds: int = 10
    """Training seeds per (method, behaviour): the unit of every CI (seed SDs of 0.05-0.23
    at 1.8 m/s, so fewer than 10 leave CIs wider than the differences judged)."""
    first_seed: int = 0
    """The first training seed: runs are seeds ``first_seed`` ... ``first_seed + seeds - 1``
    and the predictors are trained with seed ``first_seed``, so ``--first-seed 10`` into
    another ``--out`` is a second, independent seed set of the same plan (the primary
    endpoints judged twice, docs/results.md)."""
    behaviors: tuple[BehaviorName, ...] = ("circle", "bounce", "reactive", "random_reactive")
    """Behaviours trained on, each with its own predictor (Fig. 5 panels; Fig. 6 columns)."""
    train_steps: int = 4_000_000
    """Environment steps per training run."""
    table_i_behaviors: tuple[BehaviorName, ...] | None = ("reactive", "random_reactive")
    """Rows of Table I (the paper's two; None: the behaviours trained on). Each must be
    trained on (``trained_on`` in results.json says so)."""
    speeds_mps: tuple[float, ...] = PAPER_SPEEDS_MPS
    """Table I columns (target speeds, m/s)."""
    episodes: int = 300
    """Evaluation episodes per (policy, behaviour, speed) cell, from the binomial arithmetic:
    a seed's success rate at p over n episodes has SE sqrt(p(1-p)/n) <= 0.5/sqrt(n). At
    n = 300 that is <= 0.029, and 0.017 at p = 0.9 where the primary endpoints sit: a
    variance of 3e-4 against the smallest between-seed SD measured (sp_rl, 0.05: 2.5e-3)
    adds 12 % to it, and 2-6 % against rl's 0.12-0.23, so a seed mean's SD grows by <= 6 %.
    1000 episodes would buy 1-2 % of CI width at 3.3x the evaluation time; seeds buy it
    (the CI shrinks as 1/sqrt(seeds)). Quick: 200."""
    fig6_speed_mps: float = 1.8
    """The high speed of Fig. 6."""
    fig6_behaviors: tuple[BehaviorName, ...] | None = None
    """Columns of Fig. 6 and the videos (default: the behaviours trained on), each policy
    on its own behaviour."""
    transfer_from: BehaviorName = "reactive"
    """The behaviour whose policies (and predictors) the transfer table tests elsewhere."""
    transfer_behaviors: tuple[BehaviorName, ...] = ("circle", "bounce", "random_reactive")
    """Columns of the transfer table (an extra beyond the paper, not its protocol): the
    trained methods of ``transfer_from`` at ``fig6_speed_mps`` on each; () skips it."""
    predictor_steps: int = 2_000_000
    """Interaction steps the frozen predictors are trained on."""
    predictor_updates: int = 6000
    """Gradient steps of each predictor."""
    table_ii_budgets: tuple[int, ...] = (200_000, 500_000, 1_000_000, 2_000_000)
    """Table II columns (interaction steps)."""
    table_ii_eval_steps: int = 500_000
    """Held-out interaction steps per Table II behaviour."""
    table_ii: bool = True
    """The Table II stage (--no-table-ii skips it)."""
    table_ii_behaviors: tuple[BehaviorName, ...] | None = None
    """Rows of Table II (default: every registered behaviour)."""
    methods: tuple[MethodName, ...] | None = None
    """Methods compared, names of dyncatch.rl.methods.METHODS (default: all but the opt-in
    ones beyond the paper, st_rl, st_fp, rnn_rl and rnn_sp_rl, as
    dyncatch.reproduce.presentation marks them;
    list every method wanted to add them). A method
    evaluated with another's policy (sp_fp, st_fp) needs that one (gt_rl) listed too."""
    ground_truth: GroundTruthReading = GROUND_TRUTH_READING
    """How gt_rl (GT-Pred) reads the ground truth, in training and evaluation
    (dyncatch.rl.methods.GroundTruthReading): when_predicted, the target's true velocity
    under the predictor's availability rule (default), or always."""
    primary_endpoints: tuple[EndpointArg, ...] = PRIMARY_ENDPOINTS
    """The verdicts this plan declares before it runs (dyncatch.reproduce.endpoints), each
    WINNER-LOSER:BEHAVIOR:SPEED (success of WINNER minus LOSER's) or headroom:BEHAVIOR:SPEED
    (the oracle against the best non-oracle method), optionally :MARGIN (default 0.1).
    Judged unadjusted, with the smallest difference the run resolves; every other check is
    secondary (Holm). One outside the plan's Table I rows, speeds or methods is not
    measured, and report.md says so."""
    videos: bool = True
    """One GIF per behaviour of the filmed method's policy (and one per Fig. 9 scene)."""
    fig9: bool = True
    """The Fig. 9 stage: the plane-trained policies in rooms and woods, with and without
    eq. 10's collision-avoidance blend (dyncatch.reproduce.fig9); --no-fig9 skips it."""
    fig9_scenes: tuple[SceneName, ...] = PAPER_FIG9_SCENES
    """Scenes of Fig. 9 (the paper's Room-0/4/8 and Wood-P/R/S)."""
    fig9_behaviors: tuple[BehaviorName, ...] | None = None
    """Behaviours of Fig. 9 (default: the behaviours trained on: the paper's three, Sec.
    V-E names circle, bounce and reactive and its Room-0 average, 86.8 %, is their mean,
    and random_reactive, Table I's other row), each trained on; the first is filmed."""
    fig9_speed_mps: float | None = 1.8
    """The target's speed in Fig. 9 (the paper's high speed: its abstract pairs Table I's
    1.8 m/s success with the rooms'); None: the named variant ``drawn``, the speed drawn per
    episode from the world's range, U(0, 1.8) m/s."""
    fig9_episodes: int = 500
    """Evaluation episodes per Fig. 9 cell (scene, behaviour, row, seed). Fig. 9 has 528
    cells (10 seeds, 4 behaviours) of 40 s episodes (measured on 2 cores: 13 s per 1000
    episodes of plain sp_rl in room_8, 18 s blended). Its CIs are over seeds; a seed's own binomial
    error at 500 episodes is at most 0.022 (in the full run, room_8's seeds of blended sp_rl
    on reactive spread less than that, 0.950-0.962, so there it is part of the CI)."""
    fig9_duration_s: float | None = None
    """Episode length of Fig. 9 (default: each scene's, 40 s as in the paper)."""
    vmap_seeds: bool = False
    """Train a (method, behaviour)'s seeds as one vmap-ped computation (--vmap-seeds;
    dyncatch.rl.seeds: equal to separate runs to float tolerance), or one by one in this
    process (the default), the later seeds reusing the first's compiled programs. On 2 CPU
    cores one by one is faster: a group of 10 seeds trains 0.81x as many samples a second as
    one seed, of 30 0.74x (docs/scaling.md); on a GPU a group fills the device (pass
    --vmap-seeds). The power run of 2026-12-03 and its replication were trained grouped."""
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
    probe_machine: bool = True
    """Before the first stage, time this machine against the one the estimate was fit on
    (``dyncatch bench machine``, about 5 s: its compute and its compilation apart) and print
    the estimate for both; ``results.json`` keeps the probe and the scaled estimate beside
    the measured stages. Not with ``--merge-parts`` (the parts ran elsewhere). Not recorded
    in plan.json."""
    part: BehaviorName | None = None
    """Run only this trained behaviour's part of the plan into --out
    (dyncatch.reproduce.parts: its predictors, runs, Table I row, Fig. 6 column, Fig. 9
    cells and videos; the transfer table in transfer_from's part, Table II in the first
    part), for machines whose sessions end before the whole plan would; --merge-parts then
    writes the whole report. Not recorded in plan.json (the part's own plan is)."""
    merge_parts: tuple[Path, ...] = ()
    """Folders of this plan's finished parts (--part), one per trained behaviour: their
    files are copied into --out (no checkpoints, no TensorBoard logs), their wall times
    summed, and the whole plan's report written from them."""
    ppo: PPOCfg = PPOCfg()
    """PPO hyper-parameters and batch geometry of every run."""
    world: WorldCfg = WorldCfg()
    """The simulated world of every stage."""

    @property
    def profile(self) -> str:
        return "quick" if self.quick else "power" if self.power else "full"

    @property
    def out_dir(self) -> Path:
        return self.out if self.out is not None else Path("results") / self.profile

    @property
    def fig6_columns(self) -> tuple[str, ...]:
        """The behaviours of Fig. 6 and the videos."""
        return self.fig6_behaviors if self.fig6_behaviors is not None else self.behaviors

    @property
    def table_i_rows(self) -> tuple[str, ...]:
        """The behaviours of Table I."""
        return self.table_i_behaviors if self.table_i_behaviors is not None else self.behaviors

    @property
    def fig9_columns(self) -> tuple[str, ...]:
        """The behaviours of Fig. 9."""
        return self.fig9_behaviors if self.fig9_behaviors is not None else self.behaviors

    @property
    def table_ii_rows(self) -> tuple[str, ...]:
        """The behaviours of Table II."""
        return self.table_ii_behaviors if self.table_ii_behaviors is not None else all_behaviors()

    @property
    def method_names(self) -> tuple[str, ...]:
        """The methods compared, in registry order."""
        return chosen(self.methods)

    @property
    def seed_ids(self) -> range:
        """The training seeds, ``first_seed`` onward."""
        return range(self.first_seed, self.first_seed + self.seeds)

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


ROUNDING_ONLY = ("vmap_seeds",)
"""Plan fields that move results by float rounding only: seeds trained as one vmap-ped
computation or one by one (docs/scaling.md, "Seeds in one jit": parameters equal to float
tolerance). Two seed sets, or two parts of one plan, may differ in them."""

NOT_RECORDED = (
    "out",
    "executor",
    "ray_address",
    "ray_workers",
    "ray_gpus_per_job",
    "probe_machine",
    "part",
    "merge_parts",
)
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
        # paper's central behaviour only, Fig. 6 on it (own behaviour: Table I's cells at
        # 1.8 m/s, no evaluation of its own; no transfer table), 0.5 M steps (the knee of
        # the full run's learning curves). Measured: docs/results.md.
        behaviors=("reactive",),
        table_i_behaviors=None,
        transfer_behaviors=(),
        train_steps=500_000,
        episodes=200,
        predictor_steps=500_000,
        predictor_updates=1500,
        table_ii_budgets=(100_000, 500_000),
        table_ii_eval_steps=100_000,
        # One scene, the one with the most obstacles (walls, occlusion, the scan and the
        # blend all act), on the trained behaviour: 4 cells, each compiled once, and one GIF.
        # Measured with two scenes (room_8, woods_rough): 98 s of the quick run's 11.8 min;
        # terrain is left to the full profile and the tests.
        fig9_scenes=("room_8",),
        fig9_behaviors=("reactive",),
        fig9_episodes=100,
    ),
    "power": Plan(
        power=True,
        seeds=30,
        methods=("rl", "sp_rl"),
        behaviors=("reactive", "random_reactive"),
        speeds_mps=(1.6, 1.8),
        transfer_behaviors=(),
        table_ii=False,
        videos=False,
        fig9=False,
    ),
}


def profile_default(plan: Plan) -> Plan:
    """The profile and readings a first parse of the command line asked for: the command
    line is parsed again on top of them, so every flag given overrides both."""

    return apply_readings(PROFILES[plan.profile], plan.setting)
