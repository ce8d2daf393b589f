"""Milliseconds per batched simulator step, for comparing two checkouts back to back.

``python benchmarks/step_time.py [--num-envs N] [--scene S --scan-rays R]`` times 100 steps
of ``sim.vec.batch_step`` under random commands in a jitted ``lax.scan`` (best of 7, after
compiling and one warm-up call), from the same state each time. To compare code, run it
alternately on two checkouts, ``PYTHONPATH=<other checkout>/src python
benchmarks/step_time.py`` and without, a few times: this machine's speed drifts by 10-25 %
over minutes, so only pairs taken back to back compare. ``dyncatch bench env`` is the
headline figure (it runs on from where the previous call stopped, so arms near their
targets and finished episodes show up); this one isolates the code. Figures:
docs/performance.md ("A step's random numbers, XLA's library fusions").
"""

from __future__ import annotations

import argparse
import json
import time

import jax

import dyncatch
from dyncatch.sim.api import JaxCatchEnv
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.vec import batch_reset, batch_step
from dyncatch.utils.jax_setup import setup_jax

STEPS = 100


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--num-envs", type=int, default=4096)
    parser.add_argument("--scene", default="open_plane")
    parser.add_argument("--scan-rays", type=int, default=8, help="32 for the rooms' own")
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    setup_jax()
    cfg = WorldCfg().with_scene(args.scene)
    cfg = cfg.replace(scene=cfg.scene.replace(scan_rays=args.scan_rays))
    env, n = JaxCatchEnv(cfg), args.num_envs
    spec = env.action_spec

    def body(state, key):
        action = jax.random.uniform(key, (n, 3), minval=spec.low, maxval=spec.high)
        state, _, reward, _, _ = batch_step(state, action, env)
        return state, reward.sum()

    run = jax.jit(lambda s, k: jax.lax.scan(body, s, jax.random.split(k, STEPS)))
    t0 = time.perf_counter()
    state, _ = run(batch_reset(jax.random.key(0), env, n), jax.random.key(1))
    jax.block_until_ready(state)
    compile_s = time.perf_counter() - t0
    best = float("inf")
    for r in range(args.repeats):
        t0 = time.perf_counter()
        jax.block_until_ready(run(state, jax.random.key(10 + r)))
        best = min(best, time.perf_counter() - t0)
    print(
        json.dumps(
            {
                "code": dyncatch.__file__,
                "scene": args.scene,
                "scan_rays": args.scan_rays,
                "num_envs": n,
                "compile_and_first_s": round(compile_s, 1),
                "ms_per_step": round(1e3 * best / STEPS, 3),
                "env_steps_per_s": round(n * STEPS / best),
            }
        )
    )


if __name__ == "__main__":
    main()
