"""Where a simulator step's time goes: ``python benchmarks/sim_variants.py [--num-envs N]``.

The batched step (random commands, auto-reset, in a jitted ``lax.scan`` of 100 steps) is
compiled in variants side by side and timed alternately, best of 5, so that the variants see
the same machine: as it is, without the arm's IK branch (zeros), with the IK computed for
every environment (no gate), without the auto-reset, and combinations. Figures and their
reading: docs/performance.md ("One gate per control step").
"""

from __future__ import annotations

import argparse
import json
import time
from functools import partial

import jax
import jax.numpy as jnp

import dyncatch.sim.env as sim_env
import dyncatch.sim.vec as vec
from dyncatch.sim.api import JaxCatchEnv
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.gate import reference_where
from dyncatch.utils.jax_setup import setup_jax

STEPS = 100


def _zero_gate(fn, fractions):
    """A gate that never runs ``fn``: its outputs are zeros."""

    def gated(active, *args):
        shapes = jax.eval_shape(fn, *args)
        return jax.tree.map(lambda s: jnp.zeros(s.shape, s.dtype), shapes)

    return gated


def _ungated(fn, fractions):
    return partial(reference_where, fn)


GATES = {"gated": sim_env.where_active, "zero": _zero_gate, "ungated": _ungated}
VARIANTS = {
    "now": ("gated", "gated"),
    "without the IK branch": ("zero", "gated"),
    "IK everywhere": ("ungated", "gated"),
    "without auto-reset": ("gated", None),
    "without auto-reset and the IK branch": ("zero", None),
}
"""name: (the arm's gate, the auto-reset's gate or None for no auto-reset)."""


def _compiled(env: JaxCatchEnv, num_envs: int, arm_gate: str, reset_gate: str | None):
    arm_orig, reset_orig = sim_env.where_active, vec.where_active
    sim_env.where_active = GATES[arm_gate]
    vec.where_active = GATES[reset_gate or "gated"]
    spec = env.action_spec

    def body(state, key):
        action = jax.random.uniform(key, (num_envs, 3), minval=spec.low, maxval=spec.high)
        if reset_gate is None:
            state, _, reward, _, _ = jax.vmap(env.step)(state, action)
        else:
            state, _, reward, _, _ = vec.batch_step(state, action, env)
        return state, reward.sum()

    try:
        fn = jax.jit(lambda s, k: jax.lax.scan(body, s, jax.random.split(k, STEPS)))
        state = vec.batch_reset(jax.random.key(0), env, num_envs)
        out = fn(state, jax.random.key(1))  # traced now, with the gates above
        # Trace again on the stepped state that the timing uses, still with these gates: a
        # state whose leaves' types differed from the reset's (as a weakly typed one did
        # before 92d37e4) would otherwise be retraced at timing, with the gates put back.
        out = fn(out[0], jax.random.key(2))
        jax.block_until_ready(out)
        return fn, out[0]
    finally:
        sim_env.where_active, vec.where_active = arm_orig, reset_orig


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--num-envs", type=int, default=4096)
    parser.add_argument("--scene", default="open_plane")
    parser.add_argument("--scan-rays", type=int, default=8, help="32 for the rooms' own")
    parser.add_argument("--repeats", type=int, default=5)
    args = parser.parse_args()
    setup_jax()
    cfg = WorldCfg().with_scene(args.scene)
    cfg = cfg.replace(scene=cfg.scene.replace(scan_rays=args.scan_rays))
    env = JaxCatchEnv(cfg)
    built = {name: _compiled(env, args.num_envs, *gates) for name, gates in VARIANTS.items()}
    best = dict.fromkeys(built, float("inf"))
    for r in range(args.repeats):
        for name, (fn, state) in built.items():
            t0 = time.perf_counter()
            jax.block_until_ready(fn(state, jax.random.key(10 + r)))
            best[name] = min(best[name], time.perf_counter() - t0)
    rows = [
        {
            "variant": name,
            "ms_per_step": 1e3 * t / STEPS,
            "env_steps_per_s": args.num_envs * STEPS / t,
        }
        for name, t in best.items()
    ]
    print(json.dumps({"num_envs": args.num_envs, "scene": args.scene, "rows": rows}, indent=1))


if __name__ == "__main__":
    main()
