"""The stages of a reproduction. Each writes its result under the output folder and is
skipped when that result exists, so an interrupted run loses nothing finished: training
runs resume from their last checkpoint, evaluation cells are one small JSON file each.

Layout under ``out``::

    plan.json                              the plan (a different plan is refused)
    predictors/{behavior}_{kind}/          frozen predictors of p_rl / sp_rl
    table_ii/                              Table II (md, csv, png, json)
    runs/{behavior}/{method}/seed{s}/      training runs (checkpoint, metrics.csv, tb/, done.json)
    eval/table_i/{behavior}/{policy}.json  one evaluation cell list per policy
    eval/fig6/{behavior}/{policy}.json
    videos/sp_rl_{behavior}.gif
"""

from __future__ import annotations

import json
import os
import tempfile
from collections.abc import Callable
from pathlib import Path

from dyncatch.reproduce.plan import ALL_BEHAVIORS, BASELINES, EVALUATED, LEARNED, Plan

PREDICTOR_OF = {"p_rl": "vanilla", "sp_rl": "self_aware", "sp_fp": "self_aware"}
"""Which frozen predictor each method reads."""


def write_json(path: Path, obj) -> None:
    """Atomic JSON write (a crash leaves the old file or none, never half of one)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=path.name, suffix=".tmp")
    with os.fdopen(fd, "w") as f:
        json.dump(obj, f, indent=2)
    os.replace(tmp, path)


def cached(path: Path, compute: Callable[[], object]):
    if path.exists():
        return json.loads(path.read_text())
    value = compute()
    write_json(path, value)
    return value


def check_plan(out: Path, plan: Plan) -> None:
    """Record the plan; refuse to mix the results of two different plans in one folder."""
    path = out / "plan.json"
    want = json.loads(json.dumps(plan.to_json()))
    if path.exists():
        have = json.loads(path.read_text())
        if have != want:
            diff = sorted(k for k in want if have.get(k) != want[k])
            raise ValueError(
                f"{out} holds a reproduction with other {', '.join(diff)}; "
                "re-run with the same flags to resume, or choose another --out"
            )
    else:
        write_json(path, want)


def predictor_dir(out: Path, behavior: str, kind: str) -> Path:
    return out / "predictors" / f"{behavior}_{kind}"


def predictor_path(out: Path, behavior: str, method: str) -> Path | None:
    kind = PREDICTOR_OF.get(method)
    return None if kind is None else predictor_dir(out, behavior, kind) / "predictor.safetensors"


def run_dir(out: Path, behavior: str, method: str, seed: int) -> Path:
    return out / "runs" / behavior / method / f"seed{seed}"


def source_behavior(plan: Plan, behavior: str) -> str:
    """Behaviour whose policies are evaluated on ``behavior`` (its own if trained on it,
    else the first trained behaviour: Fig. 6's circle and bounce columns test transfer)."""
    return behavior if behavior in plan.behaviors else plan.behaviors[0]


def _predictor_train(plan: Plan):
    from dyncatch.predictor.config import TrainCfg

    return TrainCfg(updates=plan.predictor_updates, log_every=min(100, plan.predictor_updates))


def train_predictors(plan: Plan, out: Path, world) -> list[dict]:
    from dyncatch.cli.predictor import PredictorTrainCmd, run_predictor_train

    results = []
    for behavior in plan.behaviors:
        for kind in ("vanilla", "self_aware"):
            d = predictor_dir(out, behavior, kind)
            if not ((d / "metrics.json").exists() and (d / "predictor.safetensors").exists()):
                cmd = PredictorTrainCmd(
                    behavior=behavior,
                    kind=kind,
                    steps=plan.predictor_steps,
                    out=d,
                    eval_steps=plan.table_ii_eval_steps,
                    train=_predictor_train(plan),
                    world=world,
                )
                run_predictor_train(cmd)
            results.append(json.loads((d / "metrics.json").read_text()))
    return results


def table_ii(plan: Plan, out: Path, world) -> list[dict]:
    def compute():
        from dyncatch.predictor.config import CollectCfg, PredictorCfg
        from dyncatch.predictor.table import TableCfg, run_table, write

        table = TableCfg(
            ALL_BEHAVIORS,
            ("vanilla", "self_aware"),
            plan.table_ii_budgets,
            plan.table_ii_eval_steps,
            0,
        )
        train = _predictor_train(plan)
        rows = run_table(table, PredictorCfg(), train, CollectCfg(), world)
        write(rows, out / "table_ii")
        return rows

    return cached(out / "table_ii" / "table_ii.json", compute)


def train_policies(plan: Plan, out: Path, world, on_run: Callable[[str], None]) -> None:
    from dyncatch.cli.train import TrainCmd, run_train

    for behavior in plan.behaviors:
        for method in LEARNED:
            for seed in range(plan.seeds):
                d = run_dir(out, behavior, method, seed)
                if (d / "done.json").exists():
                    continue
                on_run(f"train {method} on {behavior}, seed {seed}")
                cmd = TrainCmd(
                    method=method,
                    behavior=behavior,
                    total_steps=plan.train_steps,
                    seed=seed,
                    out=d,
                    predictor=predictor_path(out, behavior, method),
                    resume=(d / "checkpoint.safetensors").exists(),
                    eval_speed_mps=plan.fig6_speed_mps,
                    ppo=plan.ppo,
                    world=world,
                )
                final = run_train(cmd)
                write_json(d / "done.json", final)


def policies(plan: Plan, out: Path, behavior: str, world):
    """(name, seed or None, loader) of every evaluated policy for a behaviour's runs."""
    from dyncatch.policies.registry import BASELINES as BASELINE_FACTORIES
    from dyncatch.rl.methods import METHODS
    from dyncatch.rl.policy import load_run

    src = source_behavior(plan, behavior)
    for method in EVALUATED:
        trained = METHODS[method].trained_as or method
        for seed in range(plan.seeds):

            def load(method=method, trained=trained, seed=seed):
                run = load_run(
                    run_dir(out, src, trained, seed), method, predictor_path(out, src, method)
                )
                return run.policy, run.world

            yield method, seed, load
    for name in BASELINES:
        yield name, None, lambda name=name: (BASELINE_FACTORIES[name](world), world)


def cell_name(method: str, seed: int | None) -> str:
    return method if seed is None else f"{method}_seed{seed}"


def evaluate_grid(
    plan: Plan, out: Path, world, table: str, behaviors, speeds, on_cell: Callable[[str], None]
) -> list[dict]:
    """Rows of (policy, seed, behaviour, speed) cells, each policy's cells cached together."""
    from dyncatch.evaluation.grid import evaluate_speeds

    rows = []
    for behavior in behaviors:
        for method, seed, load in policies(plan, out, behavior, world):
            path = out / "eval" / table / behavior / f"{cell_name(method, seed)}.json"

            def compute(load=load, method=method, behavior=behavior):
                on_cell(f"{table}: {method} on {behavior}")
                policy, w = load()
                return evaluate_speeds(policy, w, behavior, speeds, plan.episodes, 0, method)

            for r in cached(path, compute):
                rows.append({**r, "seed": seed, "trained_on": source_behavior(plan, behavior)})
    return rows


def record_videos(plan: Plan, out: Path, world) -> list[dict]:
    import jax

    from dyncatch.rl.policy import load_run
    from dyncatch.viz.render import render_frames, write_video
    from dyncatch.viz.trajectory import catch_time_s, record_episode

    clips = []
    for behavior in ALL_BEHAVIORS:
        path = out / "videos" / f"sp_rl_{behavior}.gif"
        meta = path.with_suffix(".json")

        def compute(behavior=behavior, path=path):
            src = source_behavior(plan, behavior)
            run = load_run(
                run_dir(out, src, "sp_rl", 0), "sp_rl", predictor_path(out, src, "sp_rl")
            )
            policy = run.policy
            cfg = run.world.with_behavior(behavior).with_speed(plan.fig6_speed_mps)

            def extra(state, obs):
                return {"pred_vel_mps": policy.obs_fn.velocity(state)[0]}

            traj = record_episode(policy, jax.random.key(0), cfg, extra_fn=extra)
            write_video(render_frames(traj, cfg, every=3, size_px=400), path, fps=17)
            t = catch_time_s(traj)
            return {
                "behavior": behavior,
                "trained_on": src,
                "speed_mps": plan.fig6_speed_mps,
                "file": str(path.relative_to(out)),
                "caught": t is not None,
                "catch_time_s": t,
            }

        clips.append(cached(meta, compute))
    return clips
