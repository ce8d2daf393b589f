"""The PPO issue's learning targets, measured on this machine.

1. Time to >= 0.90 success of ``sp_rl`` on reactive targets at 1.8 m/s (periodic evaluations
   of the mean-action policy during training; wall seconds include compilation and exclude
   the evaluations themselves).
2. ``rl`` vs ``sp_rl`` (vs ``p_rl`` with ``--methods``) vs the ``intercept`` and ``pursuit``
   baselines at 1.6 and 1.8 m/s, 1000 evaluation episodes per cell, on evaluation seeds
   disjoint from training.

Every stage is cached under ``--out`` (a finished run has ``done.json``), so re-running
only redoes what is missing. Writes ``summary.md``, ``summary.json`` and ``curves.png``.

    .venv/bin/python benchmarks/ppo_targets.py --out results/ppo_targets --total-steps 6000000
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

from dyncatch.evaluation.grid import evaluate_speeds
from dyncatch.predictor.pipeline import PredictorTrainCfg, train_predictor
from dyncatch.reproduce.layout import write_json
from dyncatch.reproduce.report import color, label, read_curve
from dyncatch.reproduce.summary import time_to_success
from dyncatch.rl.config import PPOCfg
from dyncatch.rl.methods import get_method
from dyncatch.rl.resolve import resolve_policy
from dyncatch.rl.runner import TrainRunCfg, TrainRunner
from dyncatch.sim.config import WorldCfg

WORLD = WorldCfg().with_behavior("reactive")


def predictor_for(out: Path, method: str, steps: int) -> Path | None:
    kind = get_method(method).predictor_kind
    if kind is None:
        return None
    d = out / f"predictor_{kind}"
    path = d / "predictor.safetensors"
    if not (d / "metrics.json").exists():
        train_predictor(PredictorTrainCfg(kind=kind, steps=steps, out=d, world=WORLD))
    return path


def train(out: Path, method: str, args) -> dict:
    d = out / method
    if not (d / "done.json").exists():
        cfg = TrainRunCfg(
            method=method,
            world=WORLD,
            total_steps=args.total_steps,
            seed=args.seed,
            out=d,
            predictor=predictor_for(out, method, args.predictor_steps),
            resume=(d / "checkpoint.safetensors").exists(),
            eval_speed_mps=1.8,
            ppo=PPOCfg(
                num_envs=args.num_envs,
                num_steps=args.num_steps,
                num_minibatches=args.num_minibatches,
            ),
        )
        write_json(d / "done.json", TrainRunner(cfg).learn())
    curve = read_curve(d)
    return {
        "method": method,
        "to_0.9": time_to_success(curve, 0.9),
        "final_eval_success_rate": float(curve["eval_success_rate"][-1]),
        "best_eval_success_rate": float(curve["eval_success_rate"].max()),
        "wall_s": float(curve["time_s"][-1]),
        "samples_per_s": float(curve["env_steps"][-1] / curve["time_s"][-1]),
        "curve": {k: v.tolist() for k, v in curve.items() if k.startswith("eval_")},
    }


def evaluate(out: Path, policy: str, episodes: int) -> list[dict]:
    path = out / "eval" / f"{policy}.json"
    if not path.exists():
        target = str(out / policy) if (out / policy).exists() else policy
        pol, _, trained_world = resolve_policy(target, WorldCfg())
        world = trained_world or WorldCfg()
        rows = evaluate_speeds(pol, world, "reactive", (1.6, 1.8), episodes, 0, policy)
        write_json(path, rows)
    return json.loads(path.read_text())


def plot(runs: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (ax_t, ax_s) = plt.subplots(1, 2, figsize=(11, 4))
    for r in runs:
        c = r["curve"]
        style = {"color": color(r["method"]), "label": label(r["method"])}
        ax_t.plot([t / 60 for t in c["eval_time_s"]], c["eval_success_rate"], **style)
        ax_s.plot([s / 1e6 for s in c["eval_env_steps"]], c["eval_success_rate"], **style)
    for ax, xlabel in ((ax_t, "training wall time (min, 2 CPU cores)"), (ax_s, "samples (M)")):
        ax.axhline(0.9, color="grey", ls="--", lw=0.8)
        ax.set_xlabel(xlabel)
        ax.set_ylabel("success at 1.8 m/s (evaluation)")
        ax.set_ylim(0, 1.02)
        ax.grid(alpha=0.3)
    ax_t.axvline(15, color="grey", ls=":", lw=0.8)
    ax_s.legend()
    fig.suptitle("PPO on reactive targets (speed 0.8-1.8 m/s in training)")
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def summary_markdown(runs: list[dict], rows: list[dict]) -> str:
    lines = [
        "| method | samples to 0.9 | wall to 0.9 | best / final success | samples/s |",
        "|---|---:|---:|---:|---:|",
    ]
    for r in runs:
        hit = r["to_0.9"]
        s = "never" if hit["samples"] is None else f"{hit['samples'] / 1e6:.2f} M"
        w = "never" if hit["time_s"] is None else f"{hit['time_s'] / 60:.1f} min"
        lines.append(
            f"| {r['method']} | {s} | {w} | {r['best_eval_success_rate']:.3f} / "
            f"{r['final_eval_success_rate']:.3f} | {r['samples_per_s']:,.0f} |"
        )
    lines += [
        "",
        "| policy | speed (m/s) | success [95 % CI] | catch time (s) |",
        "|---|---:|---|---:|",
    ]
    for r in rows:
        lo, hi = r["success_ci95"]
        lines.append(
            f"| {r['method']} | {r['speed_mps']:.1f} | {r['success_rate']:.3f} "
            f"[{lo:.3f}, {hi:.3f}] | {r['catch_time_s']:.2f} |"
        )
    return "\n".join(lines) + "\n"


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--out", type=Path, default=Path("results/ppo_targets"))
    p.add_argument("--methods", nargs="+", default=["sp_rl", "rl"])
    p.add_argument("--total-steps", type=int, default=6_000_000)
    p.add_argument("--predictor-steps", type=int, default=2_000_000)
    p.add_argument("--episodes", type=int, default=1000)
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--num-envs", type=int, default=PPOCfg.num_envs)
    p.add_argument("--num-steps", type=int, default=PPOCfg.num_steps)
    p.add_argument("--num-minibatches", type=int, default=PPOCfg.num_minibatches)
    p.add_argument(
        "--eval-policies",
        nargs="*",
        default=None,
        help="policies evaluated at 1.6 and 1.8 m/s (default: the methods, intercept, pursuit)",
    )
    args = p.parse_args()
    t0 = time.perf_counter()
    runs = [train(args.out, m, args) for m in args.methods]
    policies = args.eval_policies
    if policies is None:
        policies = [*args.methods, "intercept", "pursuit"]
    rows = [r for pol in policies for r in evaluate(args.out, pol, args.episodes)]
    plot(runs, args.out / "curves.png")
    text = summary_markdown(runs, rows)
    (args.out / "summary.md").write_text(text)
    write_json(
        args.out / "summary.json",
        {"runs": runs, "eval": rows, "args": vars(args) | {"out": str(args.out)}},
    )
    print(text)
    print(f"total wall {time.perf_counter() - t0:.0f} s")


if __name__ == "__main__":
    main()
