"""Interaction data of Section III-B: the robot placed around the target, moving, filmed at 2 Hz.

Every environment plays one episode of ``episode.max_steps`` control steps (no auto-reset, so
camera frames stay aligned with episode time). At each camera frame the robot either pursues
the target for the next frame period or holds a uniformly random command. A sample is the
history at frame t (``features.History``, in the simulator's robot-centred frame) and the
label v = (p_{t+1} - p_t) / dt_vis from the true world positions of the target at the
captures; it is kept only where frames t-1 and t both saw the
target. "Interaction steps" are simulator (control) steps: num_envs x max_steps.

Environment ``i`` of a seed is the same whatever the chunking, so the data of a small budget
is a prefix of the data of a larger one (Table II's budgets are nested).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from dyncatch.policies.pursuit import PursuitPolicy
from dyncatch.predictor.config import CollectCfg
from dyncatch.predictor.features import History, history_from_state
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.env import observe, reset, step
from dyncatch.sim.frame import to_scene
from dyncatch.sim.sensing import latency_steps, period_steps
from dyncatch.sim.validate import validate_world


@struct.dataclass
class Samples:
    """Valid samples, in environment order (numpy leaves, leading axis N)."""

    history: History
    label_mps: np.ndarray
    """(N, 2) true mean target velocity over the next camera period."""
    env_index: np.ndarray
    """(N,) the environment each sample came from (budget prefixes select on it)."""


def episode_key(key: jax.Array, env_index: int | jax.Array) -> jax.Array:
    return jax.random.fold_in(key, env_index)


def frame_plan(key: jax.Array, plan, world: WorldCfg, cfg: CollectCfg):
    """The plan (pursue () bool, random command (3,)) for the next frame period: the current
    ``plan`` kept, or a new one with probability ``cfg.replan_prob``."""
    k_new, k_mode, k_cmd = jax.random.split(key, 3)
    b = world.base
    lo = jnp.array([-b.max_backward_mps, -b.max_lateral_mps, -b.max_yaw_rate_rps])
    hi = jnp.array([b.max_forward_mps, b.max_lateral_mps, b.max_yaw_rate_rps])
    command = jax.random.uniform(k_cmd, (3,), minval=lo, maxval=hi)
    new = (jax.random.bernoulli(k_mode, cfg.pursuit_prob), command)
    replan = jax.random.bernoulli(k_new, cfg.replan_prob)
    return jax.tree.map(lambda a, b: jnp.where(replan, a, b), new, plan)


def plan_action(state, pursue: jax.Array, command: jax.Array, world: WorldCfg) -> jax.Array:
    chase = PursuitPolicy(world)(observe(state, world), jax.random.key(0))
    return jnp.where(pursue, chase, command)


def frame_period(world: WorldCfg) -> int:
    """Control steps per camera frame, as a Python int (call outside jit)."""
    return int(period_steps(world))


def num_frames(world: WorldCfg) -> int:
    """Camera frames with a label in one episode (the last frame only closes a label)."""
    return int(world.episode.max_steps) // frame_period(world)


def steps_per_env(world: WorldCfg) -> int:
    return num_frames(world) * frame_period(world)


def episode_samples(key: jax.Array, world: WorldCfg, cfg: CollectCfg, frames: int, period: int):
    """One environment's episode of ``frames`` x ``period`` steps (both static) ->
    (history (frames, ...), label (frames, 2), valid (frames,))."""
    k_reset, k_first, k_frames = jax.random.split(key, 3)
    lag = latency_steps(world)

    def frame(carry, k):
        state, plan = carry
        plan = frame_plan(jax.random.fold_in(k_frames, k), plan, world, cfg)
        pursue, command = plan
        # World position: the stored one moves with the robot-centred frame every step, so a
        # difference of stored positions would be the velocity relative to the robot.
        capture_xy = to_scene(state, state.target.xy_m)
        # Frame k is delivered `lag` steps after its capture; with no latency, right now.
        snap = (history_from_state(state), state.sensor.consecutive)

        def control(carry, i):
            state, snap = carry
            state, *_ = step(state, plan_action(state, pursue, command, world), world)
            now = (history_from_state(state), state.sensor.consecutive)
            snap = jax.tree.map(lambda a, b: jnp.where(i + 1 == lag, a, b), now, snap)
            return (state, snap), None

        (state, (hist, ok)), _ = jax.lax.scan(control, (state, snap), jnp.arange(period))
        return (state, plan), (hist, ok, capture_xy)

    # The first plan is always new: replan_prob only governs later frames.
    always = dataclasses.replace(cfg, replan_prob=1.0)
    first = frame_plan(k_first, (jnp.zeros((), bool), jnp.zeros(3)), world, always)
    init = (reset(k_reset, world), first)
    (state, _), (hist, ok, xy) = jax.lax.scan(frame, init, jnp.arange(frames))
    xy = jnp.concatenate([xy, to_scene(state, state.target.xy_m)[None]])
    label = (xy[1:] - xy[:-1]) / (period * world.episode.dt_s)
    return hist, label, ok


@partial(jax.jit, static_argnames=("cfg", "frames", "period"))
def _collect_chunk(key, first_env, world: WorldCfg, cfg: CollectCfg, frames: int, period: int):
    index = first_env + jnp.arange(cfg.envs_per_chunk)
    keys = jax.vmap(episode_key, in_axes=(None, 0))(key, index)
    run = jax.vmap(episode_samples, in_axes=(0, None, None, None, None))
    return run(keys, world, cfg, frames, period)


def collect(
    key: jax.Array,
    world: WorldCfg,
    cfg: CollectCfg,
    num_steps: int,
    on_chunk: Callable[[int], None] | None = None,
) -> tuple[Samples, int]:
    """Samples from at least ``num_steps`` interaction steps; returns (samples, steps used).

    ``world`` is the simulated world; ``cfg.interaction_world`` sets its episode length and
    robot placement for the collection.

    Steps are used in whole episodes and whole chunks of ``cfg.envs_per_chunk`` environments;
    ``on_chunk(steps_done)`` is called after each chunk (for progress bars).
    """
    world = cfg.interaction_world(world)
    per_env = steps_per_env(world)
    frames, period = num_frames(world), frame_period(world)
    envs = -(-num_steps // per_env)
    chunks = -(-envs // cfg.envs_per_chunk)
    parts = []
    for c in range(chunks):
        first = c * cfg.envs_per_chunk
        hist, label, ok = jax.device_get(
            _collect_chunk(key, jnp.asarray(first), world, cfg, frames, period)
        )
        env = np.broadcast_to((first + np.arange(cfg.envs_per_chunk))[:, None], ok.shape)
        keep = ok & (env < envs)
        parts.append((jax.tree.map(lambda a, m=keep: a[m], hist), label[keep], env[keep]))
        if on_chunk is not None:
            on_chunk(min(first + cfg.envs_per_chunk, envs) * per_env)
    hist = jax.tree.map(lambda *a: np.concatenate(a), *[p[0] for p in parts])
    samples = Samples(
        history=hist,
        label_mps=np.concatenate([p[1] for p in parts]),
        env_index=np.concatenate([p[2] for p in parts]),
    )
    return samples, envs * per_env


def budget_count(samples: Samples, world: WorldCfg, cfg: CollectCfg, budget_steps: int) -> int:
    """How many leading samples come from the first ``budget_steps`` interaction steps."""
    envs = budget_steps // steps_per_env(cfg.interaction_world(world))
    return int(np.searchsorted(samples.env_index, envs, side="left"))


def check_world(world: WorldCfg, behaviors, budgets, collect: CollectCfg) -> None:
    """Raise naming the flag when a behaviour or a budget cannot work in ``world``."""
    for b in behaviors:
        validate_world(world.with_behavior(b))
    per_env = steps_per_env(collect.interaction_world(world))
    for n in budgets:
        if n < per_env:
            raise ValueError(f"budget {n} steps is below one episode ({per_env}): raise it")
