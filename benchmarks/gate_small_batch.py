"""The gate's compact sub-batches at small batches: compile and run time of a batched rollout
with and without them. ``python benchmarks/gate_small_batch.py [--num-envs 8 32 64 128]``.

For each batch size, a jitted 500-step ``lax.scan`` of the batched step (auto-reset; commands
that drive each base toward its target, so that arms reach) is traced, lowered and compiled
with ``sim.gate.MIN_COMPACT_BATCH`` at 0 (compact sub-batches at every size) and above the
batch (none: nobody active, or the whole batch), the persistent compilation cache off; then
each compiled program runs alternately, best of ``--repeats``. With ``--gym-steps N`` it also
times the Gymnasium vector adapter (``CatchVectorEnv``, its default 16 environments, random
actions) both ways: its first 200 steps (mostly compilation) and the next N. The reading of
the figures: docs/performance.md ("The test suite").
"""

from __future__ import annotations

import argparse
import json
import time
from functools import partial

import jax
import jax.numpy as jnp

import dyncatch.sim.gate as gate
from dyncatch.sim.api import JaxCatchEnv
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.vec import batch_reset, batch_step
from dyncatch.utils.jax_setup import setup_jax

STEPS = 500


def _pursue(state, num_envs: int):
    rel = state.target.xy_m - state.robot.xy_m
    yaw = jnp.arctan2(rel[:, 1], rel[:, 0]) - state.robot.yaw_rad
    return jnp.stack([jnp.full(num_envs, 1.5), jnp.zeros(num_envs), 2.0 * yaw], -1)


def _rollout(state, env, num_envs: int):
    def body(s, _):
        s, _, reward, done, _ = batch_step(s, _pursue(s, num_envs), env)
        return s, (reward.sum(), done.sum())

    return jax.lax.scan(body, state, None, length=STEPS)


def _compiled(env, num_envs: int, min_batch: int) -> dict:
    """The rollout compiled with ``MIN_COMPACT_BATCH = min_batch``, and its compile times."""
    old = gate.MIN_COMPACT_BATCH
    gate.MIN_COMPACT_BATCH = min_batch
    try:
        state = batch_reset(jax.random.key(0), env, num_envs)
        fn = jax.jit(partial(_rollout, num_envs=num_envs))  # a new function: traced anew
        t0 = time.perf_counter()
        lowered = fn.lower(state, env)
        t1 = time.perf_counter()
        compiled = lowered.compile()
        t2 = time.perf_counter()
    finally:
        gate.MIN_COMPACT_BATCH = old
    out = compiled(state, env)
    jax.block_until_ready(out)
    return {"fn": compiled, "state": out[0], "trace_lower_s": t1 - t0, "compile_s": t2 - t1}


def _gym_vector(min_batch: int, steps: int) -> dict:
    """``CatchVectorEnv(num_envs=16)`` with ``MIN_COMPACT_BATCH = min_batch``: seconds for its
    first 200 steps and microseconds a step over the next ``steps``."""
    import numpy as np

    from dyncatch.gym.vector_env import CatchVectorEnv

    old = gate.MIN_COMPACT_BATCH
    gate.MIN_COMPACT_BATCH = min_batch
    jax.clear_caches()  # the adapter's jitted step is module-level: trace it anew
    try:
        env = CatchVectorEnv(num_envs=16)
        env.reset(seed=0)
        space = env.action_space
        rng = np.random.default_rng(0)
        actions = rng.uniform(space.low, space.high, (200 + steps, *space.shape))
        actions = actions.astype(np.float32)
        t0 = time.perf_counter()
        for a in actions[:200]:
            env.step(a)
        t1 = time.perf_counter()
        for a in actions[200:]:
            env.step(a)
        t2 = time.perf_counter()
    finally:
        gate.MIN_COMPACT_BATCH = old
    return {"first_200_steps_s": round(t1 - t0, 2), "us_per_step": round(1e6 * (t2 - t1) / steps)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--num-envs", type=int, nargs="+", default=[8, 32, 64, 128])
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--gym-steps", type=int, default=0, help="0: skip the Gymnasium adapter")
    args = parser.parse_args()
    setup_jax()
    jax.config.update("jax_enable_compilation_cache", False)
    env = JaxCatchEnv(WorldCfg())
    rows = []
    for n in args.num_envs:
        built = {"sub-batches": _compiled(env, n, 0), "none": _compiled(env, n, n + 1)}
        best = dict.fromkeys(built, float("inf"))
        for _ in range(args.repeats):
            for name, b in built.items():
                t0 = time.perf_counter()
                jax.block_until_ready(b["fn"](b["state"], env))
                best[name] = min(best[name], time.perf_counter() - t0)
        for name, b in built.items():
            rows.append(
                {
                    "num_envs": n,
                    "variant": name,
                    "trace_lower_s": round(b["trace_lower_s"], 2),
                    "compile_s": round(b["compile_s"], 2),
                    "us_per_step": round(1e6 * best[name] / STEPS, 1),
                }
            )
    out = {"steps": STEPS, "rows": rows}
    if args.gym_steps > 0:
        out["gym_vector_16"] = {
            "sub-batches": _gym_vector(0, args.gym_steps),
            "none": _gym_vector(17, args.gym_steps),
        }
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main()
