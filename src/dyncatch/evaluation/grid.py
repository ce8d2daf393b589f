"""Evaluate a policy over a grid of target speeds: the rows of Table I."""

from __future__ import annotations

import jax
import jax.numpy as jnp
import numpy as np

from dyncatch.evaluation.backends import get_backend
from dyncatch.evaluation.stats import summarize
from dyncatch.fullbody.config import FullBodyCfg
from dyncatch.sim.api import Environment, as_env
from dyncatch.sim.config import WorldCfg

EVAL_STREAM = 0x5EED_E7A1
"""Evaluation keys are folded with this constant, so they never coincide with the training
keys (which come from ``jax.random.key(seed)`` directly)."""


def evaluate_speeds(
    policy,
    env: Environment | WorldCfg,
    behavior: str,
    speeds_mps,
    episodes: int,
    seed: int,
    method: str,
    backend: str = "jax",
    fullbody: FullBodyCfg | None = None,
) -> list[dict]:
    """One row per speed: success rate with a Wilson 95 % CI and mean catch time, played on
    ``backend`` (a key of ``evaluation.backends.EVAL_BACKENDS``; ``fullbody`` configures the
    ``mujoco`` one); the same seed plays the same episodes on every backend."""
    env = as_env(env)
    entry = get_backend(backend, fullbody)
    key = jax.random.fold_in(jax.random.key(seed), EVAL_STREAM)
    keys = [jax.random.fold_in(key, i) for i in range(len(speeds_mps))]
    env = env.with_world(env.world.with_behavior(behavior))
    if entry.run_speeds is not None:  # every speed in one batched call
        both = jax.device_get(entry.run_speeds(policy, jnp.stack(keys), env, speeds_mps, episodes))
        outcomes = [{k: v[i] for k, v in both.items()} for i in range(len(speeds_mps))]
    else:
        outcomes = [
            entry.run(policy, k, env.with_world(env.world.with_speed(v)), episodes)
            for k, v in zip(keys, speeds_mps, strict=True)
        ]
    rows = []
    for speed, outcome in zip(speeds_mps, outcomes, strict=True):
        s = summarize(outcome)
        extra = {f"{k}_rate": float(np.mean(outcome[k])) for k in entry.events}
        rows.append(
            {
                "backend": backend,
                "method": method,
                "behavior": behavior,
                "speed_mps": float(speed),
                "episodes": s["episodes"],
                "success_rate": s["success_rate"],
                "success_ci95": s["success_ci95"],
                "catch_time_s": s["catch_time_s"],
                **extra,
            }
        )
    return rows
