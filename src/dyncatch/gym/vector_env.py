"""Many catch worlds as one ``gymnasium.vector.VectorEnv``: one jitted call per step.

Auto-reset happens in the same step (``AutoresetMode.SAME_STEP``): where an episode ends,
the returned observation is the next episode's first, and the finished episode's last one
is in ``info["final_obs"]`` (num_envs, D), valid where ``info["_final_obs"]`` is True.
``render()`` returns a tuple of frames, one per environment, as Gymnasium's ``VectorEnv``
does; ``gymnasium.wrappers.vector.RecordVideo`` tiles them. D is the observation's width,
``sim.api.obs_dim(world)``.
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

from dyncatch.gym.catch_env import (
    _UINT32,
    action_space,
    check_same_spaces,
    make_env,
    observation_space,
    seed_to_key,
)
from dyncatch.gym.options import apply_reset_options
from dyncatch.gym.rendering import RENDER_MODES, StateFrames, check_render_mode, render_metadata
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


def _with_masks(step_info: dict[str, Any], mask: np.ndarray) -> dict[str, Any]:
    """Gymnasium's vector info layout: each (num_envs,) array ``key`` beside its bool mask
    ``_key`` of the environments it holds a value for (``DictInfoToList`` reads them)."""
    info: dict[str, Any] = {}
    for key, value in step_info.items():
        info[key] = np.array(value)
        info[f"_{key}"] = mask
    return info


class CatchVectorEnv(gymnasium.vector.VectorEnv):
    """``num_envs`` independent catch worlds stepped together.

    Args:
        num_envs: number of environments, the leading axis of every array.
        behavior, world, speed_mps, render_mode, env, render_size_px: as for ``CatchEnv``;
            with render_mode="rgb_array", ``render()`` returns one frame per environment.

    ``step`` returns obs (num_envs, D) float32, rewards (num_envs,) float32, terminations
    and truncations (num_envs,) bool, and info with one (num_envs,) array per key of the
    single-env info with its ``_key`` mask of the environments whose episode goes on, plus
    ``final_obs`` (num_envs, D) (zeros where no episode ended) and ``final_info`` (the
    finished step's info), each with its ``_key`` mask of the environments whose episode
    ended: Gymnasium's layout for same-step auto-reset (its ``SyncVectorEnv`` keeps
    ``final_obs`` as an object array with None where no episode ended instead).
    ``reset(seed=s)`` starts from ``batch_reset(seed_to_key(s), cfg, num_envs)``;
    ``reset(options=...)`` takes the options of ``CatchEnv.reset`` for every environment.
    """

    metadata = {
        "render_modes": list(RENDER_MODES),
        "render_fps": 50,
        "autoreset_mode": AutoresetMode.SAME_STEP,
    }

    def __init__(
        self,
        num_envs: int = 16,
        behavior: str | None = None,
        world: WorldCfg | None = None,
        speed_mps: float | None = None,
        render_mode: str | None = None,
        env: Environment | None = None,
        render_size_px: int = 480,
    ) -> None:
        if num_envs < 1:
            raise ValueError(f"num_envs must be at least 1, got {num_envs}")
        check_render_mode(render_mode)
        self.num_envs = int(num_envs)
        self.env = make_env(behavior, world, speed_mps, env)
        self.world = self.built_world = self.env.world
        self.render_mode = render_mode
        self.metadata = {**self.metadata, **render_metadata(self.world)}
        self._frames = StateFrames(self.world, render_size_px) if render_mode else None
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
        """Start every episode anew. Returns (obs (num_envs, D) float32, {}).

        ``options``: as for ``CatchEnv.reset`` (``behavior``, ``speed_mps``), for every
        environment, this and later episodes; any other key raises ValueError.
        """
        if options:
            env = apply_reset_options(self.env, options, self.built_world)
            check_same_spaces(env, self.single_observation_space, self.single_action_space)
            self.env, self.world = env, env.world
            if self._frames is not None:
                self._frames.set_world(env.world)
        super().reset(seed=seed)
        if seed is None:
            seed = int(self.np_random.integers(_UINT32))
        self._state, obs = _reset_flat(seed_to_key(seed), self.env, self.num_envs)
        if self._frames is not None:
            self._frames.start(self._state)
        return np.array(obs, np.float32), {}

    def step(
        self, actions: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """One control step of every environment under ``actions`` (num_envs, 3); a row
        with a NaN or an infinity is refused (ValueError) and no environment steps."""
        actions = np.asarray(actions, np.float32)
        if actions.shape != self.action_space.shape:
            raise ValueError(
                f"actions must have shape {self.action_space.shape}, got {actions.shape}"
            )
        if not np.isfinite(actions).all():
            bad = np.flatnonzero(~np.isfinite(actions).all(axis=1))
            raise ValueError(f"actions must be finite (no NaN or infinity): rows {bad.tolist()}")
        self._state, *out = _step_flat(self.state, jnp.asarray(actions), self.env)
        if self._frames is not None:
            self._frames.push(self._state)
        obs, reward, done, final_obs, step_info = jax.device_get(out)
        done = np.array(done)
        # Where an episode ended, the top level holds the new episode's reset info (none),
        # and the finished step's is in final_info, as in Gymnasium's SyncVectorEnv.
        info = _with_masks(step_info, ~done)
        info["final_obs"] = np.array(final_obs, np.float32)
        info["_final_obs"] = done
        info["final_info"] = _with_masks(step_info, done)
        info["_final_info"] = done
        return (
            np.array(obs, np.float32),
            np.array(reward, np.float32),
            np.array(step_info["terminated"]),
            np.array(step_info["truncated"]),
            info,
        )

    def render(self) -> tuple[np.ndarray, ...] | None:
        """With render_mode="rgb_array", one top-down frame of each environment's current
        state, a tuple of num_envs (H, W, 3) uint8 arrays (as ``CatchEnv.render``); else
        None with a warning."""
        if self._frames is None:
            gymnasium.logger.warn(
                "render() was called with render_mode=None; pass render_mode='rgb_array'"
            )
            return None
        return self._frames.frames(self.state)
