"""Small rollout helpers shared by the simulator tests."""

from __future__ import annotations

import math
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np

from dyncatch.sim import env
from dyncatch.sim.base import command_high, command_low
from dyncatch.sim.behaviors.evader_net import EvaderNet
from dyncatch.sim.behaviors.learned import EVADER_OBS_DIM, FEATURE_NAMES
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.frame import in_scene_frame, recentre
from dyncatch.sim.state import EnvState


@partial(jax.jit, static_argnames=("num_envs", "num_steps"))
@partial(jax.jit, static_argnames=("num_envs", "num_steps"))
def random_rollout(key: jax.Array, cfg: WorldCfg, num_envs: int, num_steps: int):
    """Random commands (held for 0.5 s, drawn 20 % beyond the limits to test clipping).

    Returns per-step (T, B, ...) states and infos; no auto-reset, episodes may end early
    (later steps of an ended episode keep running and are masked with ``alive``).
    """
    k_reset, k_act = jax.random.split(key)
    state = jax.vmap(env.reset, in_axes=(0, None))(jax.random.split(k_reset, num_envs), cfg)
    lo, hi = command_low(cfg.base) * 1.2, command_high(cfg.base) * 1.2
    vstep = jax.vmap(env.step, in_axes=(0, 0, None))

    def body(carry, t):
        state, action, alive = carry
        k = jax.random.fold_in(k_act, t)
        fresh = jax.random.uniform(k, (num_envs, 3), minval=lo, maxval=hi)
        action = jnp.where(t % 25 == 0, fresh, action)
        state, _, reward, done, info = vstep(state, action, cfg)
        out = (state, info, reward, alive)
        return (state, action, alive & ~done), out

    init = (state, jnp.zeros((num_envs, 3)), jnp.ones(num_envs, bool))
    _, (states, infos, rewards, alive) = jax.lax.scan(body, init, jnp.arange(num_steps))
    return states, infos, rewards, alive


@partial(jax.jit, static_argnames=("num_steps",))
def fixed_rollout(state, action: jax.Array, cfg: WorldCfg, num_steps: int):
    """One environment under a constant command; returns the (T, ...) states and infos."""

    def body(s, _):
        s, obs, reward, done, info = env.step(s, action, cfg)
        return s, (s, obs, info)

    _, out = jax.lax.scan(body, state, None, length=num_steps)
    return out


def place(
    state: EnvState,
    robot_xy=None,
    robot_yaw=None,
    target_xy=None,
    heading=None,
) -> EnvState:
    """``state`` with the bodies put at the given world positions (m) and headings (rad),
    returned in the robot-centred frame as ``reset`` returns it; ``distance_m`` follows."""
    s = in_scene_frame(state)
    robot, target = s.robot, s.target
    f32 = partial(jnp.asarray, dtype=jnp.float32)
    if robot_xy is not None:
        robot = robot.replace(xy_m=f32(robot_xy))
    if robot_yaw is not None:
        robot = robot.replace(yaw_rad=f32(robot_yaw))
    if target_xy is not None:
        target = target.replace(xy_m=f32(target_xy))
    if heading is not None:
        target = target.replace(heading_rad=f32(heading))
    s = s.replace(robot=robot, target=target, distance_m=jnp.linalg.norm(target.xy_m - robot.xy_m))
    return recentre(s)


def world_xy(states: EnvState, xy_m: jax.Array) -> jax.Array:
    """Stored positions (..., 2) of ``states`` (any leading axes) in world coordinates."""
    return xy_m + states.origin_xy_m


def obstacles(boxes=(), cylinders=(), period_m: float = 0.0):
    """An ``Obstacles`` layout by hand: boxes as (cx, cy, hx, hy), cylinders as (cx, cy, r);
    ``period_m`` > 0 repeats it over the plane (the woods' tiling)."""
    from dyncatch.sim.obstacles import Obstacles

    centre = [b[:2] for b in boxes] + [c[:2] for c in cylinders]
    half = [b[2:] for b in boxes] + [(0.0, 0.0)] * len(cylinders)
    radius = [0.0] * len(boxes) + [c[2] for c in cylinders]
    f32 = jnp.float32
    return Obstacles(
        jnp.asarray(centre, f32).reshape(-1, 2),
        jnp.asarray(half, f32).reshape(-1, 2),
        jnp.asarray(radius, f32),
        jnp.asarray(period_m, f32),
        jnp.zeros(2, f32),
    )


def away_net(
    gain: float = -1.0, action_std: float | None = None, bias: float = 0.0, frame: str = "heading"
) -> EvaderNet:
    """A hand-made evader of one linear layer: turn = clip(gain * robot_rel_left_m + bias,
    -1, 1) * pi (away from a robot on its left for a negative gain), added to ``frame``'s
    angle; identity normaliser."""
    kernel = np.zeros((EVADER_OBS_DIM, 1), np.float32)
    kernel[FEATURE_NAMES.index("robot_rel_left_m"), 0] = gain
    return EvaderNet(
        ((kernel, np.full(1, bias, np.float32)),),
        np.zeros(EVADER_OBS_DIM, np.float32),
        np.ones(EVADER_OBS_DIM, np.float32),
        math.pi,
        {"features": list(FEATURE_NAMES)},
        action_std,
        frame,
    )
