"""The catch world as a ``gymnasium.Env``: NumPy in and out, jitted JAX inside.

One environment, no batching: for many environments in one call use
``dyncatch.gym.vector_env.CatchVectorEnv``. The episode ends itself (``terminated`` on a
catch, ``truncated`` at ``cfg.episode.max_steps``), so no ``TimeLimit`` is needed.
"""

from __future__ import annotations

from typing import Any

import gymnasium
import jax
import jax.numpy as jnp
import numpy as np
from gymnasium import spaces

from dyncatch.sim import env as sim_env
from dyncatch.sim.base import command_high, command_low
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.state import ACTION_DIM, OBS_DIM, EnvState
from dyncatch.sim.validate import validate_world

_UINT32 = 2**32


def seed_to_key(seed: int) -> jax.Array:
    """The JAX key that ``reset(seed=seed)`` starts from, a raw ``uint32`` key (2,).

    ``jax.random.PRNGKey(seed)`` for ``0 <= seed < 2**32``; the higher 32-bit words of a
    wider seed are folded in one by one, so every non-negative integer gets its own key.
    """
    if seed < 0:
        raise ValueError(f"seed must be a non-negative integer, got {seed}")
    key = jax.random.PRNGKey(seed % _UINT32)
    seed //= _UINT32
    while seed:
        key = jax.random.fold_in(key, seed % _UINT32)
        seed //= _UINT32
    return key


def make_world(
    behavior: str = "reactive", world: WorldCfg | None = None, speed_mps: float | None = None
) -> WorldCfg:
    """``world`` (default ``WorldCfg()``) with its behaviour set and, if given, a fixed
    target speed; validated, so a bad value fails here and not inside jitted code."""
    cfg = (world if world is not None else WorldCfg()).with_behavior(behavior)
    if speed_mps is not None:
        cfg = cfg.with_speed(float(speed_mps))
    return validate_world(cfg)


def observation_space() -> spaces.Box:
    """Unbounded float32 Box of shape (OBS_DIM,) = (17,); the layout is ``Obs.flat``."""
    return spaces.Box(-np.inf, np.inf, (OBS_DIM,), np.float32)


def action_space(cfg: WorldCfg) -> spaces.Box:
    """The base command (vx, vy, yaw rate) in m/s and rad/s, (ACTION_DIM,) = (3,)."""
    low = np.asarray(command_low(cfg.base), np.float32)
    high = np.asarray(command_high(cfg.base), np.float32)
    return spaces.Box(low, high, (ACTION_DIM,), np.float32)


def _reset_flat(key: jax.Array, cfg: WorldCfg) -> tuple[EnvState, jax.Array]:
    state = sim_env.reset(key, cfg)
    return state, sim_env.observe(state, cfg).flat


def _step_flat(state: EnvState, action: jax.Array, cfg: WorldCfg):
    state, obs, reward, _, info = sim_env.step(state, action, cfg)
    return state, obs.flat, reward, info


# Module-level so every instance with the same static config shares one compilation; the
# config is an argument, so its numeric fields can change without recompiling.
reset_flat = jax.jit(_reset_flat)
"""Jitted ``(key, cfg) -> (state, obs (17,))``: ``sim.env.reset`` with the flat observation."""

step_flat = jax.jit(_step_flat)
"""Jitted ``(state, action (3,), cfg) -> (state, obs (17,), reward (), info)``: ``sim.env.step``
with the flat observation; ``info["terminated"]`` and ``info["truncated"]`` give ``done``."""


def to_python_info(info: dict[str, Any]) -> dict[str, bool | float]:
    """A step's info (scalar arrays) as plain Python bools and floats."""
    return {k: bool(v) if np.asarray(v).dtype == np.bool_ else float(v) for k, v in info.items()}


class CatchEnv(gymnasium.Env[np.ndarray, np.ndarray]):
    """One legged robot catching one target.

    Args:
        behavior: target behaviour, a key of ``dyncatch.sim.behaviors.BEHAVIORS``; it
            replaces ``world.target.behavior``.
        world: the world config (default ``WorldCfg()``).
        speed_mps: fix the target speed (``WorldCfg.with_speed``); None keeps the range.
        render_mode: only None (no renderer yet).

    ``reset(seed=s)`` starts from ``seed_to_key(s)``; ``reset()`` draws a key from
    ``self.np_random``, so ``reset(seed=s)`` followed by resets without seed is a
    reproducible sequence. Actions outside ``action_space`` are clipped by the simulator.
    """

    metadata = {"render_modes": [], "render_fps": 50}

    def __init__(
        self,
        behavior: str = "reactive",
        world: WorldCfg | None = None,
        speed_mps: float | None = None,
        render_mode: str | None = None,
    ) -> None:
        if render_mode is not None:
            raise ValueError(f"render_mode {render_mode!r} is not supported; use None")
        self.world = make_world(behavior, world, speed_mps)
        self.render_mode = render_mode
        self.metadata = {**self.metadata, "render_fps": self.world.episode.control_hz}
        self.observation_space = observation_space()
        self.action_space = action_space(self.world)
        self._state: EnvState | None = None

    @property
    def state(self) -> EnvState:
        """The simulator state (a pytree of JAX arrays); only after ``reset``."""
        if self._state is None:
            raise RuntimeError("call reset() before using the environment")
        return self._state

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start an episode. Returns (obs (17,) float32, {}); ``options`` are not read."""
        super().reset(seed=seed)
        if seed is None:
            seed = int(self.np_random.integers(_UINT32))
        self._state, obs = reset_flat(seed_to_key(seed), self.world)
        return np.array(obs, np.float32), {}

    def step(
        self, action: np.ndarray
    ) -> tuple[np.ndarray, float, bool, bool, dict[str, bool | float]]:
        """One control step under the base command ``action`` (3,).

        Returns (obs (17,) float32, reward, terminated, truncated, info); info is the
        simulator's step info (``reward/<name>``, ``success``, ``terminated``,
        ``truncated``, ``distance_m``, ...; see ``sim.env.step``) as Python scalars.
        """
        action = np.asarray(action, np.float32)
        if action.shape != (ACTION_DIM,):
            raise ValueError(f"action must have shape ({ACTION_DIM},), got {action.shape}")
        self._state, obs, reward, info = step_flat(self.state, jnp.asarray(action), self.world)
        obs, reward, info = jax.device_get((obs, reward, info))
        info = to_python_info(info)
        return (
            np.array(obs, np.float32),
            float(reward),
            info["terminated"],
            info["truncated"],
            info,
        )

    def render(self) -> None:
        return None
