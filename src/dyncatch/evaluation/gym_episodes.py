"""One episode per environment of a Gymnasium vector env: ``dyncatch eval``'s numbers for
policies that are NumPy functions (a Stable-Baselines3 or skrl model, say).

The counterpart of ``episodes.run_episodes``: every environment of a ``CatchVectorEnv``
(same-step auto-reset, possibly under Gymnasium wrappers such as ``RescaleAction``) plays
exactly one episode from ``reset(seed=EVAL_STREAM + seed)``, and the episodes that follow
are ignored, so the N outcomes are independent and unbiased by episode length. Feed them
to ``stats.summarize`` for the success rate with its Wilson 95 % CI and the mean catch time.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from gymnasium.vector import AutoresetMode, VectorEnv

from dyncatch.evaluation.grid import EVAL_STREAM

NumpyPolicy = Callable[[np.ndarray], np.ndarray]
"""obs (num_envs, D) float32 -> actions (num_envs, A) in the env's action space (D is
``sim.api.obs_dim(world)``)."""


def run_gym_episodes(env: VectorEnv, policy: NumpyPolicy, seed: int = 0) -> dict[str, np.ndarray]:
    """Play one episode in each of ``env.num_envs`` environments.

    Args:
        env: a vector env of the catch world with same-step auto-reset (``CatchVectorEnv``
            or a wrapper of it); its ``unwrapped.world`` gives the control step and limit.
        policy: the actions for a batch of observations (deterministic for evaluation).
        seed: evaluation seed; the reset seed is ``EVAL_STREAM + seed``, far from the small
            seeds training usually starts from.

    Returns:
        ``success`` (N,) bool (caught), ``catch_time_s`` (N,) (the episode limit on
        failure, as ``run_episodes`` and the paper count it).
    """
    if env.metadata.get("autoreset_mode") != AutoresetMode.SAME_STEP:
        raise ValueError(
            "run_gym_episodes needs same-step auto-reset (metadata['autoreset_mode'] = "
            f"SAME_STEP), got {env.metadata.get('autoreset_mode')!r}: use CatchVectorEnv"
        )
    world = env.unwrapped.world
    limit = int(world.episode.max_steps)
    obs, _ = env.reset(seed=EVAL_STREAM + seed)
    done = np.zeros(env.num_envs, bool)
    success = np.zeros(env.num_envs, bool)
    steps = np.zeros(env.num_envs, np.int64)
    for _ in range(limit):
        obs, _, terminated, truncated, _ = env.step(policy(obs))
        live = ~done
        steps += live
        success |= live & np.asarray(terminated)
        done |= np.asarray(terminated) | np.asarray(truncated)
        if done.all():
            break
    dt = world.episode.dt_s
    return {"success": success, "catch_time_s": np.where(success, steps * dt, limit * dt)}


def format_summary(summary: dict) -> str:
    """One line of ``stats.summarize``'s output, as ``dyncatch eval`` prints its rows."""
    lo, hi = summary["success_ci95"]
    return (
        f"success {summary['success_rate']:.3f} [{lo:.3f}, {hi:.3f}] (95 % CI), "
        f"catch time {summary['catch_time_s']:.2f} s, {summary['episodes']} episodes"
    )
