"""The stages of a reproduction, in order: ``STAGES``.

Each stage writes its result under the output folder (``layout.py``) and is skipped when
that result exists, so an interrupted run loses nothing finished: training runs resume from
their last checkpoint, evaluation cells are one small JSON file each. A stage's ``jobs``
are the typed job specs (``jobs.py``) of what is unfinished, run by an executor
(``executors.py``: in this process, or as Ray tasks); its ``collect`` reads its results
back from the files, so the report is the same whoever ran them. A stage names the folders
it reads and writes (``inputs``, ``outputs``: each input is an earlier stage's output) and
estimates its wall time (``estimate.py``).

Methods, baselines, predictor kinds and behaviours all come from their registries.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from dyncatch.bench.speed_probe import REFERENCE, MachineSpeed
from dyncatch.policies.registry import BASELINES
from dyncatch.predictor.config import TrainCfg
from dyncatch.predictor.pipeline import PredictorTrainCfg
from dyncatch.predictor.table import TableCfg
from dyncatch.predictor.tracker.config import TrackerTrainCfg
from dyncatch.reproduce import estimate, fig9
from dyncatch.reproduce.jobs import (
    EvalCell,
    EvalJob,
    Job,
    PredictorJob,
    TableIIJob,
    TrainJob,
    VideoJob,
    policy_spec,
    predictor_done,
    run_done,
)
from dyncatch.reproduce.layout import (
    cell_path,
    fig6_evaluated_columns,
    predictor_dir,
    predictor_path,
    run_dir,
    source_behavior,
)
from dyncatch.reproduce.plan import Plan
from dyncatch.reproduce.presentation import filmed_methods
from dyncatch.rl.methods import predictor_kinds, trained_methods
from dyncatch.rl.runner import TrainRunCfg
from dyncatch.utils.files import read_json


@dataclass(frozen=True)
class Stage:
    """One step of a reproduction."""

    name: str
    """The key of its result in ``run``'s outputs."""
    title: str
    """What the log calls it."""
    inputs: tuple[str, ...]
    """Folders under the results folder it reads (written by earlier stages)."""
    outputs: tuple[str, ...]
    """Folders (or file prefixes) under the results folder it writes."""
    jobs: Callable[[Plan, Path], list[Job]]
    """The jobs of what is unfinished."""
    collect: Callable[[Plan, Path], object]
    """Its result, read back from the files once its jobs ran."""
    estimate: Callable[..., float]
    """Wall seconds of the whole stage: ``estimate(plan)`` on the reference machine (2
    cores), ``estimate(plan, speed)`` on a machine of that ``MachineSpeed``."""
    enabled: Callable[[Plan], bool] = lambda plan: True


def _predictor_train(plan: Plan) -> TrainCfg:
    return TrainCfg(updates=plan.predictor_updates, log_every=min(100, plan.predictor_updates))


def _predictor_pairs(plan: Plan) -> list[tuple[str, str]]:
    return [(b, k) for b in plan.behaviors for k in predictor_kinds(plan.method_names)]


def predictor_jobs(plan: Plan, out: Path) -> list[Job]:
    train = _predictor_train(plan)
    tracker = TrackerTrainCfg(updates=train.updates, log_every=train.log_every)
    jobs = []
    for behavior, kind in _predictor_pairs(plan):
        d = predictor_dir(out, behavior, kind)
        if not predictor_done(d):
            cfg = PredictorTrainCfg(
                kind=kind,
                steps=plan.predictor_steps,
                out=d,
                eval_steps=plan.table_ii_eval_steps,
                train=train,
                world=plan.world.with_behavior(behavior),
                tracker_train=tracker,
                seed=plan.first_seed,
            )
            jobs.append(PredictorJob(cfg))
    return jobs


def predictor_metrics(plan: Plan, out: Path) -> list[dict]:
    return [read_json(predictor_dir(out, b, k) / "metrics.json") for b, k in _predictor_pairs(plan)]


def table_ii_jobs(plan: Plan, out: Path) -> list[Job]:
    if (out / "table_ii" / "table_ii.json").exists():
        return []
    table = TableCfg(
        behaviors=plan.table_ii_rows,
        budgets=plan.table_ii_budgets,
        eval_steps=plan.table_ii_eval_steps,
    )
    return [TableIIJob(table, _predictor_train(plan), plan.world, out / "table_ii")]


def table_ii_rows(plan: Plan, out: Path) -> list[dict]:
    return read_json(out / "table_ii" / "table_ii.json")


def run_cfg(plan: Plan, out: Path, behavior: str, method: str, seed: int) -> TrainRunCfg:
    """The training run of (behaviour, method, seed); ``TrainJob`` sets ``resume``."""
    return TrainRunCfg(
        method=method,
        total_steps=plan.train_steps,
        seed=seed,
        out=run_dir(out, behavior, method, seed),
        predictor=predictor_path(out, behavior, method),
        resume=False,
        eval_speed_mps=plan.fig6_speed_mps,
        ground_truth=plan.ground_truth,
        ppo=plan.ppo,
        world=plan.world.with_behavior(behavior),
    )


def train_jobs(plan: Plan, out: Path) -> list[Job]:
    """A job per (behaviour, method): its unfinished seeds as one vmap-ped group, or with
    ``--no-vmap-seeds`` a job per seed."""
    jobs = []
    for behavior in plan.behaviors:
        for method in trained_methods(plan.method_names):
            cfgs = [run_cfg(plan, out, behavior, method, s) for s in plan.seed_ids]
            todo = tuple(c for c in cfgs if not run_done(c))
            groups = [todo] if plan.vmap_seeds and todo else [(c,) for c in todo]
            jobs += [TrainJob(g) for g in groups]
    return jobs


def policies(plan: Plan, table: str | None = None) -> list[tuple[str, int | None]]:
    """(name, seed or None) of every evaluated policy: each method compared over seeds,
    then each baseline (not in the transfer table: a baseline is trained on nothing, and
    its cells on a behaviour are Fig. 6's)."""
    methods = [(m, s) for m in plan.method_names for s in plan.seed_ids]
    return methods + ([] if table == "transfer" else [(b, None) for b in BASELINES])


def grid_jobs(plan: Plan, out: Path, table: str, behaviors, speeds) -> list[Job]:
    """A job per (behaviour, policy name) with the cells (one file per seed, each one
    per speed) not cached: a method's seeds share its compiled evaluation."""
    jobs = []
    for b in behaviors:
        names = dict.fromkeys(m for m, _ in policies(plan, table))
        for name in names:
            cells = tuple(
                EvalCell(cell_path(out, table, b, m, s), policy_spec(plan, out, b, m, s, table))
                for m, s in policies(plan, table)
                if m == name and not cell_path(out, table, b, m, s).exists()
            )
            if cells:
                jobs.append(EvalJob(table, b, cells, tuple(speeds), plan.episodes))
    return jobs


def grid_rows(plan: Plan, out: Path, table: str, behaviors) -> list[dict]:
    """Rows of (policy, seed, behaviour, speed) cells, read back, each with the behaviour
    its policy was trained on (None: a baseline)."""
    rows = []
    for b in behaviors:
        for m, s in policies(plan, table):
            src = None if s is None else source_behavior(plan, b, table)
            for r in read_json(cell_path(out, table, b, m, s)):
                rows.append({**r, "seed": s, "trained_on": src})
    return rows


def table_i_jobs(plan: Plan, out: Path) -> list[Job]:
    return grid_jobs(plan, out, "table_i", plan.table_i_rows, plan.speeds_mps)


def table_i_rows(plan: Plan, out: Path) -> list[dict]:
    return grid_rows(plan, out, "table_i", plan.table_i_rows)


def fig6_jobs(plan: Plan, out: Path) -> list[Job]:
    rest = fig6_evaluated_columns(plan)
    return grid_jobs(plan, out, "fig6", rest, (plan.fig6_speed_mps,)) if rest else []


def fig6_rows(plan: Plan, out: Path) -> list[dict]:
    """Fig. 6's rows: every policy at ``fig6_speed_mps`` on each of its columns, from
    Table I's cells where it has them (``fig6_evaluated_columns``)."""
    speed = plan.fig6_speed_mps
    rest = fig6_evaluated_columns(plan)
    evaluated = grid_rows(plan, out, "fig6", rest) if rest else []
    table_i = table_i_rows(plan, out) if len(rest) < len(plan.fig6_columns) else []
    rows = []
    for b in plan.fig6_columns:
        source = evaluated if b in rest else table_i
        rows += [r for r in source if r["behavior"] == b and abs(r["speed_mps"] - speed) < 1e-9]
    return rows


def transfer_jobs(plan: Plan, out: Path) -> list[Job]:
    """The transfer table's cells: ``transfer_from``'s trained policies (with its
    predictors) at ``fig6_speed_mps`` on each of ``transfer_behaviors``."""
    speeds = (plan.fig6_speed_mps,)
    return grid_jobs(plan, out, "transfer", plan.transfer_behaviors, speeds)


def transfer_rows(plan: Plan, out: Path) -> list[dict]:
    return grid_rows(plan, out, "transfer", plan.transfer_behaviors)


def _clips(plan: Plan) -> list[tuple[str, str]]:
    return [(m, b) for m in filmed_methods(plan.method_names) for b in plan.fig6_columns]


def _clip_json(out: Path, method: str, behavior: str) -> Path:
    return out / "videos" / f"{method}_{behavior}.json"


def video_jobs(plan: Plan, out: Path) -> list[Job]:
    return [
        VideoJob(
            out,
            b,
            source_behavior(plan, b),
            plan.fig6_speed_mps,
            policy_spec(plan, out, b, m, plan.first_seed),
        )
        for m, b in _clips(plan)
        if not _clip_json(out, m, b).exists()
    ]


def video_clips(plan: Plan, out: Path) -> list[dict]:
    return [read_json(_clip_json(out, m, b)) for m, b in _clips(plan)]


STAGES: tuple[Stage, ...] = (
    Stage(
        "predictors",
        "frozen predictors",
        (),
        ("predictors",),
        predictor_jobs,
        predictor_metrics,
        estimate.predictors_s,
    ),
    Stage(
        "table_ii",
        "Table II",
        (),
        ("table_ii",),
        table_ii_jobs,
        table_ii_rows,
        estimate.table_ii_s,
        lambda plan: plan.table_ii,
    ),
    Stage(
        "training",
        "training runs",
        ("predictors",),
        ("runs",),
        train_jobs,
        lambda plan, out: None,
        estimate.training_s,
    ),
    Stage(
        "table_i",
        "Table I evaluation",
        ("runs", "predictors"),
        ("eval/table_i",),
        table_i_jobs,
        table_i_rows,
        estimate.table_i_s,
    ),
    Stage(
        "fig6",
        "Fig. 6 evaluation",
        ("runs", "predictors", "eval/table_i"),
        ("eval/fig6",),
        fig6_jobs,
        fig6_rows,
        estimate.fig6_s,
    ),
    Stage(
        "transfer",
        "transfer (policies trained on one behaviour, tested on others)",
        ("runs", "predictors"),
        ("eval/transfer",),
        transfer_jobs,
        transfer_rows,
        estimate.transfer_s,
        lambda plan: bool(plan.transfer_behaviors),
    ),
    Stage(
        "videos",
        "videos",
        ("runs", "predictors"),
        ("videos",),
        video_jobs,
        video_clips,
        estimate.videos_s,
        lambda plan: plan.videos,
    ),
    Stage(
        "fig9",
        "Fig. 9 (rooms and woods)",
        ("runs", "predictors"),
        ("eval/fig9",),
        fig9.cell_jobs,
        fig9.cell_rows,
        estimate.fig9_s,
        lambda plan: plan.fig9,
    ),
    Stage(
        "fig9_videos",
        "Fig. 9 videos",
        ("runs", "predictors"),
        ("videos",),
        fig9.video_jobs,
        fig9.videos,
        estimate.fig9_videos_s,
        lambda plan: plan.fig9 and plan.videos,
    ),
)
"""Every stage, in the order they run (each reads what the ones before it wrote)."""


def stages_of(plan: Plan) -> tuple[Stage, ...]:
    """The stages ``plan`` runs."""
    return tuple(s for s in STAGES if s.enabled(plan))


def estimate_s(plan: Plan, speed: MachineSpeed = REFERENCE) -> float:
    """A rough wall-time estimate (seconds) for the whole plan on the reference machine's 2
    cores, or on a machine of ``speed`` (``bench.speed_probe``)."""
    return sum(s.estimate(plan, speed) for s in stages_of(plan))
