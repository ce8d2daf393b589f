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
Under ``vmap`` a batch's bodies are stepped in one host call, split over worker processes
(``FullBodies``' ``workers``; ``fullbody.workers``), with the same outcome for any number. The
same key gives the same initial states and target noise as the JAX backend, so rows of both
compare episode for episode. The reduced model's gait noise has no counterpart: the trot's
own ripple is the noise. A robot that falls stays where it fell and catches nothing
(``info["fell"]``); ``info["arm_over_limit"]``: an arm joint has been over its speed or
torque limit after a physics step of the episode. The full body's
constants are ``FullBodyCfg``'s defaults with the world's ``ArmCfg`` (its gait follows
``FullBodyCfg.base``, whatever base the policy was trained on); flat, open ground only.
"""

from __future__ import annotations

import dataclasses
import functools
import itertools
import os
from collections.abc import Callable
from functools import partial

import jax
import jax.numpy as jnp
import numpy as np
from flax import struct
from jax.experimental import io_callback

from dyncatch.fullbody.bodies import Bodies, Reach
from dyncatch.fullbody.config import FullBodyCfg
from dyncatch.fullbody.workers import BodyWorkers
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


def _reach(world: WorldCfg) -> Reach:
    """The world's constants the bodies read, as Python floats (static: the world's numbers
    are traced leaves under ``jit``)."""
    a = world.arm
    return Reach(
        float(world.target.height_m), float(a.catch_offset_m), float(a.activation_distance_m)
    )


def default_workers() -> int:
    """One worker process per core this process may run on."""
    return len(os.sched_getaffinity(0))


class FullBodies:
    """The host side of a full-body evaluation: the bodies ``MujocoCatchEnv``'s states name.
    ``with FullBodies(world) as bodies:`` registers them, and ``bodies.env`` is the
    environment that plays on them.

    ``workers``: processes the bodies are split over (``fullbody.workers``; None: one per
    core, ``default_workers``); 1 keeps them in this process (``bodies.group.envs``). The
    outcomes are the same with any number. ``record``: an episode's index (its body, in the
    order of the first reset) whose state is kept at every 50 Hz step until it ends
    (``recorded()``; ``benchmarks/fullbody_video.py``). ``probe(i, env, goal)``: called after
    every 200 Hz control period of body ``i`` with its ``FullBodyEnv`` and the arm's goal
    (None while stowed; ``benchmarks/fullbody_falls.py``); with workers, each works on a
    copy, and on leaving the block ``probe.merge(copy)`` takes what each copy saw.
    """

    _live: dict[int, FullBodies] = {}
    _ids = itertools.count()

    def __init__(
        self,
        env_or_world: Environment | WorldCfg,
        fullbody: FullBodyCfg | None = None,
        record: int | None = None,
        probe: Callable | None = None,
        workers: int | None = None,
    ):
        world = as_env(env_or_world).world
        self.fullbody = FullBodyCfg(arm=world.arm) if fullbody is None else fullbody
        check_world(world, self.fullbody)
        self.workers = default_workers() if workers is None else int(workers)
        if self.workers < 1:
            raise ValueError(f"workers={workers}: use at least 1 (None: one per core)")
        if probe is not None and self.workers > 1 and not hasattr(probe, "merge"):
            raise ValueError("a probe without a merge method runs in this process: workers=1")
        self.id = next(self._ids)
        self.env = MujocoCatchEnv(world, jnp.int32(self.id), self.fullbody, _reach(world))
        self.record, self.probe = record, probe
        self.group: Bodies | BodyWorkers | None = None
        """The bodies (made at the first reset)."""
        self.count = 0
        """Bodies made so far."""
        self.env_steps = 0
        """The 50 Hz steps simulated on the full bodies, over all episodes."""

    def __enter__(self) -> FullBodies:
        FullBodies._live[self.id] = self
        return self

    def __exit__(self, *exc) -> None:
        del FullBodies._live[self.id]
        if isinstance(self.group, BodyWorkers):
            if self.probe is not None and exc[0] is None:
                for copy in self.group.probes():
                    self.probe.merge(copy)
            self.group.close()

    def recorded(self) -> dict[str, np.ndarray]:
        """The recorded episode as ``qpos`` (T, nq) and ``target_m`` (T, 3) (world frame)."""
        if self.record is None or self.group is None:
            return {}
        return self.group.recorded()

    def peaks(self) -> np.ndarray:
        """(bodies, 2): each body's largest arm joint speed and torque, each over its limit,
        over every physics step of its episode (``FullBodyEnv.arm_driver``)."""
        if self.group is None:
            return np.zeros((0, 2))
        return self.group.peaks(np.arange(self.count))

    def reset(self, xy_m, yaw_rad, origin_xy_m) -> np.ndarray:
        """A new body standing at the reduced robot's pose; its index, () int32."""
        if self.group is None:
            self.group = (
                Bodies(self.fullbody, self.record, self.probe)
                if self.workers == 1
                else BodyWorkers(self.fullbody, self.workers, self.record, self.probe)
            )
        i = self.count
        origin = np.asarray(origin_xy_m, float)
        self.group.reset(i, origin + np.asarray(xy_m, float), float(yaw_rad))
        self.count += 1
        return np.int32(i)

    def step(self, reach: Reach, body, ended, command, target_xy_m, origin_xy_m):
        """One control step of bodies ``body`` (B,) while their targets pass ``target_xy_m``
        (B, n_sub + 1, 2) (each in its state's frame, whose origin is ``origin_xy_m`` (B,
        2)), those whose episode has ended or who have fallen standing still. Returns the
        measured robots (``RobotState``'s fields, in the states' frames), the smallest
        catch-point errors, whether each has fallen and whether its arm has been over a
        limit, each (B, ...)."""
        # The arguments come as arrays of JAX: in float64 numpy, as the bodies compute.
        origin = np.asarray(origin_xy_m, float)
        targets = np.asarray(target_xy_m, float) + origin[:, None, :]
        ids = np.asarray(body).astype(np.int64)
        out = self.group.step(
            reach, ids, np.asarray(ended, bool), np.asarray(command, float), targets
        )
        self.env_steps += out.stepped
        rows = out.rows
        f32 = partial(np.asarray, dtype=np.float32)
        gripper = np.concatenate([rows[:, 12:14] - origin, rows[:, 14:15]], axis=1)
        return (
            f32(rows[:, 0:2] - origin),
            f32(rows[:, 2]),
            f32(rows[:, 3:5]),
            f32(rows[:, 5]),
            f32(rows[:, 6:12]),
            f32(gripper),
            f32(out.best_m),
            out.fell,
            out.over_limit,
        )


def _pool(pool) -> FullBodies:
    if int(pool) not in FullBodies._live:
        raise RuntimeError(
            "a MujocoCatchEnv is used outside its `with FullBodies(...) as bodies:` block"
        )
    return FullBodies._live[int(pool)]


def _reset_body(pool, xy_m, yaw_rad, origin_xy_m):
    return _pool(pool).reset(xy_m, yaw_rad, origin_xy_m)


def _step_bodies(reach, pool, *args):
    return _pool(pool).step(reach, *args)


@functools.cache
def _step_io(reach: Reach):
    """The host step of the bodies as a function of JAX arrays: one call per batch under
    ``vmap`` (``custom_vmap``; a plain ``io_callback`` would call the host once per body, one
    after another), so the host can step a batch's bodies at once over its workers."""

    def call(pool, body, ended, command, target_xy, origin):
        b = body.shape[0]
        f32 = partial(jax.ShapeDtypeStruct, dtype=jnp.float32)
        flag = partial(jax.ShapeDtypeStruct, dtype=jnp.bool_)
        shapes = (
            f32((b, 2)),
            f32((b,)),
            f32((b, 2)),
            f32((b,)),
            f32((b, 6)),
            f32((b, 3)),
            f32((b,)),
            flag((b,)),
            flag((b,)),
        )
        args = (pool, body, ended, command, target_xy, origin)
        return io_callback(partial(_step_bodies, reach), shapes, *args, ordered=False)

    @jax.custom_batching.custom_vmap
    def step(pool, body, ended, command, target_xy, origin):
        one = [a[None] for a in (body, ended, command, target_xy, origin)]
        return tuple(o[0] for o in call(pool, *one))

    @step.def_vmap
    def _batched(axis_size, in_batched, pool, *args):
        if in_batched[0]:
            raise ValueError("a batch of full-body states must share one FullBodies")
        args = [
            a if batched else jnp.broadcast_to(a, (axis_size, *a.shape))
            for a, batched in zip(args, in_batched[1:], strict=True)
        ]
        out = call(pool, *args)
        return out, tuple(True for _ in out)

    return step


@struct.dataclass
class MujocoCatchEnv:
    """The catch task on the full body (the environment protocol, ``sim.api``); made by
    ``FullBodies``, valid inside its ``with`` block. ``observe``, the observation and action
    specs and the reward are the JAX world's; ``info`` adds ``fell``."""

    world: WorldCfg
    pool: jax.Array
    """() int32: its ``FullBodies`` (a leaf, so one compilation serves every pool)."""
    fullbody: FullBodyCfg = struct.field(pytree_node=False)
    reach: Reach = struct.field(pytree_node=False)

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
        xy, yaw, vel, yaw_rate, arm_q, gripper, best, fell, over = _step_io(self.reach)(
            self.pool, state.body, state.ended, command, target_xy, state.origin_xy_m
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
        info["arm_over_limit"] = over
        return _with_body(new, state.body, state.ended | done), obs, reward, done, info

    def observe(self, state: FullBodyState) -> Obs:
        return observe(state, self.world)

    def with_world(self, world: WorldCfg) -> MujocoCatchEnv:
        check_world(world, self.fullbody)
        return self.replace(world=world, reach=_reach(world))

    @property
    def observation_spec(self) -> Spec:
        return JaxCatchEnv(self.world).observation_spec

    @property
    def action_spec(self) -> Spec:
        return JaxCatchEnv(self.world).action_spec
