"""The stages of a reproduction. Each writes its result under the output folder
(``layout.py``) and is skipped when that result exists, so an interrupted run loses nothing
finished: training runs resume from their last checkpoint, evaluation cells are one small
JSON file each.

Each stage is a list of independent ``Job``s (one predictor, one seed group's training,
one policy's evaluation cells, one video), built only for what is not finished, and run by
an executor (``dyncatch.reproduce.executors``: in this process, or as Ray tasks); then the
stage reads its results back from the files, so the report is the same whoever ran them.

Methods, baselines, predictor kinds and behaviours all come from their registries.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from dyncatch.reproduce.layout import (
    cached,
    cell_path,
    predictor_dir,
    predictor_path,
    run_dir,
    source_behavior,
    write_json,
)
from dyncatch.reproduce.plan import Plan
from dyncatch.rl.methods import METHODS, get_method, predictor_kinds, trained_methods


@dataclass(frozen=True)
class Job:
    """One independent piece of a stage: ``fn(*args, progress=None)`` writes its outputs
    under the results folder, atomically or behind a completion marker, and returns
    nothing. ``fn`` is a module-level function and ``args`` plain values, so a Ray worker
    can run it; running it again after it finished, or after it died, is safe."""

    name: str
    fn: Callable[..., None]
    args: tuple

    def __call__(self, progress=None) -> None:
        try:
            self.fn(*self.args, progress=progress)
        finally:
            release_compiled()


MAPPINGS_RELEASE_FRACTION = 0.5
"""A job releases the compiled programs once the process holds this fraction of the
kernel's limit on memory mappings (``release_compiled``)."""


def _mappings() -> tuple[int, int] | None:
    """(memory mappings this process holds, the kernel's limit), where Linux tells."""
    try:
        with open("/proc/self/maps") as f:
            held = sum(1 for _ in f)
        with open("/proc/sys/vm/max_map_count") as f:
            return held, int(f.read())
    except (OSError, ValueError):
        return None


def release_compiled() -> None:
    """Drop JAX's in-memory compiled programs (the persistent cache on disk keeps them)
    once the process nears the kernel's limit on memory mappings (or always, where the
    count cannot be read).

    Each XLA:CPU executable holds memory mappings of its own, and a process that compiles
    job after job keeps every one: a full reproduction (about 200 Fig. 9 cells, each its
    own program) reached ``vm.max_map_count`` (65530) and died with "LLVM compilation
    error: Cannot allocate memory" after 2 h. After a release the count falls to a few
    thousand, and a program needed again is loaded back from the persistent cache
    (measured: Fig. 9 cells took the same 11 s each). Releasing after every job instead
    made the test suite's tiny reproduction recompile what its jobs share: 168 s against
    132 s."""
    import jax

    counts = _mappings()
    if counts is None or counts[0] >= MAPPINGS_RELEASE_FRACTION * counts[1]:
        jax.clear_caches()


def _predictor_train(plan: Plan):
    from dyncatch.predictor.config import TrainCfg

    return TrainCfg(updates=plan.predictor_updates, log_every=min(100, plan.predictor_updates))


def _predictor_done(d: Path) -> bool:
    return (d / "metrics.json").exists() and (d / "predictor.safetensors").exists()


def _predictor_job(plan: Plan, out: Path, behavior: str, kind: str, progress=None) -> None:
    from dyncatch.predictor.pipeline import PredictorTrainCfg, train_predictor
    from dyncatch.predictor.tracker.config import TrackerTrainCfg

    d = predictor_dir(out, behavior, kind)
    if _predictor_done(d):
        return
    train = _predictor_train(plan)
    cfg = PredictorTrainCfg(
        kind=kind,
        steps=plan.predictor_steps,
        out=d,
        eval_steps=plan.table_ii_eval_steps,
        train=train,
        world=plan.world.with_behavior(behavior),
        tracker_train=TrackerTrainCfg(updates=train.updates, log_every=train.log_every),
    )
    train_predictor(cfg, progress)


def train_predictors(plan: Plan, out: Path, executor) -> list[dict]:
    pairs = [(b, k) for b in plan.behaviors for k in predictor_kinds(plan.method_names)]
    executor.run(
        [
            Job(f"predictor {kind} on {behavior}", _predictor_job, (plan, out, behavior, kind))
            for behavior, kind in pairs
            if not _predictor_done(predictor_dir(out, behavior, kind))
        ]
    )
    return [json.loads((predictor_dir(out, b, k) / "metrics.json").read_text()) for b, k in pairs]


def _table_ii_job(plan: Plan, out: Path, progress=None) -> None:
    def compute():
        from dyncatch.predictor.config import CollectCfg, PredictorCfg
        from dyncatch.predictor.table import TableCfg, run_table, write

        table = TableCfg(
            behaviors=plan.table_ii_rows,
            budgets=plan.table_ii_budgets,
            eval_steps=plan.table_ii_eval_steps,
        )
        train = _predictor_train(plan)
        rows = run_table(table, PredictorCfg(), train, CollectCfg(), plan.world)
        write(rows, out / "table_ii")
        return rows

    cached(out / "table_ii" / "table_ii.json", compute)


def table_ii(plan: Plan, out: Path, executor) -> list[dict]:
    path = out / "table_ii" / "table_ii.json"
    if not path.exists():
        executor.run([Job("Table II", _table_ii_job, (plan, out))])
    return json.loads(path.read_text())


def run_cfg(plan: Plan, out: Path, behavior: str, method: str, seed: int):
    """The training run of (behaviour, method, seed), resuming its checkpoint if one exists
    (read when the job starts, so a retried job continues where the dead one saved)."""
    from dyncatch.rl.runner import TrainRunCfg

    d = run_dir(out, behavior, method, seed)
    return TrainRunCfg(
        method=method,
        total_steps=plan.train_steps,
        seed=seed,
        out=d,
        predictor=predictor_path(out, behavior, method),
        resume=(d / "checkpoint.safetensors").exists(),
        eval_speed_mps=plan.fig6_speed_mps,
        ppo=plan.ppo,
        world=plan.world.with_behavior(behavior),
    )


def _run_done(out: Path, behavior: str, method: str, seed: int) -> bool:
    return (run_dir(out, behavior, method, seed) / "done.json").exists()


def _train_job(
    plan: Plan, out: Path, behavior: str, method: str, seeds: tuple[int, ...], progress=None
) -> None:
    """Train the unfinished ``seeds`` of (behaviour, method): one vmap-ped group with
    ``plan.vmap_seeds`` and more than one seed, else one ``TrainRunner``."""
    from dyncatch.rl.runner import TrainRunner
    from dyncatch.rl.seeds import SeedGroupRunner

    seeds = tuple(s for s in seeds if not _run_done(out, behavior, method, s))
    cfgs = [run_cfg(plan, out, behavior, method, s) for s in seeds]
    if len(cfgs) > 1:
        finals = SeedGroupRunner(cfgs).learn(progress)
    else:
        finals = [TrainRunner(c).learn(progress) for c in cfgs]
    for cfg, final in zip(cfgs, finals, strict=True):
        write_json(cfg.out / "done.json", final)


def train_policies(plan: Plan, out: Path, executor) -> None:
    jobs = []
    for behavior in plan.behaviors:
        for method in trained_methods(plan.method_names):
            todo = [s for s in range(plan.seeds) if not _run_done(out, behavior, method, s)]
            groups = [tuple(todo)] if plan.vmap_seeds and todo else [(s,) for s in todo]
            for seeds in groups:
                name = f"train {method} on {behavior}, seed{'s' * (len(seeds) > 1)} "
                name += ", ".join(map(str, seeds))
                jobs.append(Job(name, _train_job, (plan, out, behavior, method, seeds)))
    executor.run(jobs)


def policies(plan: Plan) -> list[tuple[str, int | None]]:
    """(name, seed or None) of every evaluated policy: each method compared over seeds,
    then each baseline."""
    from dyncatch.policies.registry import BASELINES

    methods = [(m, s) for m in plan.method_names for s in range(plan.seeds)]
    return methods + [(b, None) for b in BASELINES]


def load_policy(plan: Plan, out: Path, behavior: str, name: str, seed: int | None):
    """(policy, world) of a method's seed trained for ``behavior``'s runs, or a baseline."""
    from dyncatch.policies.registry import BASELINES
    from dyncatch.rl.policy import load_run

    if seed is None:
        return BASELINES[name](plan.world), plan.world
    src = source_behavior(plan, behavior)
    trained = METHODS[name].policy_source
    run = load_run(run_dir(out, src, trained, seed), name, predictor_path(out, src, name))
    return run.policy, run.world


def _eval_job(
    plan: Plan,
    out: Path,
    table: str,
    behavior: str,
    method: str,
    seed: int | None,
    speeds: tuple[float, ...],
    progress=None,
) -> None:
    from dyncatch.evaluation.grid import evaluate_speeds

    def compute():
        policy, w = load_policy(plan, out, behavior, method, seed)
        return evaluate_speeds(policy, w, behavior, speeds, plan.episodes, 0, method)

    cached(cell_path(out, table, behavior, method, seed), compute)


def evaluate_grid(plan: Plan, out: Path, table: str, behaviors, speeds, executor) -> list[dict]:
    """Rows of (policy, seed, behaviour, speed) cells, each policy's cells cached together."""
    cells = [(b, m, s) for b in behaviors for m, s in policies(plan)]
    executor.run(
        [
            Job(
                f"{table}: {m}{'' if s is None else f' seed {s}'} on {b}",
                _eval_job,
                (plan, out, table, b, m, s, tuple(speeds)),
            )
            for b, m, s in cells
            if not cell_path(out, table, b, m, s).exists()
        ]
    )
    rows = []
    for b, m, s in cells:
        for r in json.loads(cell_path(out, table, b, m, s).read_text()):
            rows.append({**r, "seed": s, "trained_on": source_behavior(plan, b)})
    return rows


def fig6_grid(plan: Plan, out: Path, table_i_rows: list[dict], executor) -> list[dict]:
    """Fig. 6's rows: every policy at ``fig6_speed_mps`` on each of its columns. A column that
    is a Table I row, when Fig. 6's speed is a Table I speed, takes Table I's cells there (the
    same policies, behaviour, speed and episode count; evaluating them again would only draw
    other episodes); the other columns are evaluated (``evaluate_grid``)."""
    speed = plan.fig6_speed_mps
    rest = fig6_evaluated_columns(plan)
    evaluated = evaluate_grid(plan, out, "fig6", rest, (speed,), executor) if rest else []
    rows = []
    for b in plan.fig6_columns:
        source = evaluated if b in rest else table_i_rows
        rows += [r for r in source if r["behavior"] == b and abs(r["speed_mps"] - speed) < 1e-9]
    return rows


def fig6_evaluated_columns(plan: Plan) -> tuple[str, ...]:
    """The Fig. 6 columns ``fig6_grid`` evaluates (the others reuse Table I's cells)."""
    if not any(abs(plan.fig6_speed_mps - v) < 1e-9 for v in plan.speeds_mps):
        return plan.fig6_columns
    return tuple(b for b in plan.fig6_columns if b not in plan.table_i_rows)


def filmed_methods(plan: Plan) -> tuple[str, ...]:
    return tuple(name for name in plan.method_names if METHODS[name].filmed)


def _video_job(plan: Plan, out: Path, method: str, behavior: str, progress=None) -> None:
    import jax

    from dyncatch.rl.policy import load_run
    from dyncatch.viz.render import render_frames, write_video
    from dyncatch.viz.trajectory import catch_time_s, record_episode

    path = out / "videos" / f"{method}_{behavior}.gif"

    def compute():
        src = source_behavior(plan, behavior)
        m = get_method(method)
        run = load_run(
            run_dir(out, src, m.policy_source, 0), method, predictor_path(out, src, method)
        )
        policy = run.policy
        cfg = run.world.with_behavior(behavior).with_speed(plan.fig6_speed_mps)

        def extra(state, obs):
            return {"pred_vel_mps": policy.obs_fn.velocity(state)[0]}

        extra_fn = extra if m.velocity_input is not None else None
        traj = record_episode(policy, jax.random.key(0), cfg, extra_fn=extra_fn)
        write_video(render_frames(traj, cfg, every=3, size_px=400), path, fps=17)
        t = catch_time_s(traj)
        return {
            "method": method,
            "behavior": behavior,
            "trained_on": src,
            "speed_mps": plan.fig6_speed_mps,
            "file": str(path.relative_to(out)),
            "caught": t is not None,
            "catch_time_s": t,
        }

    cached(path.with_suffix(".json"), compute)


def record_videos(plan: Plan, out: Path, executor) -> list[dict]:
    clips = [(m, b) for m in filmed_methods(plan) for b in plan.fig6_columns]
    path = lambda m, b: out / "videos" / f"{m}_{b}.json"  # noqa: E731
    executor.run(
        [
            Job(f"video {m} on {b}", _video_job, (plan, out, m, b))
            for m, b in clips
            if not path(m, b).exists()
        ]
    )
    return [json.loads(path(m, b).read_text()) for m, b in clips]
