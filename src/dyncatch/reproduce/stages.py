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
    videos/{method}_{behavior}.gif         the filmed method (sp_rl)

Methods, baselines, predictor kinds and behaviours all come from their registries.
"""

from __future__ import annotations

import json
import os
import tempfile
from collections.abc import Callable
from pathlib import Path

from dyncatch.reproduce.plan import Plan
from dyncatch.rl.methods import METHODS, get_method, predictor_kinds, trained_methods
from dyncatch.utils.config_io import config_diff


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
    want = plan.to_json()
    if path.exists():
        have = json.loads(path.read_text())
        if have != want:
            diff = _real_diff(have, want)
            if not diff:  # only fields added since, at their defaults: same results
                write_json(path, want)
                return
            shown = ", ".join(f"{k} ({diff[k][0]} -> {diff[k][1]})" for k in list(diff)[:4])
            more = f" and {len(diff) - 4} more" if len(diff) > 4 else ""
            raise ValueError(
                f"{out} holds a reproduction with other {shown}{more}; "
                "re-run with the same flags to resume, or choose another --out"
            )
    else:
        write_json(path, want)


def _real_diff(have: dict, want: dict) -> dict:
    """The differing fields, leaving out those the recorded plan lacks whose new value is
    the field's default: a field added to the code later defaults to the behaviour the
    code had before it existed (the repository's convention), so a cached study made
    before it still holds. A field removed since, or one set away from its default, counts."""
    from dyncatch.utils.config_io import flatten

    defaults = flatten(Plan().to_json())
    known = flatten(have)
    return {
        k: v
        for k, v in config_diff(have, want).items()
        if k in known or k not in defaults or v[1] != defaults[k]
    }


def predictor_dir(out: Path, behavior: str, kind: str) -> Path:
    return out / "predictors" / f"{behavior}_{kind}"


def predictor_path(out: Path, behavior: str, method: str) -> Path | None:
    """The frozen predictor ``method`` reads for ``behavior``'s runs (None if it reads none)."""
    kind = get_method(method).predictor_kind
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


def train_predictors(plan: Plan, out: Path, progress=None) -> list[dict]:
    from dyncatch.predictor.pipeline import PredictorTrainCfg, train_predictor

    results = []
    for behavior in plan.behaviors:
        for kind in predictor_kinds():
            d = predictor_dir(out, behavior, kind)
            if not ((d / "metrics.json").exists() and (d / "predictor.safetensors").exists()):
                cfg = PredictorTrainCfg(
                    behavior=behavior,
                    kind=kind,
                    steps=plan.predictor_steps,
                    out=d,
                    eval_steps=plan.table_ii_eval_steps,
                    train=_predictor_train(plan),
                    world=plan.world,
                )
                train_predictor(cfg, progress)
            results.append(json.loads((d / "metrics.json").read_text()))
    return results


def table_ii(plan: Plan, out: Path) -> list[dict]:
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

    return cached(out / "table_ii" / "table_ii.json", compute)


def train_policies(plan: Plan, out: Path, on_run: Callable[[str], None], progress=None) -> None:
    from dyncatch.rl.runner import TrainRunCfg, TrainRunner

    for behavior in plan.behaviors:
        for method in trained_methods():
            for seed in range(plan.seeds):
                d = run_dir(out, behavior, method, seed)
                if (d / "done.json").exists():
                    continue
                on_run(f"train {method} on {behavior}, seed {seed}")
                cfg = TrainRunCfg(
                    method=method,
                    behavior=behavior,
                    total_steps=plan.train_steps,
                    seed=seed,
                    out=d,
                    predictor=predictor_path(out, behavior, method),
                    resume=(d / "checkpoint.safetensors").exists(),
                    eval_speed_mps=plan.fig6_speed_mps,
                    ppo=plan.ppo,
                    world=plan.world,
                )
                final = TrainRunner(cfg).learn(progress)
                write_json(d / "done.json", final)


def policies(plan: Plan, out: Path, behavior: str):
    """(name, seed or None, loader) of every evaluated policy for a behaviour's runs: each
    method of the registry over seeds, then each baseline."""
    from dyncatch.policies.registry import BASELINES
    from dyncatch.rl.policy import load_run

    src = source_behavior(plan, behavior)
    for method, m in METHODS.items():
        for seed in range(plan.seeds):

            def load(method=method, trained=m.policy_source, seed=seed):
                run = load_run(
                    run_dir(out, src, trained, seed), method, predictor_path(out, src, method)
                )
                return run.policy, run.world

            yield method, seed, load
    for name, baseline in BASELINES.items():
        yield name, None, lambda b=baseline: (b(plan.world), plan.world)


def cell_name(method: str, seed: int | None) -> str:
    return method if seed is None else f"{method}_seed{seed}"


def evaluate_grid(
    plan: Plan, out: Path, table: str, behaviors, speeds, on_cell: Callable[[str], None]
) -> list[dict]:
    """Rows of (policy, seed, behaviour, speed) cells, each policy's cells cached together."""
    from dyncatch.evaluation.grid import evaluate_speeds

    rows = []
    for behavior in behaviors:
        for method, seed, load in policies(plan, out, behavior):
            path = out / "eval" / table / behavior / f"{cell_name(method, seed)}.json"

            def compute(load=load, method=method, behavior=behavior):
                on_cell(f"{table}: {method} on {behavior}")
                policy, w = load()
                return evaluate_speeds(policy, w, behavior, speeds, plan.episodes, 0, method)

            for r in cached(path, compute):
                rows.append({**r, "seed": seed, "trained_on": source_behavior(plan, behavior)})
    return rows


def filmed_methods() -> tuple[str, ...]:
    return tuple(name for name, m in METHODS.items() if m.filmed)


def record_videos(plan: Plan, out: Path) -> list[dict]:
    import jax

    from dyncatch.rl.policy import load_run
    from dyncatch.viz.render import render_frames, write_video
    from dyncatch.viz.trajectory import catch_time_s, record_episode

    clips = []
    for method in filmed_methods():
        for behavior in plan.fig6_columns:
            path = out / "videos" / f"{method}_{behavior}.gif"

            def compute(method=method, behavior=behavior, path=path):
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

            clips.append(cached(path.with_suffix(".json"), compute))
    return clips
