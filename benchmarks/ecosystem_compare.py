"""dyncatch's own PPO beside Stable-Baselines3's and skrl's on the Gymnasium adapters.

One run on this machine, the same task for all three: slow circle targets (default
0.5 m/s), the same network (``--hidden-sizes``, ELU actor and critic), the same sample
budget and 8192 samples per update in 4 minibatches x 4 epochs. Each library trains as
its example does (``examples/sb3_ppo.py``: 16 single ``CatchEnv`` in SB3's DummyVecEnv;
``examples/skrl_ppo.py``: one ``CatchVectorEnv`` of 256); dyncatch trains with
``rl.train.make_train`` (256 envs x 32 steps, everything in one jitted function). Every
policy is then evaluated the same way, by ``run_gym_episodes``: the mean action, one
episode in each of ``--episodes`` environments, the same evaluation seeds.

samples/s is the budget over the wall time of training (model construction, compilation
and every update included; evaluation excluded); dyncatch's steady rate (after its
compiling first iteration) is reported beside it. Writes ``--out`` (JSON) and prints a
Markdown table.

    .venv/bin/python benchmarks/ecosystem_compare.py --total-steps 491520 \\
        --out results/ecosystem_compare.json
"""

from __future__ import annotations

import argparse
import importlib.util
import json
import os
import sys
import time
from pathlib import Path

import jax
import numpy as np

from dyncatch.bench.machine import machine_info
from dyncatch.evaluation.gym_episodes import run_gym_episodes
from dyncatch.evaluation.stats import summarize
from dyncatch.gym import CatchVectorEnv
from dyncatch.rl.config import PPOCfg
from dyncatch.rl.train import make_train, to_command
from dyncatch.sim.api import JaxCatchEnv
from dyncatch.sim.config import WorldCfg

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
LIBRARIES = {"stable-baselines3": "sb3_ppo.py", "skrl": "skrl_ppo.py"}


def parse_args() -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--total-steps", type=int, default=491_520, help="samples per library")
    p.add_argument("--behavior", default="circle")
    p.add_argument("--speed-mps", type=float, default=0.5)
    p.add_argument("--hidden-sizes", type=int, nargs="+", default=[64, 64])
    p.add_argument("--episodes", type=int, default=200, help="evaluation episodes")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--libraries", nargs="+", default=list(LIBRARIES), choices=list(LIBRARIES))
    p.add_argument("--out", type=Path, default=Path("results/ecosystem_compare.json"))
    return p.parse_args()


def run_dyncatch(args: argparse.Namespace) -> dict:
    """dyncatch's PPO: ``make_train`` iterations up to the budget, then the same evaluation."""
    world = WorldCfg().with_behavior(args.behavior).with_speed(args.speed_mps)
    env = JaxCatchEnv(world)
    ppo = PPOCfg(
        num_envs=256,
        num_steps=32,
        num_minibatches=4,
        update_epochs=4,
        hidden_sizes=tuple(args.hidden_sizes),
    )
    start = time.perf_counter()
    init, iterate, net = make_train(env, ppo)
    init, iterate = jax.jit(init), jax.jit(iterate)
    ts = init(jax.random.key(args.seed))
    iterations = -(-args.total_steps // ppo.batch_size)
    first_done = None
    for _ in range(iterations):
        ts, _ = iterate(ts)
        jax.block_until_ready(ts.env_steps)
        first_done = first_done or time.perf_counter()
    end = time.perf_counter()
    train_s, steps = end - start, int(ts.env_steps)
    steady = (steps - ppo.batch_size) / (end - first_done) if iterations > 1 else float("nan")

    @jax.jit
    def act(obs):
        mean, _, _ = net.apply(ts.params, ts.norm(obs))
        return to_command(mean, env)

    venv = CatchVectorEnv(args.episodes, behavior=args.behavior, speed_mps=args.speed_mps)
    outcome = run_gym_episodes(venv, lambda obs: np.asarray(act(obs)), seed=args.seed)
    return {
        "library": "dyncatch",
        "total_steps": steps,
        "train_s": train_s,
        "samples_per_s": steps / train_s,
        "steady_samples_per_s": steady,
        "hidden_sizes": list(args.hidden_sizes),
        **summarize(outcome),
    }


def run_library(name: str, args: argparse.Namespace) -> dict:
    """The library's example at this budget (its ``main`` returns the same fields)."""
    path = EXAMPLES / LIBRARIES[name]
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    argv = [
        "--total-steps", str(args.total_steps), "--behavior", args.behavior,
        "--speed-mps", str(args.speed_mps), "--episodes", str(args.episodes),
        "--seed", str(args.seed), "--hidden-sizes", *map(str, args.hidden_sizes),
    ]  # fmt: skip
    return module.main(argv)


def table(rows: list[dict], args: argparse.Namespace) -> str:
    base = rows[0]["samples_per_s"]
    lines = [
        f"{args.behavior} targets at {args.speed_mps} m/s, MLP {args.hidden_sizes} (ELU), "
        f"{args.episodes} evaluation episodes",
        "",
        "| library | samples | train (s) | samples/s | ratio to dyncatch | success [95 % CI] "
        "| catch time (s) |",
        "|---|---:|---:|---:|---:|---|---:|",
    ]
    for r in rows:
        lo, hi = r["success_ci95"]
        lines.append(
            f"| {r['library']} | {r['total_steps']:,} | {r['train_s']:.0f} | "
            f"{r['samples_per_s']:,.0f} | {r['samples_per_s'] / base:.3f} | "
            f"{r['success_rate']:.3f} [{lo:.3f}, {hi:.3f}] | {r['catch_time_s']:.2f} |"
        )
    return "\n".join(lines)


def main() -> None:
    args = parse_args()
    load_start = os.getloadavg()[0]
    rows = [run_dyncatch(args)]
    print(json.dumps(rows[-1]), flush=True)
    for name in args.libraries:
        rows.append(run_library(name, args))  # the example prints its own line
    args.out.parent.mkdir(parents=True, exist_ok=True)
    report = {
        "command": " ".join(["benchmarks/ecosystem_compare.py", *sys.argv[1:]]),
        "machine": machine_info(),
        # Other processes share the cores; the 1-minute load average says how much.
        "load_avg_1m": {"start": load_start, "end": os.getloadavg()[0]},
        "rows": rows,
        "table": table(rows, args),
    }
    args.out.write_text(json.dumps(report, indent=2) + "\n")
    print(report["table"])


if __name__ == "__main__":
    main()
