"""The gate's compact sub-batches at small batches: compile and run time of a batched rollout
with and without them. ``python benchmarks/gate_small_batch.py [--num-envs 8 32 64 128]``.

For each batch size, a jitted 500-step ``lax.scan`` of the batched step (auto-reset; the
scripted pursuit, ``policies.pursuit``, so that arms reach) is traced, lowered and compiled
with ``sim.gate.MIN_COMPACT_BATCH`` at 0 (compact sub-batches at every size) and above the
batch (none: nobody active, or the whole batch), the persistent compilation cache off; then
each compiled program runs alternately, best of ``--repeats``. With ``--gym-steps N`` it also
times the Gymnasium vector adapter (``CatchVectorEnv``, its default 16 environments, random
actions) both ways: its first 200 steps (mostly compilation) and the next N. The reading of
the figures: docs/performance.md ("The test suite").
"""

from __future__ import annotations

import argparse
import contextlib
import json
import time

import jax

import dyncatch.sim.gate as gate
from dyncatch.policies.pursuit import PursuitCfg, pursuit_action
from dyncatch.sim.api import JaxCatchEnv
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.vec import batch_reset, batch_step
from dyncatch.utils.jax_setup import setup_jax

STEPS = 500


@contextlib.contextmanager
def _min_compact_batch(n: int):
    """``sim.gate.MIN_COMPACT_BATCH`` set to ``n`` while functions are traced."""
    old, gate.MIN_COMPACT_BATCH = gate.MIN_COMPACT_BATCH, n
    try:
        yield
    finally:
        gate.MIN_COMPACT_BATCH = old


def _rollout(state, obs, env):
    pursue = jax.vmap(pursuit_action, in_axes=(0, None, None))

    def body(carry, _):
        s, o = carry
        s, o, reward, done, _ = batch_step(s, pursue(o, env.world, PursuitCfg()), env)
        return (s, o), (reward.sum(), done.sum())

    return jax.lax.scan(body, (state, obs), None, length=STEPS)


def _compiled(env, num_envs: int, min_batch: int) -> dict:
    """The rollout compiled with ``MIN_COMPACT_BATCH = min_batch``, and its compile times."""
    with _min_compact_batch(min_batch):
        state = batch_reset(jax.random.key(0), env, num_envs)
        carry = (state, jax.vmap(env.observe)(state))
        fn = jax.jit(lambda s, o, e: _rollout(s, o, e))  # a new function: traced anew
        t0 = time.perf_counter()
        lowered = fn.lower(*carry, env)
        t1 = time.perf_counter()
        compiled = lowered.compile()
        t2 = time.perf_counter()
    out = compiled(*carry, env)
    jax.block_until_ready(out)
    return {"fn": compiled, "carry": out[0], "trace_lower_s": t1 - t0, "compile_s": t2 - t1}


def _gym_vector(min_batch: int, steps: int) -> dict:
    """``CatchVectorEnv(num_envs=16)`` with ``MIN_COMPACT_BATCH = min_batch``: seconds for its
    first 200 steps and microseconds a step over the next ``steps``."""
    import numpy as np

    from dyncatch.gym.vector_env import CatchVectorEnv

    jax.clear_caches()  # the adapter's jitted step is module-level: trace it anew
    with _min_compact_batch(min_batch):
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
                jax.block_until_ready(b["fn"](*b["carry"], env))
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
