"""The catch task on the full body behind the environment protocol: ``MujocoCatchEnv``.

The episodes, the target, the camera, the reward and the catch test are the JAX world's
(``sim.env``); only the robot is replaced by the MuJoCo Aliengo + Z1 under the trot and the
arm's DLS IK (``FullBodyEnv``). ``dyncatch eval RUN --backend mujoco`` plays it through the
JAX backend's episode loop (``evaluation.episodes.run_episodes``). One 50 Hz step:

1. **Target (JAX).** ``plan_target`` splits the state's key as ``sim.env.step`` does, turns
   the target from the measured robot (``sim.env.turn_target``) and moves it through the
   step's sub-steps (``sim.target.move``): its ``n_sub + 1`` positions.
2. **Robot (MuJoCo, through ``jax.experimental.io_callback``).** The step's sub-steps are
   control periods of the episode's full body (4 x 200 Hz): the clipped command goes to the
   trot; the arm's goal, the target's centre ``catch_offset_m`` up (as ``sim.arm`` aims),
   goes to the IK while the target is within ``activation_distance_m`` of the trunk, else
   the arm stows. The catch-point error is taken before each period and after the last, as
   the JAX world takes it before each sub-step and at the end.
3. **The rest (JAX).** The measured robot (trunk position and yaw, heading-frame velocity,
   arm joints, gripper) replaces the reduced one and ``sim.env.finish_step`` does what the
   JAX world does after its physics: the catch, the camera, the reward, the frame, the end.

An evaluation-only backend: the full bodies are host state (one ``mujoco.MjData`` each), held
by a ``FullBodies`` pool for the duration of a ``with`` block; a state names its body, so a
state must be stepped once, in order, as an episode loop does (no replay, no auto-reset).
``reset`` takes a new body; once an episode has ended its body stops (no more MuJoCo time).
Under ``vmap`` the bodies are stepped one after another. The same key gives the same initial
states and target noise as the JAX backend, so rows of both compare episode for episode. The
reduced model's gait noise has no counterpart: the trot's own ripple is the noise. A robot
that falls stays where it fell and catches nothing (``info["fell"]``). The full body's
constants are ``FullBodyCfg``'s defaults with the world's ``ArmCfg`` (its gait follows
``FullBodyCfg.base``, whatever base the policy was trained on); flat, open ground only.
"""

from __future__ import annotations

import dataclasses
import itertools
from collections.abc import Callable
from functools import partial
from typing import NamedTuple

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct
from jax.experimental import io_callback

from dyncatch.fullbody.config import FullBodyCfg
from dyncatch.fullbody.env import FullBodyEnv
from dyncatch.fullbody.gait import yaw_of
from dyncatch.fullbody.model import build_model
from dyncatch.sim.api import Environment, JaxCatchEnv, Spec, as_env
from dyncatch.sim.base import clip_command
from dyncatch.sim.behaviors import get_behavior
from dyncatch.sim.config import WorldCfg
from dyncatch.sim.draws import step_draws
from dyncatch.sim.env import finish_step, observe, turn_target
from dyncatch.sim.env import reset as sim_reset
from dyncatch.sim.scenes import get_scene
from dyncatch.sim.state import EnvState, Obs
from dyncatch.sim.target import move


def check_world(world: WorldCfg, fullbody: FullBodyCfg) -> None:
    """Refuse what the full body cannot run, naming the setting to change."""
    scene = get_scene(world.scene.name)
    if scene.walls or scene.layout is not None or scene.terrain is not None:
        raise ValueError(
            f"--backend mujoco runs on flat open ground only; scene {world.scene.name!r} has "
            "walls, obstacles or terrain: use --world.scene.name open_plane"
        )
    if world.arm.aim != "true":
        raise ValueError(
            f"--backend mujoco aims the arm at the target itself; arm.aim = {world.arm.aim!r} "
            "is a reading of the JAX world only: use --world.arm.aim true"
        )
    rate = world.episode.control_hz * world.episode.physics_substeps
    if abs(rate - fullbody.control_hz) > 1e-6:
        raise ValueError(
            f"the world's sub-steps run at {rate} Hz (episode.control_hz x "
            f"episode.physics_substeps), the full body's control at {fullbody.control_hz} Hz: "
            "they must be equal"
        )


def plan_target(state: EnvState, action: jax.Array, cfg: WorldCfg):
    """``sim.env.step``'s draws and target without its base: ``(command (3,), target after the
    step, target xy before each sub-step and after the last (n_sub + 1, 2), next key, camera
    noise (2,))``, positions in ``state``'s frame. The target sees the measured robot (no gait
    noise) and no obstacles (the full body runs on the open plane only)."""
    draws = step_draws(state.key)
    n_sub = cfg.episode.physics_substeps
    reflect = get_behavior(cfg.target.behavior).reflects_off_walls
    walls = get_scene(cfg.scene.name).walls
    target = turn_target(state.target, state.robot, None, draws.behavior_key, cfg)
    xys = [target.xy_m]
    for _ in range(n_sub):
        dt_s = cfg.episode.dt_s / n_sub
        target = move(target, cfg.target, cfg.arena, state.origin_xy_m, dt_s, reflect, walls)
        xys.append(target.xy_m)
    return clip_command(action, cfg.base), target, jnp.stack(xys), draws.next_key, draws.sense_noise


@struct.dataclass
class FullBodyState(EnvState):
    """``EnvState`` with the robot measured on the full body (what policies read), and which
    body is the episode's."""

    body: jax.Array
    """() int32: the episode's full body in its ``FullBodies``."""
    ended: jax.Array
    """() bool: the episode is over; its body no longer moves."""


def _with_body(state: EnvState, body: jax.Array, ended: jax.Array) -> FullBodyState:
    fields = {f.name: getattr(state, f.name) for f in dataclasses.fields(EnvState)}
    return FullBodyState(**fields, body=body, ended=ended)


class _Reach(NamedTuple):
    """The world's constants the bodies' side reads, as Python floats (static: the world's
    numbers are traced leaves under ``jit``)."""

    target_height_m: float
    catch_offset_m: float
    activation_distance_m: float

    @classmethod
    def of(cls, world: WorldCfg) -> _Reach:
        a = world.arm
        return cls(
            float(world.target.height_m), float(a.catch_offset_m), float(a.activation_distance_m)
        )


class FullBodies:
    """The host side of a full-body evaluation: the bodies ``MujocoCatchEnv``'s states name,
    sharing one compiled ``MjModel``. ``with FullBodies(world) as bodies:`` registers them, and
    ``bodies.env`` is the environment that plays on them.

    ``record``: an episode's index (its body, in the order of the first reset) whose state is
    kept at every 50 Hz step until it ends (``recorded()``; ``benchmarks/fullbody_video.py``).
    ``probe(i, env, goal)``: called after every 200 Hz control period of body ``i`` with its
    ``FullBodyEnv`` and the arm's goal (None while stowed; ``benchmarks/fullbody_falls.py``).
    """

    _live: dict[int, FullBodies] = {}
    _ids = itertools.count()

    def __init__(
        self,
        env_or_world: Environment | WorldCfg,
        fullbody: FullBodyCfg | None = None,
        record: int | None = None,
        probe: Callable | None = None,
    ):
        world = as_env(env_or_world).world
        self.fullbody = FullBodyCfg(arm=world.arm) if fullbody is None else fullbody
        check_world(world, self.fullbody)
        self.id = next(self._ids)
        self.env = MujocoCatchEnv(world, jnp.int32(self.id), self.fullbody, _Reach.of(world))
        self.record, self.probe = record, probe
        self.envs: list[FullBodyEnv] = []
        self.fallen: list[bool] = []
        self.env_steps = 0
        """The 50 Hz steps simulated on the full bodies, over all episodes."""
        self._built = None
        self._qpos, self._target_m = [], []

    def __enter__(self) -> FullBodies:
        FullBodies._live[self.id] = self
        return self

    def __exit__(self, *exc) -> None:
        del FullBodies._live[self.id]

    def recorded(self) -> dict[str, np.ndarray]:
        """The recorded episode as ``qpos`` (T, nq) and ``target_m`` (T, 3) (world frame)."""
        if self.record is None:
            return {}
        return {"qpos": np.array(self._qpos), "target_m": np.array(self._target_m)}

    def reset(self, xy_m, yaw_rad, origin_xy_m) -> np.ndarray:
        """A new body standing at the reduced robot's pose; its index, () int32."""
        if self._built is None:
            self._built = build_model(self.fullbody)
        body = FullBodyEnv(self.fullbody, self._built)
        origin = np.asarray(origin_xy_m, float)
        body.reset(xy_m=tuple(origin + np.asarray(xy_m, float)), yaw_rad=float(yaw_rad))
        self.envs.append(body)
        self.fallen.append(False)
        return np.int32(len(self.envs) - 1)

    def step(self, reach: _Reach, i, ended, command, target_xy_m, origin_xy_m):
        """One control step of body ``i`` while the target passes ``target_xy_m`` (n_sub + 1,
        2) (in the state's frame, whose origin is ``origin_xy_m``), unless its episode has
        ended or it has fallen. Returns the measured robot (``RobotState``'s fields, in the
        state's frame), the smallest catch-point error and whether it has fallen."""
        # The arguments come as arrays of JAX: in float64 numpy, as the bodies compute.
        i, env, ended = int(i), self.envs[int(i)], bool(ended)
        origin = np.asarray(origin_xy_m, float)
        target_xy_m = np.asarray(target_xy_m, float) + origin
        best = np.inf
        if not (ended or self.fallen[i]):
            best = _physics(env, i, np.asarray(command, float), target_xy_m, reach, self.probe)
            self.fallen[i] = env.fallen()
            self.env_steps += 1
        if i == self.record and not ended:
            self._qpos.append(env.data.qpos.copy())
            self._target_m.append(env.data.mocap_pos[env.idx.target_mocap].copy())
        d, idx = env.data, env.idx
        vel = env.base_velocity_heading()
        grip = env.gripper_m()
        f32 = partial(np.asarray, dtype=np.float32)
        return (
            f32(d.qpos[:2] - origin),
            f32(yaw_of(d.xmat[idx.base_body].reshape(3, 3))),
            f32(vel[:2]),
            f32(vel[2]),
            f32(d.qpos[idx.arm_qpos]),
            f32(np.concatenate([grip[:2] - origin, grip[2:]])),
            f32(best),
            np.bool_(self.fallen[i]),
        )


def _pool(pool) -> FullBodies:
    if int(pool) not in FullBodies._live:
        raise RuntimeError(
            "a MujocoCatchEnv is used outside its `with FullBodies(...) as bodies:` block"
        )
    return FullBodies._live[int(pool)]


def _reset_body(pool, xy_m, yaw_rad, origin_xy_m):
    return _pool(pool).reset(xy_m, yaw_rad, origin_xy_m)


def _step_body(reach, pool, *args):
    return _pool(pool).step(reach, *args)


def _catch_error_m(gripper_m: np.ndarray, target_xyz_m: np.ndarray, reach: _Reach) -> float:
    """``sim.env.catch_error_m`` in numpy (world frame)."""
    catch_point = gripper_m - np.array([0.0, 0.0, reach.catch_offset_m])
    return float(np.linalg.norm(target_xyz_m - catch_point))


def _physics(env: FullBodyEnv, i: int, command, target_xy_m: np.ndarray, reach: _Reach, probe):
    """One control step of a full body through the sub-steps while the target passes
    ``target_xy_m`` (n_sub + 1, 2) (world frame). Returns the smallest catch-point error."""
    height = reach.target_height_m
    best = np.inf
    for xy in target_xy_m[:-1]:
        target = np.array([xy[0], xy[1], height])
        best = min(best, _catch_error_m(env.gripper_m(), target, reach))
        near = np.sum((xy - env.data.qpos[:2]) ** 2) <= reach.activation_distance_m**2
        goal = target + np.array([0.0, 0.0, reach.catch_offset_m]) if near else None
        env.set_target(target)
        env.step(command, goal)
        if probe is not None:
            probe(i, env, goal)
    last = np.array([*target_xy_m[-1], height])
    env.set_target(last)
    return min(best, _catch_error_m(env.gripper_m(), last, reach))


@struct.dataclass
class MujocoCatchEnv:
    """The catch task on the full body (the environment protocol, ``sim.api``); made by
    ``FullBodies``, valid inside its ``with`` block. ``observe``, the observation and action
    specs and the reward are the JAX world's; ``info`` adds ``fell``."""

    world: WorldCfg
    pool: jax.Array
    """() int32: its ``FullBodies`` (a leaf, so one compilation serves every pool)."""
    fullbody: FullBodyCfg = struct.field(pytree_node=False)
    reach: _Reach = struct.field(pytree_node=False)

    def reset(self, key: jax.Array) -> FullBodyState:
        state = sim_reset(key, self.world)
        robot = state.robot
        body = io_callback(
            _reset_body,
            jax.ShapeDtypeStruct((), jnp.int32),
            self.pool,
            robot.xy_m,
            robot.yaw_rad,
            state.origin_xy_m,
            ordered=False,
        )
        return _with_body(state, body, jnp.zeros((), bool))

    def step(self, state: FullBodyState, action: jax.Array):
        command, target, target_xy, key, sense_noise = plan_target(state, action, self.world)
        f32 = partial(jax.ShapeDtypeStruct, dtype=jnp.float32)
        shapes = (f32((2,)), f32(()), f32((2,)), f32(()), f32((6,)), f32((3,)), f32(()))
        xy, yaw, vel, yaw_rate, arm_q, gripper, best, fell = io_callback(
            partial(_step_body, self.reach),
            (*shapes, jax.ShapeDtypeStruct((), jnp.bool_)),
            self.pool,
            state.body,
            state.ended,
            command,
            target_xy,
            state.origin_xy_m,
            ordered=False,
        )
        robot = state.robot.replace(
            xy_m=xy,
            yaw_rad=yaw,
            vel_body_mps=vel,
            yaw_rate_rps=yaw_rate,
            arm_q_rad=arm_q,
            gripper_xyz_m=gripper,
        )
        new, obs, reward, done, info = finish_step(
            state, robot, target, best, key, sense_noise, self.world
        )
        info["fell"] = fell
        return _with_body(new, state.body, state.ended | done), obs, reward, done, info

    def observe(self, state: FullBodyState) -> Obs:
        return observe(state, self.world)

    def with_world(self, world: WorldCfg) -> MujocoCatchEnv:
        check_world(world, self.fullbody)
        return self.replace(world=world, reach=_Reach.of(world))

    @property
    def observation_spec(self) -> Spec:
        return JaxCatchEnv(self.world).observation_spec

    @property
    def action_spec(self) -> Spec:
        return JaxCatchEnv(self.world).action_spec
