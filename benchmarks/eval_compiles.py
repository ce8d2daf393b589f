"""Evaluation compiled once per (method, scene), measured: the compilations and wall
seconds of a grid of cells (seeds x speeds x blend off/on) played the per-cell way (a
plain and a blended program) and through the shared program (the blend a traced flag,
``policies.blend.Blended.on``), in one process, and whether their outcomes agree.

    python benchmarks/eval_compiles.py    # room_8: 3 seeds x 6 speeds x blend off/on, 200 episodes
    python benchmarks/eval_compiles.py --episodes 50 --duration-s 5

The policy is a learned policy's structure (``rl``'s inputs, the quick profile's
128-128-64 network) with seed-dependent initial weights: the compiled program is a trained
run's, and its parameters are arguments. No persistent compilation cache: every
compilation counted is a real one.
"""

from __future__ import annotations

import argparse
import json
import os
import time

import jax
import jax.numpy as jnp
import numpy as np

from dyncatch.evaluation.episodes import run_episodes
from dyncatch.policies.blend import deploy
from dyncatch.reproduce.fig9 import CONTACT_TOL_M, cell_key, scene_world
from dyncatch.reproduce.paper import PAPER_SPEEDS_MPS
from dyncatch.rl.methods import method_obs
from dyncatch.rl.networks import ActorCritic
from dyncatch.rl.normalize import RunningNorm
from dyncatch.rl.policy import LearnedPolicy
from dyncatch.sim.api import JaxCatchEnv, obs_dim
from dyncatch.sim.config import WorldCfg
from dyncatch.utils.compiles import compile_log
from dyncatch.utils.jax_setup import with_cpu_flags

REPORTED = ("success", "catch_time_s", "contacts")
"""The outcomes a table reports (the return is not)."""


def untrained(seed: int, world: WorldCfg, hidden: tuple[int, ...]) -> LearnedPolicy:
    net = ActorCritic(3, hidden, 0.0)
    d = obs_dim(world)
    params = net.init(jax.random.key(seed), jnp.zeros((1, d)))
    return LearnedPolicy(
        net, params, RunningNorm.create(d, 0.5), method_obs("rl"), JaxCatchEnv(world)
    )


def play(cells, trained: WorldCfg, world: WorldCfg, episodes: int, flag: bool, hidden):
    """{cell: outcome}, seconds and the evaluation program's compilations (count, seconds)."""
    key = cell_key(world.scene.name, world.target.behavior)
    out = {}
    t = time.perf_counter()
    with compile_log() as log:
        for seed, speed, blend in cells:
            policy = deploy(
                untrained(seed, trained, hidden), trained, world, blend, blend_as_flag=flag
            )
            out[seed, speed, blend] = jax.device_get(
                run_episodes(
                    policy, key, world.with_speed(speed), episodes, contact_tol_m=CONTACT_TOL_M
                )
            )
    program = log.of("_run_impl")
    return out, time.perf_counter() - t, len(program), sum(program)


def main() -> None:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--scene", default="room_8")
    p.add_argument("--behavior", default="reactive")
    p.add_argument("--seeds", type=int, default=3)
    p.add_argument("--speeds", type=float, nargs="+", default=list(PAPER_SPEEDS_MPS))
    p.add_argument("--episodes", type=int, default=200)
    p.add_argument(
        "--duration-s", type=float, default=10.0, help="episode length (the scene's: 40)"
    )
    p.add_argument("--hidden-sizes", type=int, nargs="+", default=[128, 128, 64])
    a = p.parse_args()
    os.environ["XLA_FLAGS"] = with_cpu_flags(os.environ.get("XLA_FLAGS", ""))
    trained = WorldCfg().with_behavior(a.behavior)
    world = scene_world(trained, a.scene, a.behavior, a.duration_s)
    cells = [(s, v, b) for s in range(a.seeds) for v in a.speeds for b in (False, True)]
    hidden = tuple(a.hidden_sizes)
    # The shared program first: what the process warms up on its first compilation counts
    # against it, not for it.
    new, new_s, new_n, new_c = play(cells, trained, world, a.episodes, True, hidden)
    old, old_s, old_n, old_c = play(cells, trained, world, a.episodes, False, hidden)
    same = {k: all(np.array_equal(old[c][k], new[c][k]) for c in cells) for k in REPORTED}
    ret = max(float(np.max(np.abs(old[c]["return"] - new[c]["return"]))) for c in cells)
    result = {
        "grid": f"{a.scene} {a.behavior}: {a.seeds} seeds x {len(a.speeds)} speeds x blend off/on, "
        f"{a.episodes} episodes of {a.duration_s:g} s",
        "cells": len(cells),
        "per_cell": {"compiles": old_n, "compile_s": round(old_c, 1), "wall_s": round(old_s, 1)},
        "shared": {"compiles": new_n, "compile_s": round(new_c, 1), "wall_s": round(new_s, 1)},
        "wall_ratio": round(old_s / new_s, 2),
        "identical": same,
        "return_max_abs_diff": ret,
    }
    print(json.dumps(result, indent=1))


if __name__ == "__main__":
    main()
