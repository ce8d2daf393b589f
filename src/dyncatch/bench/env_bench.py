"""Environment steps per second: the jitted batched simulator vs the Gymnasium adapter."""

from __future__ import annotations

import time
from functools import partial

import jax
import numpy as np

from dyncatch.gym.catch_env import CatchEnv
from dyncatch.sim.api import JaxCatchEnv
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.vec import batch_reset, batch_step


@partial(jax.jit, static_argnames=("num_envs", "num_steps"))
def _random_action_rollout(state, key, env: JaxCatchEnv, num_envs: int, num_steps: int):
    spec = env.action_spec

    def body(s, k):
        action = jax.random.uniform(k, (num_envs, *spec.shape), minval=spec.low, maxval=spec.high)
        s, _, reward, _, _ = batch_step(s, action, env)
        return s, reward.sum()

    return jax.lax.scan(body, state, jax.random.split(key, num_steps))


def jax_steps_per_s(cfg: WorldCfg, num_envs: int, min_steps: int = 500_000, repeats: int = 3):
    """Best of ``repeats`` timed runs of a jitted scan (compilation excluded)."""
    num_steps = int(np.clip(min_steps // num_envs, 50, 5000))
    env = JaxCatchEnv(cfg)
    state = batch_reset(jax.random.key(0), env, num_envs)
    out = _random_action_rollout(state, jax.random.key(1), env, num_envs, num_steps)
    jax.block_until_ready(out)
    best = float("inf")
    for r in range(repeats):
        t0 = time.perf_counter()
        out = _random_action_rollout(out[0], jax.random.key(2 + r), env, num_envs, num_steps)
        jax.block_until_ready(out)
        best = min(best, time.perf_counter() - t0)
    return num_envs * num_steps / best


def gym_loop_steps_per_s(cfg: WorldCfg, num_steps: int = 2000) -> float:
    """A plain Python loop over the single-environment Gymnasium adapter."""

    env = CatchEnv(behavior=cfg.target.behavior, world=cfg)
    env.reset(seed=0)
    env.action_space.seed(0)
    for _ in range(20):  # compile and warm up
        env.step(env.action_space.sample())
    t0 = time.perf_counter()
    for _ in range(num_steps):
        _, _, term, trunc, _ = env.step(env.action_space.sample())
        if term or trunc:
            env.reset()
    return num_steps / (time.perf_counter() - t0)


def run_env_benchmark(cfg: WorldCfg, num_envs: tuple[int, ...]) -> list[dict]:
    """One row per batch size of the jitted simulator, then the Gymnasium loop's; each row
    names the scene and its scan's ray count (``--scene room_8`` alone keeps the world's
    rays: add ``--world.scene.scan-rays 32`` for the rooms' own)."""
    where = {"scene": cfg.scene.name, "scan_rays": cfg.scene.scan_rays}
    rows = [
        {"backend": "jax", "num_envs": n, **where, "steps_per_s": jax_steps_per_s(cfg, n)}
        for n in num_envs
    ]
    gym = gym_loop_steps_per_s(cfg)
    rows.append({"backend": "gym_loop", "num_envs": 1, **where, "steps_per_s": gym})
    return rows
