"""Record one episode of one environment as per-step numpy arrays (for plots and videos).

Row 0 is the state right after ``reset`` (time 0); row k is the state after k control steps
(time k * dt). The rollout is one jitted ``lax.scan`` over the episode limit with no
auto-reset; rows after the first ``done`` are dropped on the host.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from typing import Any

import jax
import jax.numpy as jnp
import numpy as np

from dyncatch.policies.api import as_recurrent
from dyncatch.policies.blend import blend_weights, collid_scan_m
from dyncatch.sim.api import Environment, as_env
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.frame import to_scene
from dyncatch.sim.obstacles import line_of_sight
from dyncatch.sim.scan import robot_clearance_m
from dyncatch.sim.sensing import in_view
from dyncatch.sim.state import EnvState, Obs

ExtraFn = Callable[[EnvState, Obs], dict[str, jax.Array]]

STATE_KEYS = (
    "step",
    "time_s",
    "robot_xy_m",
    "robot_yaw_rad",
    "robot_speed_mps",
    "gripper_xyz_m",
    "target_xy_m",
    "target_speed_mps",
    "obs_xy_m",
    "visible",
    "ever_seen",
    "success",
    "obstacle_xy_m",
    "obstacle_half_m",
    "obstacle_radius_m",
)
"""The values of one state that the renderer draws (``state_row``; ``time_s`` on the host)."""
BUILTIN_KEYS = (*STATE_KEYS, "done")


def state_row(state: EnvState) -> dict[str, jax.Array]:
    """The drawn values of a state, every ``STATE_KEYS`` entry but ``time_s`` (which is
    ``step * dt_s``, computed on the host in float64), positions in world coordinates (they
    are stored relative to the robot, ``sim.frame``). Works on a batch too: each value then
    has the state's leading axes, e.g. ``robot_xy_m`` (num_envs, 2)."""
    gripper = state.robot.gripper_xyz_m
    return {
        "step": state.step,
        "robot_xy_m": to_scene(state, state.robot.xy_m),
        "robot_yaw_rad": state.robot.yaw_rad,
        "robot_speed_mps": jnp.linalg.norm(state.robot.vel_body_mps, axis=-1),
        "gripper_xyz_m": jnp.concatenate(
            [to_scene(state, gripper[..., :2]), gripper[..., 2:]], axis=-1
        ),
        "target_xy_m": to_scene(state, state.target.xy_m),
        "target_speed_mps": state.target.speed_mps,
        "obs_xy_m": to_scene(state, state.sensor.obs_xy_m),
        "visible": state.sensor.visible,
        "ever_seen": state.sensor.ever_seen,
        "success": state.success,
        # (..., K, 2): the origin broadcasts over the obstacles of each state.
        "obstacle_xy_m": state.obstacles.centre_xy_m + state.origin_xy_m[..., None, :],
        "obstacle_half_m": state.obstacles.half_m,
        "obstacle_radius_m": state.obstacles.radius_m,
    }


@dataclasses.dataclass(frozen=True)
class SceneExtras:
    """``extra_fn`` of a scene with obstacles (``scene_extras``): per row ``scan_m`` (N,)
    (pi_collid's own scan where a blend is given, else the observation's), ``occluded`` ()
    bool (the target is in the camera's cone and range but an obstacle hides it) and, with
    a blend, ``blend_w_c`` () (eq. 10's pi_collid weight)."""

    world: WorldCfg
    blend: Any = None
    """A ``policies.blend.BlendCfg``, or None."""

    def __call__(self, state: EnvState, obs: Obs) -> dict[str, jax.Array]:

        robot, target = state.robot, state.target
        hidden = ~line_of_sight(state.obstacles, robot.xy_m, target.xy_m)
        out = {"occluded": in_view(robot, target.xy_m, self.world) & hidden}
        if self.blend is None:
            out["scan_m"] = obs.scan_m
        else:
            out["scan_m"] = collid_scan_m(state, self.world, self.blend.collid)
            _, out["blend_w_c"] = blend_weights(robot_clearance_m(state, self.world), self.blend)
        return out


def scene_extras(world: WorldCfg, blend=None) -> SceneExtras:
    """What ``record_episode`` records for the renderer to draw the range scan, occluded
    sightings and the blend weight (``blend``: a ``BlendCfg`` or None)."""
    return SceneExtras(world, blend)


def _snapshot(state: EnvState, done: jax.Array, extra_fn, obs: Obs) -> dict:
    """The recorded values of one state (one row of the trajectory)."""
    row = {**state_row(state), "done": done}
    if extra_fn is not None:
        extra = extra_fn(state, obs)
        clash = sorted(set(extra) & set(BUILTIN_KEYS))
        if clash:
            raise ValueError(f"extra_fn returned built-in keys {clash}; rename them")
        row.update(extra)
    return row


def _rollout_impl(
    policy: Callable, key: jax.Array, env: Environment, num_steps: int, extra_fn: ExtraFn | None
) -> dict[str, jax.Array]:
    """Rows of ``num_steps + 1`` states: each value has a leading axis of that length."""
    k_reset, k_act = jax.random.split(key)
    state = env.reset(k_reset)
    obs = env.observe(state)
    first = _snapshot(state, jnp.zeros((), bool), extra_fn, obs)
    pol = as_recurrent(policy)

    def body(carry, t):
        state, obs, pcarry = carry
        pcarry, action = pol.step(pcarry, state, obs, jax.random.fold_in(k_act, t))
        state, obs, _, done, _ = env.step(state, action)
        return (state, obs, pcarry), _snapshot(state, done, extra_fn, obs)

    init = (state, obs, pol.init_carry(state, obs))
    _, rows = jax.lax.scan(body, init, jnp.arange(num_steps))
    return jax.tree.map(lambda a, b: jnp.concatenate([a[None], b]), first, rows)


_rollout_static = jax.jit(_rollout_impl, static_argnames=("policy", "num_steps", "extra_fn"))
_rollout_pytree = jax.jit(_rollout_impl, static_argnames=("num_steps", "extra_fn"))


def _rollout(policy, key, env, num_steps, extra_fn):
    """Pytree policies (``is_pytree_policy``) are jit arguments; others are static."""
    run = _rollout_pytree if getattr(policy, "is_pytree_policy", False) else _rollout_static
    return run(policy, key, env, num_steps, extra_fn)


def record_episode(
    policy: Callable,
    key: jax.Array,
    cfg: Environment | WorldCfg,
    max_steps: int | None = None,
    extra_fn: ExtraFn | None = None,
) -> dict[str, np.ndarray]:
    """Play one episode of ``policy(obs, key) -> action`` and return it row by row.

    Args:
        policy: a pure ``(obs, key) -> action (3,)``; it is a static jit argument, so pass
            the same object to reuse the compiled rollout.
        key: PRNG key of the episode (reset and policy keys are split from it).
        cfg: the world, or a backend of ``dyncatch.sim.api`` (its state must carry the
            JAX world's ``robot``, ``target`` and ``sensor`` fields, which are recorded).
        max_steps: steps to simulate; defaults to the episode limit ``cfg.episode.max_steps``.
        extra_fn: optional ``(state, obs) -> {name: array}`` recorded per row next to the
            built-in values (e.g. ``pred_vel_mps`` (2,), which the renderer draws as an arrow).

    Returns:
        ``{name: (T, ...)}`` with T = 1 + steps up to and including the first ``done`` (all
        rows if the episode never ends within ``max_steps``): ``step`` (T,) int,
        ``time_s`` (T,) float64, ``robot_xy_m`` (T, 2), ``robot_yaw_rad`` (T,),
        ``robot_speed_mps`` (T,), ``gripper_xyz_m`` (T, 3), ``target_xy_m`` (T, 2),
        ``target_speed_mps`` (T,),
        ``obs_xy_m`` (T, 2) (the held sighting), ``visible`` / ``ever_seen`` / ``success`` /
        ``done`` (T,) bool, and the ``extra_fn`` values.
    """
    env = as_env(cfg)
    cfg = env.world
    num_steps = int(cfg.episode.max_steps) if max_steps is None else int(max_steps)
    if num_steps < 1:
        raise ValueError(f"max_steps must be at least 1, got {num_steps}")
    rows = jax.device_get(_rollout(policy, key, env, num_steps, extra_fn))
    done = np.asarray(rows["done"])
    end = int(np.argmax(done)) + 1 if done.any() else len(done)
    traj = {name: np.asarray(value)[:end] for name, value in rows.items()}
    # On the host in float64, so that times are exact multiples of dt.
    traj["time_s"] = traj["step"] * cfg.episode.dt_s
    return traj


def catch_time_s(traj: dict[str, np.ndarray]) -> float | None:
    """Time of the first successful row of a recorded episode, or None if never caught."""
    hits = np.flatnonzero(traj["success"])
    return float(traj["time_s"][hits[0]]) if hits.size else None
