"""The catch world as a ``gymnasium.Env``: NumPy in and out, jitted JAX inside.

One environment, no batching: for many environments in one call use
``dyncatch.gym.vector_env.CatchVectorEnv``. The episode ends itself (``terminated`` on a
catch, ``truncated`` at ``cfg.episode.max_steps``), so no ``TimeLimit`` is needed.
``render_mode="rgb_array"`` draws the current state top-down (``gym.rendering``);
``reset(options=...)`` changes the world for this and later episodes (``gym.options``).
"""

from __future__ import annotations

import math
import multiprocessing
import numbers
from typing import Any

import gymnasium
import jax
import jax.numpy as jnp
import numpy as np
from gymnasium import logger, spaces

from dyncatch.gym.options import apply_reset_options
from dyncatch.gym.rendering import RENDER_MODES, StateFrames, check_render_mode, render_metadata
from dyncatch.sim.api import Environment, JaxCatchEnv
from dyncatch.sim.config import WorldCfg
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


def spawn_workers_by_default() -> None:
    """Make "spawn" the process's multiprocessing start method if none was chosen yet.

    Gymnasium's async vector env (``gymnasium.make_vec(..., vectorization_mode="async")``)
    starts its workers with the default start method, "fork" on Linux before Python 3.14;
    a child forked after JAX has started deadlocks, and the parent always starts JAX (it
    builds one environment for the spaces). A start method the program set itself is left
    as it is (with "fork", pass ``vector_kwargs={"context": "spawn"}``). As with any spawn,
    a script that builds the vector env needs ``if __name__ == "__main__":``.
    """
    if multiprocessing.get_start_method(allow_none=True) is None:
        multiprocessing.set_start_method("spawn")


def make_env(
    behavior: str | None = None,
    world: WorldCfg | None = None,
    speed_mps: float | None = None,
    env: Environment | None = None,
) -> Environment:
    """The backend an adapter steps: ``env`` (default the JAX world ``JaxCatchEnv``) in
    ``world`` (default ``env.world``, else ``WorldCfg()``, the library's training default)
    with, if given, another behaviour (None: the world's own, ``world.target.behavior``) and a
    fixed target speed; validated, so a bad value fails here and not inside jitted code."""
    env = env if env is not None else JaxCatchEnv()
    cfg = world if world is not None else env.world
    if behavior is not None:
        cfg = cfg.with_behavior(behavior)
    if speed_mps is not None:
        if not isinstance(speed_mps, numbers.Real) or not math.isfinite(speed_mps):
            raise ValueError(f"speed_mps must be a finite number of m/s, got {speed_mps!r}")
        cfg = cfg.with_speed(float(speed_mps))
    return env.with_world(validate_world(cfg))


def _box(spec) -> spaces.Box:
    low, high = np.asarray(spec.low, np.float32), np.asarray(spec.high, np.float32)
    return spaces.Box(low, high, spec.shape, np.float32)


def observation_space(env: Environment) -> spaces.Box:
    """float32 Box of ``env.observation_spec`` (the JAX world: ``Obs.flat``,
    (``sim.api.obs_dim(world)``,), within the bounds of ``sim.obs_bounds``)."""
    return _box(env.observation_spec)


def action_space(env: Environment) -> spaces.Box:
    """The base command (vx, vy, yaw rate) in m/s and rad/s: ``env.action_spec``, (3,)."""
    return _box(env.action_spec)


def check_same_spaces(new_env: Environment, obs_space: spaces.Box, act_space: spaces.Box) -> None:
    """Raise ValueError if ``new_env`` (a world set by reset options) has other spaces than
    the adapter declared: spaces are fixed for an environment's lifetime."""
    for name, old, new in (
        ("observation", obs_space, observation_space(new_env)),
        ("action", act_space, action_space(new_env)),
    ):
        if old.shape != new.shape:
            raise ValueError(
                f"the reset options change the {name} shape {old.shape} -> {new.shape}; "
                "build a new environment with gymnasium.make for that world"
            )
        moved = np.flatnonzero((old.low != new.low) | (old.high != new.high))
        if moved.size:
            bounds = ", ".join(
                f"[{i}] [{old.low[i]}, {old.high[i]}] -> [{new.low[i]}, {new.high[i]}]"
                for i in moved
            )
            raise ValueError(
                f"the reset options change the {name} space bounds {bounds}; "
                "build a new environment with gymnasium.make for that world"
            )


def _reset_flat(key: jax.Array, env: Environment):
    state = env.reset(key)
    return state, env.observe(state).flat


def _step_flat(state, action: jax.Array, env: Environment):
    state, obs, reward, _, info = env.step(state, action)
    return state, obs.flat, reward, info


# Module-level so every instance with the same static config shares one compilation; the
# environment is an argument, so its numeric fields can change without recompiling.
reset_flat = jax.jit(_reset_flat)
"""Jitted ``(key, env) -> (state, obs (D,))``: ``env.reset`` with the flat observation."""

step_flat = jax.jit(_step_flat)
"""Jitted ``(state, action (3,), env) -> (state, obs (D,), reward (), info)``: ``env.step``
with the flat observation; ``info["terminated"]`` and ``info["truncated"]`` give ``done``."""


def _step_packed(state, action: jax.Array, env: Environment):
    state, obs, reward, info = _step_flat(state, action, env)
    scalars = jnp.stack([reward, *(info[k] for k in sorted(info))]).astype(jnp.float32)
    return state, jnp.concatenate([obs, scalars])


step_packed = jax.jit(_step_packed)
"""Jitted ``(state, action (3,), env) -> (state, packed (D + 1 + K,) float32)``: the flat
observation, the reward and the K info values in sorted key order (``info_layout``), so a
step reaches the host in one transfer rather than K + 2 (measured: CatchEnv.step 0.9 ->
0.3 ms on two busy cores)."""

_INFO_LAYOUTS: dict = {}


def info_layout(state, env: Environment) -> tuple[tuple[str, bool], ...]:
    """(key, is_bool) of ``env``'s step info in sorted key order; traced once per static
    structure of ``env`` (behaviour, backend), as compilation is."""
    treedef = jax.tree.structure(env)
    if treedef not in _INFO_LAYOUTS:
        action = jax.ShapeDtypeStruct(env.action_spec.shape, jnp.float32)
        info = jax.eval_shape(_step_flat, state, action, env)[3]
        _INFO_LAYOUTS[treedef] = tuple((k, info[k].dtype == jnp.bool_) for k in sorted(info))
    return _INFO_LAYOUTS[treedef]


class CatchEnv(gymnasium.Env[np.ndarray, np.ndarray]):
    """One legged robot catching one target.

    Args:
        behavior: target behaviour, a key of ``dyncatch.sim.behaviors.BEHAVIORS``; it
            replaces ``world.target.behavior`` (None: the world's own).
        world: the world config (default ``WorldCfg()``, the library's training default,
            the same reward ``dyncatch train`` uses).
        speed_mps: fix the target speed (``WorldCfg.with_speed``); None keeps the range.
        render_mode: None, or "rgb_array": ``render()`` returns the top-down drawing of the
            current state, (render_size_px, render_size_px, 3) uint8.
        env: the backend (``dyncatch.sim.api``); default the JAX world (a backend whose
            state lacks the JAX world's ``robot``, ``target`` and ``sensor`` cannot render).
        render_size_px: width and height of the rendered frames in pixels.

    ``reset(seed=s)`` starts from ``seed_to_key(s)``; ``reset()`` draws a key from
    ``self.np_random``, so ``reset(seed=s)`` followed by resets without seed is a
    reproducible sequence. ``reset(options={"behavior": name, "speed_mps": v})`` sets the
    behaviour and the target speed (None: the speed range it was built with) for this and
    every later episode. Actions outside ``action_space`` are clipped by the simulator; an
    action with a NaN or an infinity is refused (ValueError), since no clipping can give it
    a meaning, and the state is left as it was.

    Building one makes "spawn" the multiprocessing start method if the program chose none
    (``spawn_workers_by_default``), so ``gymnasium.make_vec("dyncatch/Catch-v0",
    vectorization_mode="async")`` works: forked workers deadlock once JAX has started.
    """

    metadata = {"render_modes": list(RENDER_MODES), "render_fps": 50}

    def __init__(
        self,
        behavior: str | None = None,
        world: WorldCfg | None = None,
        speed_mps: float | None = None,
        render_mode: str | None = None,
        env: Environment | None = None,
        render_size_px: int = 480,
    ) -> None:
        check_render_mode(render_mode)
        spawn_workers_by_default()
        self.env = make_env(behavior, world, speed_mps, env)
        self.world = self.built_world = self.env.world
        self.render_mode = render_mode
        self.metadata = {**self.metadata, **render_metadata(self.world)}
        self.observation_space = observation_space(self.env)
        self.action_space = action_space(self.env)
        self._frames = StateFrames(self.world, render_size_px) if render_mode else None
        self._state = None

    @property
    def state(self):
        """The simulator state (a pytree of JAX arrays); only after ``reset``."""
        if self._state is None:
            raise RuntimeError("call reset() before using the environment")
        return self._state

    def reset(
        self, *, seed: int | None = None, options: dict[str, Any] | None = None
    ) -> tuple[np.ndarray, dict[str, Any]]:
        """Start an episode. Returns (obs (D,) float32, {}), D = ``sim.api.obs_dim(world)``.

        ``options`` (``gym.options.RESET_OPTIONS``): ``behavior`` (a behaviour name) and
        ``speed_mps`` (a fixed target speed in m/s, or None for the built range); they
        hold for later episodes too. Any other key raises ValueError naming the allowed.
        """
        if options:
            self._set_env(apply_reset_options(self.env, options, self.built_world))
        super().reset(seed=seed)
        if seed is None:
            seed = int(self.np_random.integers(_UINT32))
        self._state, obs = reset_flat(seed_to_key(seed), self.env)
        if self._frames is not None:
            self._frames.start(self._state)
        return np.array(obs, np.float32), {}

    def _set_env(self, env: Environment) -> None:
        """Step ``env`` from now on; refused if its spaces differ (they are fixed)."""
        check_same_spaces(env, self.observation_space, self.action_space)
        self.env, self.world = env, env.world
        if self._frames is not None:
            self._frames.set_world(env.world)

    def step(
        self, action: np.ndarray
    ) -> tuple[np.ndarray, float, bool, bool, dict[str, bool | float]]:
        """One control step under the base command ``action`` (3,).

        Returns (obs (D,) float32, reward, terminated, truncated, info); info is the
        simulator's step info (``reward/<name>``, ``success``, ``terminated``,
        ``truncated``, ``distance_m``, ...; see ``sim.env.step``) as Python scalars.
        """
        action = np.asarray(action, np.float32)
        if action.shape != self.action_space.shape:
            raise ValueError(
                f"action must have shape {self.action_space.shape}, got {action.shape}"
            )
        if not np.isfinite(action).all():
            raise ValueError(f"action must be finite (no NaN or infinity), got {action}")
        layout = info_layout(self.state, self.env)
        self._state, packed = step_packed(self.state, action, self.env)
        if self._frames is not None:
            self._frames.push(self._state)
        packed = np.asarray(packed)
        dim = self.observation_space.shape[0]
        info = {
            key: bool(value) if is_bool else float(value)
            for (key, is_bool), value in zip(layout, packed[dim + 1 :], strict=True)
        }
        return packed[:dim].copy(), float(packed[dim]), info["terminated"], info["truncated"], info

    def render(self) -> np.ndarray | None:
        """The current state drawn top-down, (H, W, 3) uint8, with render_mode="rgb_array":
        the arena, robot, camera cone, arm reach, gripper, target with its last 2 s and the
        held sighting (``viz.render.TopDownDrawer``). None (with a warning) without a mode."""
        if self._frames is None:
            logger.warn("render() was called with render_mode=None; pass render_mode='rgb_array'")
            return None
        return self._frames.frame(self.state)
