"""Many catch worlds as one ``gymnasium.vector.VectorEnv``: one jitted call per step.

Auto-reset happens in the same step (``AutoresetMode.SAME_STEP``): where an episode ends,
the returned observation is the next episode's first, and the finished episode's last one
is in ``info["final_obs"]`` (num_envs, 17), valid where ``info["_final_obs"]`` is True.
"""

from __future__ import annotations

from functools import partial
from typing import Any

import gymnasium
import jax
import jax.numpy as jnp
import numpy as np
from gymnasium.vector import AutoresetMode
from gymnasium.vector.utils import batch_space

from dyncatch.gym.catch_env import _UINT32, action_space, make_env, observation_space, seed_to_key
from dyncatch.sim.api import Environment
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.vec import batch_observe, batch_reset, batch_step


@partial(jax.jit, static_argnames="num_envs")
def _reset_flat(key: jax.Array, env: Environment, num_envs: int):
    state = batch_reset(key, env, num_envs)
    return state, batch_observe(state, env).flat


@jax.jit
def _step_flat(state, actions: jax.Array, env: Environment):
    state, obs, reward, done, info = batch_step(state, actions, env)
    final_obs = jnp.where(done[:, None], info.pop("final_obs").flat, 0.0)
    return state, obs.flat, reward, done, final_obs, info


class CatchVectorEnv(gymnasium.vector.VectorEnv):
    """``num_envs`` independent catch worlds stepped together.

    Args:
        num_envs: number of environments, the leading axis of every array.
        behavior, world, speed_mps, render_mode, env: as for ``CatchEnv``.

    ``step`` returns obs (num_envs, 17) float32, rewards (num_envs,) float32, terminations
    and truncations (num_envs,) bool, and info with one (num_envs,) array per key of the
    single-env info (the finished step's values), plus ``final_obs`` (num_envs, 17) (zeros
    where no episode ended) and ``final_info`` (the same step info), each with its ``_key``
    mask of the environments whose episode ended. ``reset(seed=s)`` starts from
    ``batch_reset(seed_to_key(s), cfg, num_envs)``.
    """

    metadata = {"render_modes": [], "autoreset_mode": AutoresetMode.SAME_STEP}

    def __init__(
        self,
        num_envs: int = 16,
        behavior: str = "reactive",
        world: WorldCfg | None = None,
        speed_mps: float | None = None,
        render_mode: str | None = None,
        env: Environment | None = None,
    ) -> None:
        if num_envs < 1:
            raise ValueError(f"num_envs must be at least 1, got {num_envs}")
        if render_mode is not None:
            raise ValueError(f"render_mode {render_mode!r} is not supported; use None")
        self.num_envs = int(num_envs)
        self.env = make_env(behavior, world, speed_mps, env)
        self.world = self.env.world
        self.render_mode = render_mode
        self.single_observation_space = observation_space(self.env)
        self.single_action_space = action_space(self.env)
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self._state = None

    @property
    def state(self):
        """The batched simulator state (leading axis num_envs); only after ``reset``."""
        if self._state is None:
            raise RuntimeError("call reset() before using the environment")
        return self._state

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start every episode anew. Returns (obs (num_envs, 17) float32, {})."""
        super().reset(seed=seed)
        if seed is None:
            seed = int(self.np_random.integers(_UINT32))
        self._state, obs = _reset_flat(seed_to_key(seed), self.env, self.num_envs)
        return np.array(obs, np.float32), {}

    def step(
        self, actions: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """One control step of every environment under ``actions`` (num_envs, 3)."""
        actions = np.asarray(actions, np.float32)
        if actions.shape != self.action_space.shape:
            raise ValueError(
                f"actions must have shape {self.action_space.shape}, got {actions.shape}"
            )
        self._state, *out = _step_flat(self.state, jnp.asarray(actions), self.env)
        obs, reward, done, final_obs, step_info = jax.device_get(out)
        info: dict[str, Any] = {k: np.array(v) for k, v in step_info.items()}
        info["final_obs"] = np.array(final_obs, np.float32)
        info["_final_obs"] = np.array(done)
        info["final_info"] = {k: np.array(v) for k, v in step_info.items()}
        info["_final_info"] = np.array(done)
        return (
            np.array(obs, np.float32),
            np.array(reward, np.float32),
            np.array(step_info["terminated"]),
            np.array(step_info["truncated"]),
            info,
        )
