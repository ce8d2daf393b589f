"""Interaction data of the tracker: the predictor's robot-target episodes at the control rate.

Every environment plays one episode (no auto-reset) in which the robot pursues the target
or holds a random command, re-planned at camera frames as in ``predictor.data``. The tracker
ingests every state; each control step with at least one sighting behind it is a sample:
the encoded memory, the extrapolation base and the true target position and velocity in
the newest capture frame. Nothing is discarded for lack of consecutive sightings: gaps
(out of view, occluded) are what the tracker must bridge.

Environment ``i`` of a seed is the same whatever the chunking (``predictor.data``), so a
small budget's data are a prefix of a larger one's.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct

from dyncatch.predictor.config import CollectCfg
from dyncatch.predictor.data import episode_key, frame_plan, plan_action
from dyncatch.predictor.tracker.memory import capture_frame_point
from dyncatch.predictor.tracker.model import Tracker
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.env import reset, step
from dyncatch.sim.geometry import world_to_body
from dyncatch.sim.sensing import period_steps


@struct.dataclass
class TrackSamples:
    """Samples in environment order (numpy leaves, leading axis N)."""

    x: np.ndarray
    """(N, D) encoded inputs."""
    base: np.ndarray
    """(N, 4) constant-velocity base: position then velocity, capture frame."""
    label: np.ndarray
    """(N, 4) true target position (m) then velocity (m/s), capture frame."""
    hold_m: np.ndarray
    """(N, 2) the newest sighting, capture frame (the sample-and-hold estimate)."""
    since_sighting_s: np.ndarray
    """(N,) time since the newest sighting's capture."""
    remembered: np.ndarray
    """(N,) how many sightings the memory held (1 to ``TrackerCfg.memory``)."""
    env_index: np.ndarray
    """(N,) the environment each sample came from."""


def episode_track(key: jax.Array, world: WorldCfg, cfg: CollectCfg, tracker: Tracker, steps: int):
    """One environment's episode of ``steps`` control steps (static) -> per step
    (x (T, D), base (T, 4), label (T, 4), hold (T, 2), tau (T,), count (T,), valid (T,))."""
    k_reset, k_first, k_frames = jax.random.split(key, 3)
    period = period_steps(world)

    def sample(memory, state):
        x, base = tracker.encode(memory, state)
        pose = state.sensor.robot_pose
        label = jnp.concatenate(
            [
                capture_frame_point(state, state.target.xy_m),
                world_to_body(state.target.vel_mps, pose[2]),
            ]
        )
        tau = state.sensor.time_since_seen_s
        count = jnp.sum(memory.valid.astype(jnp.int32))
        return x, base, label, memory.sight_m[0], tau, count, memory.valid[0]

    def control(carry, t):
        state, plan, memory = carry
        new_plan = frame_plan(jax.random.fold_in(k_frames, t), plan, world, cfg)
        plan = jax.tree.map(lambda a, b: jnp.where(t % period == 0, a, b), new_plan, plan)
        state, *_ = step(state, plan_action(state, *plan, world), world)
        memory = tracker.ingest(memory, state)
        return (state, plan, memory), sample(memory, state)

    always = dataclasses.replace(cfg, replan_prob=1.0)
    first = frame_plan(k_first, (jnp.zeros((), bool), jnp.zeros(3)), world, always)
    state = reset(k_reset, world)
    memory = tracker.ingest(tracker.init_carry(), state)
    _, out = jax.lax.scan(control, (state, first, memory), jnp.arange(1, steps + 1))
    return out


@partial(jax.jit, static_argnames=("cfg", "tracker", "steps", "every"))
def _collect_chunk(key, first_env, world, cfg: CollectCfg, tracker: Tracker, steps, every):
    index = first_env + jnp.arange(cfg.envs_per_chunk)
    keys = jax.vmap(episode_key, in_axes=(None, 0))(key, index)
    out = jax.vmap(episode_track, in_axes=(0, None, None, None, None))(
        keys, world, cfg, tracker, steps
    )
    return jax.tree.map(lambda a: a[:, every - 1 :: every], out)


def collect_track(
    key: jax.Array,
    world: WorldCfg,
    cfg: CollectCfg,
    tracker: Tracker,
    num_steps: int,
    every: int = 1,
    on_chunk: Callable[[int], None] | None = None,
) -> tuple[TrackSamples, int]:
    """Samples from at least ``num_steps`` interaction steps, every ``every``-th control
    step of each episode; returns (samples, steps used). ``cfg.interaction_world`` sets the
    episode length and robot placement."""
    world = cfg.interaction_world(world)
    steps = int(world.episode.max_steps)
    envs = -(-num_steps // steps)
    chunks = -(-envs // cfg.envs_per_chunk)
    parts = []
    for c in range(chunks):
        first = c * cfg.envs_per_chunk
        x, base, label, hold, tau, count, ok = jax.device_get(
            _collect_chunk(key, jnp.asarray(first), world, cfg, tracker, steps, every)
        )
        env = np.broadcast_to((first + np.arange(cfg.envs_per_chunk))[:, None], ok.shape)
        keep = ok & (env < envs)
        parts.append(
            TrackSamples(
                x[keep], base[keep], label[keep], hold[keep], tau[keep], count[keep], env[keep]
            )
        )
        if on_chunk is not None:
            on_chunk(min(first + cfg.envs_per_chunk, envs) * steps)
    samples = jax.tree.map(lambda *a: np.concatenate(a), *parts)
    return samples, envs * steps


def budget_rows(samples: TrackSamples, world: WorldCfg, cfg: CollectCfg, budget_steps: int) -> int:
    """How many leading samples come from the first ``budget_steps`` interaction steps."""
    envs = budget_steps // int(cfg.interaction_world(world).episode.max_steps)
    return int(np.searchsorted(samples.env_index, envs, side="left"))
